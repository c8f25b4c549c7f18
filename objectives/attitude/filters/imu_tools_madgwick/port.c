/* ---- imu_tools_madgwick: imu_filter_madgwick's filter (Madgwick 2010 report eqs. 12-13, 20-21, 25-34, 42-49, the
   node's world frames and stateless start); ported from objectives/attitude/filters/imu_tools_madgwick/kernel.py
   (the layout S is the enum above) */

/* J^T f of eqs. 20-21 for the earth reference d and the measurement s (kernel.py: _grad) */
static void itm_grad(const real q[4], real dx, real dy, real dz, real sx, real sy, real sz, real g[4])
{
    real q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3], f1, f2, f3;
    f1 = 2.0 * dx * (0.5 - q2 * q2 - q3 * q3) + 2.0 * dy * (q0 * q3 + q1 * q2) + 2.0 * dz * (q1 * q3 - q0 * q2) - sx;
    f2 = 2.0 * dx * (q1 * q2 - q0 * q3) + 2.0 * dy * (0.5 - q1 * q1 - q3 * q3) + 2.0 * dz * (q0 * q1 + q2 * q3) - sy;
    f3 = 2.0 * dx * (q0 * q2 + q1 * q3) + 2.0 * dy * (q2 * q3 - q0 * q1) + 2.0 * dz * (0.5 - q1 * q1 - q2 * q2) - sz;
    g[0] = ((2.0 * dy * q3 - 2.0 * dz * q2) * f1 + (-2.0 * dx * q3 + 2.0 * dz * q1) * f2
            + (2.0 * dx * q2 - 2.0 * dy * q1) * f3);
    g[1] = ((2.0 * dy * q2 + 2.0 * dz * q3) * f1 + (2.0 * dx * q2 - 4.0 * dy * q1 + 2.0 * dz * q0) * f2
            + (2.0 * dx * q3 - 2.0 * dy * q0 - 4.0 * dz * q1) * f3);
    g[2] = ((-4.0 * dx * q2 + 2.0 * dy * q1 - 2.0 * dz * q0) * f1 + (2.0 * dx * q1 + 2.0 * dz * q3) * f2
            + (2.0 * dx * q0 + 2.0 * dy * q3 - 4.0 * dz * q2) * f3);
    g[3] = ((-4.0 * dx * q3 + 2.0 * dy * q0 + 2.0 * dz * q1) * f1 + (-2.0 * dx * q0 - 4.0 * dy * q3 + 2.0 * dz * q2) * f2
            + (2.0 * dx * q1 + 2.0 * dy * q2) * f3);
}

/* the node's stateless orientation from gravity a and a northward reference e; 0 when |e x a| < 1e-7 */
static int itm_stateless(int frame, const real a_in[3], const real e[3], real q[4])
{
    real h[3], a[3], m[3], R[3][3], nh, na;
    int i;
    cross3(e, a_in, h);
    nh = norm3(h);
    if (!(nh >= 1e-7))
        return 0;
    na = norm3(a_in);
    for (i = 0; i < 3; i++) {
        h[i] /= nh;
        a[i] = a_in[i] / na;
    }
    cross3(a, h, m);
    for (i = 0; i < 3; i++) {
        if (frame == PFX_WORLD_FRAME_NED) {
            R[0][i] = m[i]; R[1][i] = h[i]; R[2][i] = -a[i];
        } else if (frame == PFX_WORLD_FRAME_NWU) {
            R[0][i] = m[i]; R[1][i] = -h[i]; R[2][i] = a[i];
        } else {
            R[0][i] = h[i]; R[1][i] = m[i]; R[2][i] = a[i];
        }
    }
    quat_from_rotmat(R, q);
    return 1;
}

