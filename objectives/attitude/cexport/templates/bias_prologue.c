/* ---- the robust blocks' prologue of the quaternion-and-bias filters (_bias_filter.robust_sample) ------- */
/* (x, y, z) / |(x, y, z)| and 1, or unchanged and 0 (zero or non-finite norm): _scalar.unit */
static int unit3(real *x, real *y, real *z)
{
    real n = *x * *x + *y * *y + *z * *z;
    if (n > 0.0 && n < (real)INFINITY) {
        real r = 1.0 / SQRT(n);
        *x *= r;
        *y *= r;
        *z *= r;
        return 1;
    }
    return 0;
}

static void set_rate(PFX_filter *f, real dt)
{
    robust_rate(f, dt, 0.5 / 9.81, f->p.rest_bias_tau_s);
}

/* h = q v q*: _scalar.rotate_sensor_to_earth */
static void rotate_sensor_to_earth(const real *q, real x, real y, real z, real h[3])
{
    real q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3];
    h[0] = (x * (1.0 - 2.0 * (q2 * q2 + q3 * q3)) + 2.0 * y * (q1 * q2 - q0 * q3) + 2.0 * z * (q1 * q3 + q0 * q2));
    h[1] = (2.0 * x * (q1 * q2 + q0 * q3) + y * (1.0 - 2.0 * (q1 * q1 + q3 * q3)) + 2.0 * z * (q2 * q3 - q0 * q1));
    h[2] = (2.0 * x * (q1 * q3 - q0 * q2) + 2.0 * y * (q2 * q3 + q0 * q1) + z * (1.0 - 2.0 * (q1 * q1 + q2 * q2)));
}

static int robust_on(const PFX_params *p)
{
    return p->mag_rejection || p->rest_bias || p->acc_lp_tau_s > 0.0;
}

/* the rest bias rb to subtract, the unit acc a for the gravity correction (1: usable) and the
   magnetometer gain gm, at the previous estimate f->q; updates the blocks' states */
static int robust_sample(PFX_filter *f, const real *gyr, const real *acc, const real *mag, int use_mag, real rb[3],
                         real a[3], real *gm)
{
    const PFX_params *p = &f->p;
    int rej = p->mag_rejection, rest = p->rest_bias, alp = p->acc_lp_tau_s > 0.0, a_ok;
    int g_ok = finite3(gyr);
    a[0] = acc[0];
    a[1] = acc[1];
    a[2] = acc[2];
    a_ok = unit3(&a[0], &a[1], &a[2]);
    if ((rej || rest) && g_ok && a_ok)
        rest_update(f->rs, f->rc, gyr[0], gyr[1], gyr[2], a[0], a[1], a[2]);
    rb[0] = rb[1] = rb[2] = 0.0;
    if (rest) {
        rb[0] = f->rs[8];
        rb[1] = f->rs[9];
        rb[2] = f->rs[10];
    }
    if (alp && a_ok) {
        real lp[3];
        acc_lp_update(f->as, f->alp_k, f->q, a[0], a[1], a[2], lp);
        a[0] = lp[0];
        a[1] = lp[1];
        a[2] = lp[2];
        a_ok = unit3(&a[0], &a[1], &a[2]);
    }
    *gm = 1.0;
    if (rej && use_mag && finite3(mag)) {
        real h[3], gl, g, *ms = f->ms, *rs = f->rs;
        rotate_sensor_to_earth(f->q, mag[0], mag[1], mag[2], h);
        gl = SQRT(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2]);
        g = mag_dist_update(ms, f->mc, h[0], h[1], h[2], gl);
        if (ms[0] == 0.0 && p->mag_ref_start) {
            ms[0] = ms[8];
            ms[1] = ms[9];
            ms[2] = f->mc[5];
            ms[6] = 0.0;
            g = 1.0;
        }
        *gm = ms[0] == 0.0 ? 1.0 : g;
    }
    return a_ok;
}

/* the first sample's start orientation, the rate's coefficients and the blocks' inputs of one sample:
   gyro rate g (bias-free by the rest bias), unit acc a, unit mag m; returns acc_ok, *mag_ok, *gm */
static int prologue(PFX_filter *f, const real *gyr, const real *acc, const real *mag, real dt, real g[3], real a[3],
                    real m[3], int *mag_ok, real *gm)
{
    int use_mag = f->p.use_mag && mag != 0, acc_ok;
    real rb[3] = {0.0, 0.0, 0.0};
    if (!f->started) {
        start_quaternion(f->p.init, f->p.q0, acc, use_mag ? mag : 0, f->q);
        f->started = 1;
    }
    if (dt != f->dt_s)
        set_rate(f, dt);
    if (finite3(gyr)) {
        g[0] = gyr[0];
        g[1] = gyr[1];
        g[2] = gyr[2];
    } else {
        g[0] = g[1] = g[2] = 0.0;
    }
    *gm = 1.0;
    if (robust_on(&f->p)) {
        acc_ok = robust_sample(f, gyr, acc, mag, use_mag, rb, a, gm);
        g[0] = g[0] - rb[0];
        g[1] = g[1] - rb[1];
        g[2] = g[2] - rb[2];
    } else {
        a[0] = acc[0];
        a[1] = acc[1];
        a[2] = acc[2];
        acc_ok = unit3(&a[0], &a[1], &a[2]);
    }
    *mag_ok = 0;
    if (use_mag) {
        m[0] = mag[0];
        m[1] = mag[1];
        m[2] = mag[2];
        *mag_ok = unit3(&m[0], &m[1], &m[2]) && *gm > 0.0;
    }
    return acc_ok;
}

static void bias_init(PFX_filter *f, const PFX_params *p)
{
    int i;
    robust_init(f, p);
    for (i = 0; i < 4; i++)
        f->q[i] = i == 0 ? 1.0 : 0.0;
    for (i = 0; i < 3; i++)
        f->b[i] = 0.0;
    set_rate(f, p->dt_s);
}

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    bias_init(f, p);
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
