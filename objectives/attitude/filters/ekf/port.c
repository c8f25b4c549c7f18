/* ---- quaternion EKF with TRIAD and robust blocks (ported from objectives/attitude/filters/ekf/kernel.py,
        FAEKF paper eqs. 11-22, 36) -------------------------------------------------------------------- */
static void set_rate(PFX_filter *f, real dt)
{
    robust_rate(f, dt, 0.5 * f->p.g / 9.81, 2.0);
}

/* time update (eqs. 16, 20, 21) with the gyro sample w: kernel._predict */
static void predict(PFX_filter *f, const real *w_in, real h)
{
    real *x = f->x, (*P)[X_LEN] = f->P, A[4][4], B[4][3], T[4][X_LEN];
    real q0 = x[0], q1 = x[1], q2 = x[2], q3 = x[3];
    real wx = w_in[0] - x[4], wy = w_in[1] - x[5], wz = w_in[2] - x[6], ca, sa, hx, hy, hz;
    int r, c;
    if (f->p.integration == PFX_INTEGRATION_EXACT) {
        real wn = SQRT(wx * wx + wy * wy + wz * wz), ang = h * wn, sn;
        sincos_(ang, &sn, &ca);
        sa = h * (ang > 1e-6 ? sn / ang : 1.0 - ang * ang / 6.0);
    } else {
        ca = 1.0;
        sa = h;
    }
    hx = sa * wx;
    hy = sa * wy;
    hz = sa * wz;
    A[0][0] = ca; A[0][1] = -hx; A[0][2] = -hy; A[0][3] = -hz;
    A[1][0] = hx; A[1][1] = ca; A[1][2] = hz; A[1][3] = -hy;
    A[2][0] = hy; A[2][1] = -hz; A[2][2] = ca; A[2][3] = hx;
    A[3][0] = hz; A[3][1] = hy; A[3][2] = -hx; A[3][3] = ca;
    B[0][0] = h * q1; B[0][1] = h * q2; B[0][2] = h * q3;
    B[1][0] = -h * q0; B[1][1] = h * q3; B[1][2] = -h * q2;
    B[2][0] = -h * q3; B[2][1] = -h * q0; B[2][2] = h * q1;
    B[3][0] = h * q2; B[3][1] = -h * q1; B[3][2] = -h * q0;
    x[0] = ca * q0 - hx * q1 - hy * q2 - hz * q3;
    x[1] = ca * q1 + hx * q0 + hz * q2 - hy * q3;
    x[2] = ca * q2 + hy * q0 - hz * q1 + hx * q3;
    x[3] = ca * q3 + hz * q0 + hy * q1 - hx * q2;
    for (r = 0; r < 4; r++)
        for (c = 0; c < X_LEN; c++)
            T[r][c] = (A[r][0] * P[0][c] + A[r][1] * P[1][c] + A[r][2] * P[2][c] + A[r][3] * P[3][c]
                       + B[r][0] * P[4][c] + B[r][1] * P[5][c] + B[r][2] * P[6][c]);
    for (r = 0; r < 4; r++) {
        for (c = r; c < 4; c++) {
            real s = (T[r][0] * A[c][0] + T[r][1] * A[c][1] + T[r][2] * A[c][2] + T[r][3] * A[c][3]
                      + T[r][4] * B[c][0] + T[r][5] * B[c][1] + T[r][6] * B[c][2]);
            P[r][c] = s;
            P[c][r] = s;
        }
        P[r][r] += f->p.q_q;
        for (c = 4; c < X_LEN; c++) {
            P[r][c] = T[r][c];
            P[c][r] = T[r][c];
        }
    }
    for (r = 4; r < X_LEN; r++)
        P[r][r] += f->p.q_w;
}

/* predicted north in sensor coordinates (first row of R(q), eq. 3) */
static void north_(const real *x, real n[3])
{
    n[0] = x[0] * x[0] + x[1] * x[1] - x[2] * x[2] - x[3] * x[3];
    n[1] = 2.0 * (x[1] * x[2] - x[0] * x[3]);
    n[2] = 2.0 * (x[1] * x[3] + x[0] * x[2]);
}

