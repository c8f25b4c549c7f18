/* ---- the toy filter (ported from tests/attitude/toy_filter/kernel.py, same operations) ----------------- */
static void toy_step(real *q, real wx, real wy, real wz, real h)
{
    real n0 = q[0] + h * (-q[1] * wx - q[2] * wy - q[3] * wz);
    real n1 = q[1] + h * (q[0] * wx + q[2] * wz - q[3] * wy);
    real n2 = q[2] + h * (q[0] * wy - q[1] * wz + q[3] * wx);
    real n3 = q[3] + h * (q[0] * wz + q[1] * wy - q[2] * wx);
    real r = 1.0 / SQRT(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3);
    q[0] = n0 * r;
    q[1] = n1 * r;
    q[2] = n2 * r;
    q[3] = n3 * r;
}

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    int i;
    f->p = *p;
    f->started = 0;
    for (i = 0; i < X_LEN; i++)
        f->q[i] = i == 0 ? 1.0 : 0.0;
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    real *q = f->q, wx = gyr[0], wy = gyr[1], wz = gyr[2], ax = acc[0], ay = acc[1], az = acc[2], an, vx, vy, vz;
    real gain = f->p.gain;
    if (!f->started) { /* the first sample's orientation, with the magnetometer when given (the model's start) */
        start_quaternion(f->p.init, f->p.q0, acc, mag, q);
        f->started = 1;
    }
    an = SQRT(ax * ax + ay * ay + az * az);
    if (an > 0.0) {
        ax = ax / an;
        ay = ay / an;
        az = az / an;
        vx = 2.0 * (q[1] * q[3] - q[0] * q[2]);
        vy = 2.0 * (q[0] * q[1] + q[2] * q[3]);
        vz = q[0] * q[0] - q[1] * q[1] - q[2] * q[2] + q[3] * q[3];
        wx += gain * (ay * vz - az * vy);
        wy += gain * (az * vx - ax * vz);
        wz += gain * (ax * vy - ay * vx);
    }
    if (f->p.step == PFX_STEP_HALF) {
        toy_step(q, wx, wy, wz, 0.25 * dt);
        toy_step(q, wx, wy, wz, 0.25 * dt);
    } else {
        toy_step(q, wx, wy, wz, 0.5 * dt);
    }
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    to_output(f->q, q);
}

void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    from_output(q, f->q);
    f->started = 1;
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    (void)f;
    b[0] = b[1] = b[2] = 0.0;
}
