/* ---- Madgwick's filter (ported from objectives/attitude/filters/madgwick/kernel.py, report eqs. 11-13, 25-49) */
void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    real g[3], a[3], m[3], gm;
    int mag_ok, acc_ok = prologue(f, gyr, acc, mag, dt, g, a, m, &mag_ok, &gm);
    real q0_ = f->q[0], q1 = f->q[1], q2 = f->q[2], q3 = f->q[3];
    real beta = f->p.beta, zeta = f->p.zeta, k = f->p.field_k;
    real gx = g[0] - f->b[0], gy = g[1] - f->b[1], gz = g[2] - f->b[2];
    real qd0, qd1, qd2, qd3, n0, n1, n2, n3, r;
    /* eq. 12 */
    qd0 = 0.5 * (-q1 * gx - q2 * gy - q3 * gz);
    qd1 = 0.5 * (q0_ * gx + q2 * gz - q3 * gy);
    qd2 = 0.5 * (q0_ * gy - q1 * gz + q3 * gx);
    qd3 = 0.5 * (q0_ * gz + q1 * gy - q2 * gx);
    if (acc_ok) {
        real ax = a[0], ay = a[1], az = a[2], f1, f2, f3, s0, s1, s2, s3, sn;
        /* eq. 25 and eq. 34 with J_g of eq. 26 */
        f1 = 2.0 * (q1 * q3 - q0_ * q2) - ax;
        f2 = 2.0 * (q0_ * q1 + q2 * q3) - ay;
        f3 = 1.0 - 2.0 * (q1 * q1 + q2 * q2) - az;
        s0 = -2.0 * q2 * f1 + 2.0 * q1 * f2;
        s1 = 2.0 * q3 * f1 + 2.0 * q0_ * f2 - 4.0 * q1 * f3;
        s2 = -2.0 * q0_ * f1 + 2.0 * q3 * f2 - 4.0 * q2 * f3;
        s3 = 2.0 * q1 * f1 + 2.0 * q2 * f2;
        if (mag_ok) {
            real mx = m[0], my = m[1], mz = m[2], h[3], tbx, tbz, e1, e2, e3;
            /* eqs. 45-46 (paper: k = 2; the 2010 C code: k = 1), eq. 29, eq. 34 with J_b of eq. 30 */
            rotate_sensor_to_earth(f->q, mx, my, mz, h);
            tbx = k * SQRT(h[0] * h[0] + h[1] * h[1]);
            tbz = k * h[2];
            e1 = tbx * (0.5 - q2 * q2 - q3 * q3) + tbz * (q1 * q3 - q0_ * q2) - mx;
            e2 = tbx * (q1 * q2 - q0_ * q3) + tbz * (q0_ * q1 + q2 * q3) - my;
            e3 = tbx * (q0_ * q2 + q1 * q3) + tbz * (0.5 - q1 * q1 - q2 * q2) - mz;
            if (gm != 1.0) {
                e1 *= gm;
                e2 *= gm;
                e3 *= gm;
            }
            s0 += -tbz * q2 * e1 + (-tbx * q3 + tbz * q1) * e2 + tbx * q2 * e3;
            s1 += tbz * q3 * e1 + (tbx * q2 + tbz * q0_) * e2 + (tbx * q3 - 2.0 * tbz * q1) * e3;
            s2 += ((-2.0 * tbx * q2 - tbz * q0_) * e1 + (tbx * q1 + tbz * q3) * e2 + (tbx * q0_ - 2.0 * tbz * q2) * e3);
            s3 += (-2.0 * tbx * q3 + tbz * q1) * e1 + (-tbx * q0_ + tbz * q2) * e2 + tbx * q1 * e3;
        }
        sn = s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3;
        if (sn > 0.0 && sn < (real)INFINITY) {
            r = 1.0 / SQRT(sn);
            s0 *= r;
            s1 *= r;
            s2 *= r;
            s3 *= r;
            /* eqs. 42-43 */
            qd0 -= beta * s0;
            qd1 -= beta * s1;
            qd2 -= beta * s2;
            qd3 -= beta * s3;
            if (zeta != 0.0) {
                /* eqs. 47-48 */
                real c = 2.0 * zeta * dt;
                f->b[0] += c * (q0_ * s1 - q1 * s0 - q2 * s3 + q3 * s2);
                f->b[1] += c * (q0_ * s2 + q1 * s3 - q2 * s0 - q3 * s1);
                f->b[2] += c * (q0_ * s3 - q1 * s2 + q2 * s1 - q3 * s0);
            }
        }
    }
    /* eq. 13 and normalisation */
    n0 = q0_ + qd0 * dt;
    n1 = q1 + qd1 * dt;
    n2 = q2 + qd2 * dt;
    n3 = q3 + qd3 * dt;
    r = 1.0 / SQRT(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3);
    f->q[0] = n0 * r;
    f->q[1] = n1 * r;
    f->q[2] = n2 * r;
    f->q[3] = n3 * r;
}

/* the bias estimate omega_b plus the rest bias (the kernel's bias output) */
void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    int i;
    for (i = 0; i < 3; i++)
        b[i] = f->b[i] + (f->p.rest_bias ? f->rs[8 + i] : 0.0);
}
