/* ---- sine and cosine without libm's sin/cos ------------------------------------------------------ */
/* sin(a), cos(a): a reduced by the nearest multiple k of pi/2 (pi/2 split in two parts, as fdlibm's
   pio2_1 + pio2_1t, so the reduction is exact to ~1e-20 for the angles filters see), then Taylor series on
   |r| <= pi/4 (truncation below 3e-18) and the quadrant's swap and signs */
static void sincos_(real a, real *s, real *c)
{
    real k, r, r2, sn, cs;
    long q;
    if (!(fabs(a) < 1.0e9)) { /* not a filter's angle (inf, NaN or huge): NaN out, as libm's sin/cos give */
        *s = *c = a - a;
        return;
    }
    k = a * 0.63661977236758134308; /* 2/pi */
    k = k >= 0.0 ? (real)(long)(k + 0.5) : -(real)(long)(0.5 - k);
    r = (a - k * 1.57079632673412561417) - k * 6.07710050650619224932e-11;
    r2 = r * r;
    sn = r * (1.0 - r2 * (1.0 / 6.0) * (1.0 - r2 * (1.0 / 20.0) * (1.0 - r2 * (1.0 / 42.0) * (1.0 - r2 * (1.0 / 72.0) * (1.0 - r2 * (1.0 / 110.0)
         * (1.0 - r2 * (1.0 / 156.0) * (1.0 - r2 * (1.0 / 210.0) * (1.0 - r2 * (1.0 / 272.0)))))))));
    cs = 1.0 - r2 * (1.0 / 2.0) * (1.0 - r2 * (1.0 / 12.0) * (1.0 - r2 * (1.0 / 30.0) * (1.0 - r2 * (1.0 / 56.0) * (1.0 - r2 * (1.0 / 90.0)
         * (1.0 - r2 * (1.0 / 132.0) * (1.0 - r2 * (1.0 / 182.0) * (1.0 - r2 * (1.0 / 240.0) * (1.0 - r2 * (1.0 / 306.0)))))))));
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