/* block (a)'s gain at the predicted attitude (1 until a first reference): kernel._mag_gain */
static real mag_gain(PFX_filter *f, const real n[3], real mx, real my, real mz)
{
    const real *x = f->x, *rs = f->rs;
    real p0 = x[0], p1 = x[1], p2 = x[2], p3 = x[3], ex, ey, ez, gl, gm;
    ex = n[0] * mx + n[1] * my + n[2] * mz;
    ey = 2.0 * (p1 * p2 + p0 * p3) * mx + (p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3) * my + 2.0 * (p2 * p3 - p0 * p1) * mz;
    ez = 2.0 * (p1 * p3 - p0 * p2) * mx + 2.0 * (p2 * p3 + p0 * p1) * my + (p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3) * mz;
    gl = SQRT(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2]);
    gm = mag_dist_update(f->ms, f->mc, ex, ey, -ez, gl);
    return f->ms[0] == 0.0 ? 1.0 : gm;
}

/* the TRIAD's second vector for a gain gm < 1: kernel._blend_north */
static void blend_north(real ax, real ay, real az, real gm, const real n[3], real m[3])
{
    real an = SQRT(ax * ax + ay * ay + az * az), ux = ax / an, uy = ay / an, uz = az / an;
    real dm = m[0] * ux + m[1] * uy + m[2] * uz, hx = m[0] - dm * ux, hy = m[1] - dm * uy, hz = m[2] - dm * uz;
    real hn = SQRT(hx * hx + hy * hy + hz * hz);
    real dn = n[0] * ux + n[1] * uy + n[2] * uz, gx = n[0] - dn * ux, gy = n[1] - dn * uy, gz = n[2] - dn * uz;
    real gn = SQRT(gx * gx + gy * gy + gz * gz);
    if (hn > 0.0 && gn > 0.0) {
        m[0] = gm * hx / hn + (1.0 - gm) * gx / gn;
        m[1] = gm * hy / hn + (1.0 - gm) * gy / gn;
        m[2] = gm * hz / hn + (1.0 - gm) * gz / gn;
    }
}

/* TRIAD quaternion (eqs. 11-14, NED, Shepperd branches); 0 when acc x mag vanishes: conversions._triad_into */
static int triad(real ax, real ay, real az, real mx, real my, real mz, real z[4])
{
    real na = SQRT(ax * ax + ay * ay + az * az), cx = ay * mz - az * my, cy = az * mx - ax * mz, cz = ax * my - ay * mx;
    real nc = SQRT(cx * cx + cy * cy + cz * cz), r1x, r1y, r1z, r2x, r2y, r2z, r3x, r3y, r3z, tr, s, t;
    real R00, R01, R02, R10, R11, R12, R20, R21, R22;
    if (!(na > 0.0 && nc > 1e-12 * na * SQRT(mx * mx + my * my + mz * mz)) || !(nc < (real)INFINITY))
        return 0;
    r1x = ax / na; r1y = ay / na; r1z = az / na;
    r2x = cx / nc; r2y = cy / nc; r2z = cz / nc;
    r3x = r1y * r2z - r1z * r2y;
    r3y = r1z * r2x - r1x * r2z;
    r3z = r1x * r2y - r1y * r2x;
    R00 = -r3x; R01 = -r3y; R02 = -r3z;
    R10 = -r2x; R11 = -r2y; R12 = -r2z;
    R20 = -r1x; R21 = -r1y; R22 = -r1z;
    tr = R00 + R11 + R22;
    if (tr > 0.0) {
        s = 2.0 * SQRT(1.0 + tr);
        z[0] = 0.25 * s; z[1] = (R21 - R12) / s; z[2] = (R02 - R20) / s; z[3] = (R10 - R01) / s;
    } else if (R00 > R11 && R00 > R22) {
        t = 1.0 + R00 - R11 - R22;
        s = 2.0 * SQRT(t > 0.0 ? t : 0.0);
        z[0] = (R21 - R12) / s; z[1] = 0.25 * s; z[2] = (R01 + R10) / s; z[3] = (R02 + R20) / s;
    } else if (R11 > R22) {
        t = 1.0 + R11 - R00 - R22;
        s = 2.0 * SQRT(t > 0.0 ? t : 0.0);
        z[0] = (R02 - R20) / s; z[1] = (R01 + R10) / s; z[2] = 0.25 * s; z[3] = (R12 + R21) / s;
    } else {
        t = 1.0 + R22 - R00 - R11;
        s = 2.0 * SQRT(t > 0.0 ? t : 0.0);
        z[0] = (R10 - R01) / s; z[1] = (R02 + R20) / s; z[2] = (R12 + R21) / s; z[3] = 0.25 * s;
    }
    return !ISNAN_(z[0]);
}

