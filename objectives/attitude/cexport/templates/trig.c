/* ---- sine and cosine without libm's sin/cos (or with them: PFX_LIBM_TRIG) ------------------------------ */
#ifdef PFX_LIBM_TRIG
/* compiled with -DPFX_LIBM_TRIG: libm's sin and cos, the numba kernel's own (with the same libm the C then
   computes what the kernel computes, operation for operation; libm's sin and cos cost more than the series) */
static void sincos_(real a, real *s, real *c)
{
    *s = SIN(a);
    *c = COS(a);
}
#else
/* sin(a), cos(a): a reduced by the nearest multiple k of pi/2 (pi/2 split in two parts, as fdlibm's
   pio2_1 + pio2_1t, so the reduction is exact to ~1e-20 for the angles filters see), then fdlibm's minimax
   polynomials on |r| <= pi/4 and the quadrant's swap and signs (within 1 ulp of libm's sin and cos) */
static void sincos_(real a, real *s, real *c)
{
    real k, r, r2, sn, cs;
    long q;
    if (!(fabs(a) < 1.0e9)) { /* not a filter's angle (inf, NaN or huge): NaN out, as libm's sin/cos give */
        *s = *c = a - a;
        return;
    }
    if (fabs(a) <= 0.78539816339744830962) { /* |a| <= pi/4: no reduction */
        k = 0.0;
        r = a;
    } else {
        k = a * 0.63661977236758134308; /* 2/pi */
        k = k >= 0.0 ? (real)(long)(k + 0.5) : -(real)(long)(0.5 - k);
        r = (a - k * 1.57079632673412561417) - k * 6.07710050650619224932e-11;
    }
    r2 = r * r;
    /* minimax polynomials of fdlibm's __kernel_sin and __kernel_cos on |r| <= pi/4 */
    sn = r + r * r2 * (-1.66666666666666324348e-01 + r2 * (8.33333333332248946124e-03
         + r2 * (-1.98412698298579493134e-04 + r2 * (2.75573137070700676789e-06
         + r2 * (-2.50507602534068634195e-08 + r2 * 1.58969099521155010221e-10)))));
    cs = 1.0 - 0.5 * r2 + r2 * r2 * (4.16666666666666019037e-02 + r2 * (-1.38888888888741095749e-03
         + r2 * (2.48015872894767294178e-05 + r2 * (-2.75573143513906633035e-07
         + r2 * (2.08757232129817482790e-09 + r2 * -1.13596475577881948265e-11)))));
    q = (long)k & 3;
    if (q == 0) {
        *s = sn;
        *c = cs;
    } else if (q == 1) {
        *s = cs;
        *c = -sn;
    } else if (q == 2) {
        *s = -sn;
        *c = -cs;
    } else {
        *s = -cs;
        *c = sn;
    }
}
#endif