static void node_given(PFX_filter *f, const real q[4])
{
    real n = SQRT(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int i;
    for (i = 0; i < 4; i++) f->s[S_Q + i] = q[i] / n;
    f->s[S_PHASE] = 2.0;
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    real *s = f->s, q[4], a[3], m[3] = {0.0, 0.0, 0.0}, g[3], st[4], t[4], d[4], n0, n1, n2, n3, r, step = dt;
    real zeta = f->p.zeta, gain = f->p.gain, sgn = f->p.world_frame == PFX_WORLD_FRAME_NED ? -1.0 : 1.0;
    int i, marg = 0, frame = f->p.world_frame;
    for (i = 0; i < 3; i++) {
        a[i] = acc[i];
        g[i] = gyr[i];
    }
    if (mag != 0 && f->p.use_mag) {
        m[0] = mag[0] - f->p.mag_bias_x;
        m[1] = mag[1] - f->p.mag_bias_y;
        m[2] = mag[2] - f->p.mag_bias_z;
        marg = finite3(m) && !(m[0] == 0.0 && m[1] == 0.0 && m[2] == 0.0);
    }
    if (s[S_PHASE] == 2.0) { /* a given start orientation: the start sample is updated with dt = 0 */
        s[S_PHASE] = 1.0;
        step = 0.0;
    } else if (s[S_PHASE] == 0.0) {
        real e[3] = {0.0, 0.0, 0.0}, q0[4];
        if (f->p.init == 1) { /* BROAD's quatFromAccMag */
            start_quaternion(1, f->p.q0, acc, marg ? m : 0, q0);
        } else {
            if (marg) {
                e[0] = m[0]; e[1] = m[1]; e[2] = m[2];
            } else if (fabs(a[0]) > 0.1 || fabs(a[1]) > 0.1) {
                e[0] = a[1]; e[1] = a[0];
            } else if (fabs(a[2]) > 0.1) {
                e[1] = a[2]; e[2] = a[1];
            }
            if (!itm_stateless(frame, a, e, q0))
                return; /* no start yet: the quaternion reads NaN */
        }
        for (i = 0; i < 4; i++) s[S_Q + i] = q0[i];
        s[S_PHASE] = 1.0;
        step = 0.0;
    }
    for (i = 0; i < 4; i++) q[i] = s[S_Q + i];
    if (!(a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0)) {
        real na = 1.0 / SQRT(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), sn;
        for (i = 0; i < 3; i++) a[i] *= na;
        itm_grad(q, 0.0, 0.0, sgn, a[0], a[1], a[2], st); /* eq. 25 */
        if (marg) {
            real nm = 1.0 / SQRT(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]), h[3], bxy;
            for (i = 0; i < 3; i++) m[i] *= nm;
            /* eq. 45: h = q m q*; eq. 46: b = (|h_xy|, 0, h_z) on the frame's north axis */
            h[0] = ((1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3])) * m[0] + 2.0 * (q[1] * q[2] - q[0] * q[3]) * m[1]
                    + 2.0 * (q[1] * q[3] + q[0] * q[2]) * m[2]);
            h[1] = (2.0 * (q[1] * q[2] + q[0] * q[3]) * m[0] + (1.0 - 2.0 * (q[1] * q[1] + q[3] * q[3])) * m[1]
                    + 2.0 * (q[2] * q[3] - q[0] * q[1]) * m[2]);
            h[2] = (2.0 * (q[1] * q[3] - q[0] * q[2]) * m[0] + 2.0 * (q[2] * q[3] + q[0] * q[1]) * m[1]
                    + (1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2])) * m[2]);
            bxy = SQRT(h[0] * h[0] + h[1] * h[1]);
            if (frame == PFX_WORLD_FRAME_ENU)
                itm_grad(q, 0.0, bxy, h[2], m[0], m[1], m[2], t);
            else
                itm_grad(q, bxy, 0.0, h[2], m[0], m[1], m[2], t);
            for (i = 0; i < 4; i++) st[i] += t[i];
        }
        sn = SQRT(st[0] * st[0] + st[1] * st[1] + st[2] * st[2] + st[3] * st[3]);
        if (sn > 0.0)
            for (i = 0; i < 4; i++) st[i] /= sn;
        if (marg) { /* eqs. 47-49 */
            s[S_WB] += 2.0 * (q[0] * st[1] - q[1] * st[0] - q[2] * st[3] + q[3] * st[2]) * step * zeta;
            s[S_WB + 1] += 2.0 * (q[0] * st[2] + q[1] * st[3] - q[2] * st[0] - q[3] * st[1]) * step * zeta;
            s[S_WB + 2] += 2.0 * (q[0] * st[3] - q[1] * st[2] + q[2] * st[1] - q[3] * st[0]) * step * zeta;
            for (i = 0; i < 3; i++) g[i] -= s[S_WB + i];
        }
        /* eq. 12, eqs. 42-43 */
        d[0] = 0.5 * (-q[1] * g[0] - q[2] * g[1] - q[3] * g[2]) - gain * st[0];
        d[1] = 0.5 * (q[0] * g[0] + q[2] * g[2] - q[3] * g[1]) - gain * st[1];
        d[2] = 0.5 * (q[0] * g[1] - q[1] * g[2] + q[3] * g[0]) - gain * st[2];
        d[3] = 0.5 * (q[0] * g[2] + q[1] * g[1] - q[2] * g[0]) - gain * st[3];
    } else {
        d[0] = 0.5 * (-q[1] * g[0] - q[2] * g[1] - q[3] * g[2]);
        d[1] = 0.5 * (q[0] * g[0] + q[2] * g[2] - q[3] * g[1]);
        d[2] = 0.5 * (q[0] * g[1] - q[1] * g[2] + q[3] * g[0]);
        d[3] = 0.5 * (q[0] * g[2] + q[1] * g[1] - q[2] * g[0]);
    }
    /* eq. 13 and normalisation */
    n0 = q[0] + d[0] * step;
    n1 = q[1] + d[1] * step;
    n2 = q[2] + d[2] * step;
    n3 = q[3] + d[3] * step;
    r = 1.0 / SQRT(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3);
    s[S_Q] = n0 * r;
    s[S_Q + 1] = n1 * r;
    s[S_Q + 2] = n2 * r;
    s[S_Q + 3] = n3 * r;
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    int i;
    if (f->s[S_PHASE] == 0.0) { /* not started: no orientation yet */
        for (i = 0; i < 4; i++) q[i] = NAN;
        return;
    }
    to_output(f->s + S_Q, q);
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    int i;
    for (i = 0; i < 3; i++) b[i] = f->s[S_WB + i];
}