/* measurement update (eqs. 17, 22) by Cholesky of S = P_qq + R_k: the loop of kernel._steps */
static void correct(PFX_filter *f, real z[4], const real *acc)
{
    real *x = f->x, (*P)[X_LEN] = f->P, L[4][4], W[4][X_LEN], v[4], dot, r_k, s, inv;
    real huber = DEG2RAD(f->p.huber_deg); /* the Huber innovation angle, rad */
    int r, c, m;
    for (r = 0; r < 4; r++)
        for (c = 0; c < 4; c++)
            L[r][c] = 0.0;
    if (f->p.acc_gate < (real)INFINITY) {
        real an = SQRT(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2]);
        if (!(fabs(an - f->p.g) <= f->p.acc_gate * f->p.g))
            return;
    }
    dot = z[0] * x[0] + z[1] * x[1] + z[2] * x[2] + z[3] * x[3];
    if (dot < 0.0) {
        dot = -dot;
        for (r = 0; r < 4; r++)
            z[r] = -z[r];
    }
    r_k = f->p.rho * 1.0;
    if (huber < (real)INFINITY) {
        /* innovation angle d = 2 acos(c), written as 4 asin(sqrt((1 - c) / 2)) */
        real nx = SQRT(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]), cc = dot / nx, d;
        cc = cc < 1.0 ? cc : 1.0;
        d = 4.0 * ASIN(SQRT((1.0 - cc) * 0.5));
        if (d > huber)
            r_k *= d / huber;
    }
    for (r = 0; r < 4; r++)
        for (c = 0; c <= r; c++) {
            s = P[r][c];
            if (r == c)
                s += r_k;
            for (m = 0; m < c; m++)
                s -= L[r][m] * L[c][m];
            if (r == c)
                L[r][r] = SQRT(s);
            else
                L[r][c] = s / L[c][c];
        }
    for (r = 0; r < 4; r++) {
        inv = 1.0 / L[r][r];
        for (c = 0; c < X_LEN; c++) {
            s = P[r][c];
            for (m = 0; m < r; m++)
                s -= L[r][m] * W[m][c];
            W[r][c] = s * inv;
        }
        s = z[r] - x[r];
        for (m = 0; m < r; m++)
            s -= L[r][m] * v[m];
        v[r] = s * inv;
    }
    for (c = 0; c < X_LEN; c++)
        x[c] += W[0][c] * v[0] + W[1][c] * v[1] + W[2][c] * v[2] + W[3][c] * v[3];
    for (r = 0; r < X_LEN; r++)
        for (c = r; c < X_LEN; c++) {
            s = P[r][c] - (W[0][r] * W[0][c] + W[1][r] * W[1][c] + W[2][r] * W[2][c] + W[3][r] * W[3][c]);
            P[r][c] = s;
            P[c][r] = s;
        }
}

