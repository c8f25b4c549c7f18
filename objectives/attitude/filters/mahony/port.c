/* ---- Mahony's explicit complementary filter (ported from objectives/attitude/filters/mahony/kernel.py) -------- */
void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    real g[3], a[3], m[3], gm;
    int mag_ok, acc_ok = prologue(f, gyr, acc, mag, dt, g, a, m, &mag_ok, &gm);
    real q0_ = f->q[0], q1 = f->q[1], q2 = f->q[2], q3 = f->q[3];
    real kp = f->p.Kp, ki = f->p.Ki, h, n0, n1, n2, n3, r;
    real gx = g[0], gy = g[1], gz = g[2], ix = f->b[0], iy = f->b[1], iz = f->b[2];
    if (acc_ok) {
        real ax = a[0], ay = a[1], az = a[2], vx, vy, vz, ex, ey, ez;
        /* predicted gravity v_hat = R(q)^T (0, 0, 1); omega_mes = a x v_hat */
        vx = 2.0 * (q1 * q3 - q0_ * q2);
        vy = 2.0 * (q0_ * q1 + q2 * q3);
        vz = q0_ * q0_ - q1 * q1 - q2 * q2 + q3 * q3;
        ex = ay * vz - az * vy;
        ey = az * vx - ax * vz;
        ez = ax * vy - ay * vx;
        if (mag_ok) {
            real mx = m[0], my = m[1], mz = m[2], hh[3], bx, bz, wx, wy, wz;
            /* b = (|h_xy|, 0, h_z), h = q m q*; w_hat = R(q)^T b; + m x w_hat (scaled by the rejection gain) */
            rotate_sensor_to_earth(f->q, mx, my, mz, hh);
            bx = SQRT(hh[0] * hh[0] + hh[1] * hh[1]);
            bz = hh[2];
            wx = 2.0 * gm * (bx * (0.5 - q2 * q2 - q3 * q3) + bz * (q1 * q3 - q0_ * q2));
            wy = 2.0 * gm * (bx * (q1 * q2 - q0_ * q3) + bz * (q0_ * q1 + q2 * q3));
            wz = 2.0 * gm * (bx * (q0_ * q2 + q1 * q3) + bz * (0.5 - q1 * q1 - q2 * q2));
            ex += my * wz - mz * wy;
            ey += mz * wx - mx * wz;
            ez += mx * wy - my * wx;
        }
        if (ki > 0.0) {
            ix += ki * ex * dt;
            iy += ki * ey * dt;
            iz += ki * ez * dt;
        } else {
            ix = 0.0;
            iy = 0.0;
            iz = 0.0;
        }
        gx += kp * ex;
        gy += kp * ey;
        gz += kp * ez;
    }
    h = 0.5 * dt;
    gx = (gx + ix) * h;
    gy = (gy + iy) * h;
    gz = (gz + iz) * h;
    n0 = q0_ + (-q1 * gx - q2 * gy - q3 * gz);
    n1 = q1 + (q0_ * gx + q2 * gz - q3 * gy);
    n2 = q2 + (q0_ * gy - q1 * gz + q3 * gx);
    n3 = q3 + (q0_ * gz + q1 * gy - q2 * gx);
    r = 1.0 / SQRT(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3);
    f->q[0] = n0 * r;
    f->q[1] = n1 * r;
    f->q[2] = n2 * r;
    f->q[3] = n3 * r;
    f->b[0] = ix;
    f->b[1] = iy;
    f->b[2] = iz;
}

/* the rest bias less the integral, b = -I (the kernel's bias output) */
void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    int i;
    for (i = 0; i < 3; i++)
        b[i] = (f->p.rest_bias ? f->rs[8 + i] : 0.0) - f->b[i];
}
