/* ---- sine and cosine without libm's sin/cos ------------------------------------------------------ */
/* sin and cos from a Taylor series on |a| <= 0.5 and angle doubling (no libm sin/cos) */
static void sincos_(real a, real *s, real *c)
{
    int n = 0, i;
    real a2, sn, cs, t;
    while (fabs(a) > 0.5 && n < 60) {
        a *= 0.5;
        n++;
    }
    a2 = a * a;
    sn = a * (1.0 - a2 / 6.0 * (1.0 - a2 / 20.0 * (1.0 - a2 / 42.0 * (1.0 - a2 / 72.0 * (1.0 - a2 / 110.0
         * (1.0 - a2 / 156.0 * (1.0 - a2 / 210.0)))))));
    cs = 1.0 - a2 / 2.0 * (1.0 - a2 / 12.0 * (1.0 - a2 / 30.0 * (1.0 - a2 / 56.0 * (1.0 - a2 / 90.0
         * (1.0 - a2 / 132.0 * (1.0 - a2 / 182.0 * (1.0 - a2 / 240.0)))))));
    for (i = 0; i < n; i++) {
        t = 2.0 * sn * cs;
        cs = 1.0 - 2.0 * sn * sn;
        sn = t;
    }
    *s = sn;
    *c = cs;
}