/* bias pseudo-measurement at rest (three scalar updates): kernel._rest_bias_update */
static void rest_bias_update(PFX_filter *f)
{
    real *x = f->x, (*P)[X_LEN] = f->P, w[X_LEN], s, innov;
    int i, j, r, c;
    for (i = 0; i < 3; i++) {
        j = 4 + i;
        s = P[j][j] + f->p.rest_bias_var;
        innov = f->rs[i] - x[j];
        for (c = 0; c < X_LEN; c++)
            w[c] = P[c][j] / s;
        for (c = 0; c < X_LEN; c++)
            x[c] += w[c] * innov;
        for (r = 0; r < X_LEN; r++)
            for (c = 0; c < X_LEN; c++)
                P[r][c] -= w[r] * w[c] * s;
    }
}

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    int i, j;
    robust_init(f, p);
    for (i = 0; i < X_LEN; i++) {
        f->x[i] = i == 0 ? 1.0 : 0.0;
        for (j = 0; j < X_LEN; j++)
            f->P[i][j] = 0.0;
    }
    for (i = 0; i < 3; i++)
        f->prev_gyr[i] = 0.0;
    set_rate(f, p->dt_s);
}

/* the initial state (eq. 18): x = (q0 normalised, 0), P = diag(p0_q I4, p0_b I3) */
static void start_(PFX_filter *f, const real q[4])
{
    real nq = SQRT(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int i;
    for (i = 0; i < 4; i++) {
        f->P[i][i] = f->p.p0_q;
        f->x[i] = q[i] / nq;
    }
    for (i = 4; i < X_LEN; i++) {
        f->P[i][i] = f->p.p0_b;
        f->x[i] = 0.0;
    }
    f->started = 1;
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    int use_mag = f->p.use_mag && mag != 0, i, at_rest = 0;
    real a[3], m[3], n[3], z[4], gm = 1.0, nq, inv;
    if (f->started < 2) { /* sample 0 is the initial state */
        if (!f->started) {
            real q[4];
            start_quaternion(f->p.init, f->p.q0, acc, use_mag ? mag : 0, q);
            start_(f, q);
        }
        for (i = 0; i < 3; i++)
            f->prev_gyr[i] = gyr[i];
        f->started = 2;
        return;
    }
    if (dt != f->dt_s)
        set_rate(f, dt);
    if (f->p.rest_bias || f->p.mag_rejection)
        at_rest = rest_update(f->rs, f->rc, gyr[0], gyr[1], gyr[2], acc[0], acc[1], acc[2]);
    predict(f, f->p.gyro_sample == PFX_GYRO_SAMPLE_CURRENT ? gyr : f->prev_gyr, 0.5 * dt);
    for (i = 0; i < 3; i++)
        f->prev_gyr[i] = gyr[i];
    if (f->p.acc_lp_tau_s > 0.0) {
        acc_lp_update(f->as, f->alp_k, f->x, acc[0], acc[1], acc[2], a);
    } else {
        a[0] = acc[0];
        a[1] = acc[1];
        a[2] = acc[2];
    }
    if (use_mag) {
        m[0] = mag[0];
        m[1] = mag[1];
        m[2] = mag[2];
        if (f->p.mag_rejection) {
            north_(f->x, n);
            gm = mag_gain(f, n, m[0], m[1], m[2]);
            if (gm < 1.0)
                blend_north(a[0], a[1], a[2], gm, n, m);
        }
    } else {
        north_(f->x, m);
    }
    f->mag_gain = gm;
    if (triad(a[0], a[1], a[2], m[0], m[1], m[2], z))
        correct(f, z, acc);
    if (f->p.rest_bias && at_rest)
        rest_bias_update(f);
    nq = SQRT(f->x[0] * f->x[0] + f->x[1] * f->x[1] + f->x[2] * f->x[2] + f->x[3] * f->x[3]);
    inv = 1.0 / nq;
    for (i = 0; i < 4; i++)
        f->x[i] *= inv;
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    to_output(f->x, q);
}

void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    from_output(q, w);
    start_(f, w);
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    b[0] = f->x[4];
    b[1] = f->x[5];
    b[2] = f->x[6];
}
