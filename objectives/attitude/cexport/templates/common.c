/* ---- shared helpers (ported from objectives/attitude/filters/_scalar.py and base.py) ---------------- */
#define PI_ 3.14159265358979323846
#define DEG2RAD(x) ((x) * (PI_ / 180.0))
#define COUNT_(a) ((int)(sizeof(a) / sizeof((a)[0]))) /* entries of an array member (sizes come from layouts) */

static int finite3(const real *v)
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* Hamilton product p (x) q */
static void qmul(const real p[4], const real q[4], real out[4])
{
    real w = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3];
    real x = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2];
    real y = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1];
    real z = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0];
    out[0] = w;
    out[1] = x;
    out[2] = y;
    out[3] = z;
}

/* unit quaternion (w >= 0) of a rotation matrix, Shepperd's method: base.quat_from_rotmat */
static void quat_from_rotmat(real R[3][3], real q[4])
{
    real tr = R[0][0] + R[1][1] + R[2][2], s, n;
    int i;
    if (tr > 0.0) {
        s = 2.0 * SQRT(1.0 + tr);
        q[0] = 0.25 * s; q[1] = (R[2][1] - R[1][2]) / s; q[2] = (R[0][2] - R[2][0]) / s; q[3] = (R[1][0] - R[0][1]) / s;
    } else if (R[0][0] > R[1][1] && R[0][0] > R[2][2]) {
        s = 2.0 * SQRT(1.0 + R[0][0] - R[1][1] - R[2][2]);
        q[0] = (R[2][1] - R[1][2]) / s; q[1] = 0.25 * s; q[2] = (R[0][1] + R[1][0]) / s; q[3] = (R[0][2] + R[2][0]) / s;
    } else if (R[1][1] > R[2][2]) {
        s = 2.0 * SQRT(1.0 + R[1][1] - R[0][0] - R[2][2]);
        q[0] = (R[0][2] - R[2][0]) / s; q[1] = (R[0][1] + R[1][0]) / s; q[2] = 0.25 * s; q[3] = (R[1][2] + R[2][1]) / s;
    } else {
        s = 2.0 * SQRT(1.0 + R[2][2] - R[0][0] - R[1][1]);
        q[0] = (R[1][0] - R[0][1]) / s; q[1] = (R[0][2] + R[2][0]) / s; q[2] = (R[1][2] + R[2][1]) / s; q[3] = 0.25 * s;
    }
    n = SQRT(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (i = 0; i < 4; i++)
        q[i] /= n;
    if (!(q[0] >= 0.0))
        for (i = 0; i < 4; i++)
            q[i] = -q[i];
}

static void cross3(const real a[3], const real b[3], real out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static real norm3(const real a[3])
{
    return SQRT(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

/* start orientation from one acc (and mag) sample in the working frame: base.quat_from_acc_mag */
static void start_accmag(const real *acc, const real *mag, real q[4])
{
    real up[3], east[3], north[3], R[3][3], n = norm3(acc);
    int i, done = 0;
    for (i = 0; i < 3; i++)
        up[i] = acc[i] / n;
    if (mag != 0 && finite3(mag)) {
        cross3(mag, up, east);
        done = norm3(east) > 1e-12;
    }
    if (!done) {
        const real ex[3] = {1.0, 0.0, 0.0}, ey[3] = {0.0, 1.0, 0.0};
        cross3(ex, up, east);
        if (norm3(east) < 1e-9)
            cross3(ey, up, east);
        for (i = 0; i < 3; i++)
            east[i] = -east[i];
    }
    n = norm3(east);
    for (i = 0; i < 3; i++)
        east[i] /= n;
    cross3(up, east, north);
    for (i = 0; i < 3; i++) {
#if WORK_FRAME == 1 /* NED */
        R[0][i] = north[i]; R[1][i] = east[i]; R[2][i] = -up[i];
#elif WORK_FRAME == 0 /* ENU */
        R[0][i] = east[i]; R[1][i] = north[i]; R[2][i] = up[i];
#else /* NWU */
        R[0][i] = north[i]; R[1][i] = -east[i]; R[2][i] = up[i];
#endif
    }
    quat_from_rotmat(R, q);
}

static real copysign_(real mag, real sgn)
{
    return sgn < 0.0 || (sgn == 0.0 && 1.0 / sgn < 0.0) ? -mag : mag;
}

/* BROAD's quatFromAccMag (NWU), then in the working frame: init_broad.broad_start */
static void start_broad(const real *a, const real *m, real q[4])
{
    real mm[3], t[3], x[3], y[3], R[3][3], rad[4], na, nx, ny, qn[4];
    int i;
    for (i = 0; i < 3; i++)
        mm[i] = -m[i];
    cross3(a, mm, t);
    cross3(t, a, x);
    cross3(a, x, y);
    na = norm3(a);
    nx = norm3(x);
    ny = norm3(y);
    for (i = 0; i < 3; i++) {
        R[i][0] = x[i] / nx;
        R[i][1] = y[i] / ny;
        R[i][2] = a[i] / na;
    }
    rad[0] = 1 + R[0][0] + R[1][1] + R[2][2];
    rad[1] = 1 + R[0][0] - R[1][1] - R[2][2];
    rad[2] = 1 - R[0][0] + R[1][1] - R[2][2];
    rad[3] = 1 - R[0][0] - R[1][1] + R[2][2];
    for (i = 0; i < 4; i++)
        rad[i] = 0.5 * SQRT(rad[i] > 0.0 ? rad[i] : 0.0);
    qn[0] = rad[0];
    qn[1] = copysign_(rad[1], R[2][1] - R[1][2]);
    qn[2] = copysign_(rad[2], R[0][2] - R[2][0]);
    qn[3] = copysign_(rad[3], R[1][0] - R[0][1]);
    {
        static const real r[4] = NWU_TO_WORK;
        qmul(r, qn, q);
    }
}

/* the start quaternion of the first sample by params->init (0 accmag, 1 broad, 2 params->q0) */
static void start_quaternion(int init, const real q0[4], const real *acc, const real *mag, real q[4])
{
    int i;
    if (init == 1 && mag != 0) {
        start_broad(acc, mag, q);
    } else if (init == 2) {
        for (i = 0; i < 4; i++)
            q[i] = q0[i];
    } else {
        start_accmag(acc, mag, q);
    }
}

/* the working-frame quaternion in the output frame: frame_rotation(work, out) (x) q */
static void to_output(const real q[4], real out[4])
{
    static const real r[4] = WORK_TO_OUT;
    qmul(r, q, out);
}

/* an output-frame quaternion in the working frame: conj(frame_rotation(work, out)) (x) q */
static void from_output(const real q[4], real out[4])
{
    static const real r[4] = OUT_TO_WORK;
    qmul(r, q, out);
}
