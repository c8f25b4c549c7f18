/* ---- the thesis's 2-state tilt Kalman filter (ported from objectives/attitude/filters/_kf1d_kernels.py,
        thesis eqs. 3.9-3.13, 3.17): the tilt about the sensor y axis from gyr[1], acc[0] and acc[2] ------ */
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

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    f->p = *p;
    f->started = 0;
    f->th = 0.0;
    f->b = 0.0;
    f->p00 = p->p0_theta;
    f->p01 = 0.0;
    f->p11 = p->p0_bias;
    f->prev_gyr = 0.0;
    f->dt_s = p->dt_s;
}

/* the tilt of a start quaternion (working frame ENU) from its up vector: kf1d.tilt_from_quat */
static real tilt_from_quat(const real q[4], real s)
{
    real w = q[0], x = q[1], y = q[2], z = q[3];
    real ux = 2.0 * (x * z - w * y), uz = w * w - x * x - y * y + z * z;
    return ATAN2(-s * ux, s * uz);
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    const PFX_params *pp = &f->p;
    real s = pp->up_sign, m00, m01, m11, z, res, sk, g0, g1;
    if (f->started < 2) { /* sample 0 is the initial state (theta0, 0), P0 */
        if (!f->started) {
            real q[4];
            start_quaternion(pp->init, pp->q0, acc, pp->use_mag ? mag : 0, q);
            f->th = tilt_from_quat(q, s);
        }
        f->prev_gyr = gyr[1];
        f->started = 2;
        return;
    }
    f->dt_s = dt;
    /* time update (3.11) with the previous gyro sample */
    f->th += dt * (f->prev_gyr - f->b);
    m00 = f->p00 - 2.0 * dt * f->p01 + dt * dt * f->p11 + pp->q00;
    m01 = f->p01 - dt * f->p11;
    m11 = f->p11 + pp->q11;
    f->prev_gyr = gyr[1];
    /* measurement update (3.12, 3.13) with the accelerometer angle (3.6), residual wrapped */
    z = ATAN2(-s * acc[0], s * acc[2]);
    res = z - f->th;
    if (res > PI_ || res < -PI_)
        res -= TWO_PI_ * floor_((res + PI_) / TWO_PI_);
    sk = m00 + pp->rho * 1.0;
    g0 = m00 / sk;
    g1 = m01 / sk;
    f->th += g0 * res;
    f->b += g1 * res;
    f->p00 = (1.0 - g0) * m00;
    f->p01 = (1.0 - g0) * m01;
    f->p11 = m11 - g1 * m01;
}

/* the rotation about y by the tilt, (cos(theta/2), 0, sin(theta/2), 0), in the frame of up_sign */
void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    real sn, cs;
    sincos_(0.5 * f->th, &sn, &cs);
    q[0] = cs;
    q[1] = 0.0;
    q[2] = sn;
    q[3] = 0.0;
}

/* start from a known orientation (its tilt about y) instead of the first sample's */
void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    from_output(q, w);
    f->th = tilt_from_quat(w, f->p.up_sign);
    f->started = 1;
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    b[0] = 0.0;
    b[1] = f->b;
    b[2] = 0.0;
    (void)to_output;
}
