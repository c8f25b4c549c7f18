/* ---- angles without libm: wrapping to [-pi, pi) for the ports that carry angles ----------------------- */
#define TWO_PI_ (2.0 * PI_)

/* floor without libm (exact for |x| < 2^52; larger doubles are integers already) */
static real floor_(real x)
{
    real t;
    if (!(fabs(x) < 4.0e15))
        return x;
    t = (real)(long long)x;
    return t > x ? t - 1.0 : t;
}
