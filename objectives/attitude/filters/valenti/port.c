/* ---- valenti: the complementary filter of Valenti, Dryanovski and Xiao 2015 as imu_complementary_filter runs it
   (eqs. 25, 35-36, 38-61 and the node's steady-state bias); ported from
   objectives/attitude/filters/valenti/kernel.py (the layout S is the enum above; the state is ^L_G q, NWU) */
#define VAL_EPS_LERP 0.9

/* p (x) v (x) p* of a unit quaternion p (kernel.py: _rotate) */
static void val_rotate(real p0, real p1, real p2, real p3, const real v[3], real o[3])
{
    o[0] = (p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3) * v[0] + 2.0 * (p1 * p2 - p0 * p3) * v[1]
           + 2.0 * (p1 * p3 + p0 * p2) * v[2];
    o[1] = 2.0 * (p1 * p2 + p0 * p3) * v[0] + (p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3) * v[1]
           + 2.0 * (p2 * p3 - p0 * p1) * v[2];
    o[2] = 2.0 * (p1 * p3 - p0 * p2) * v[0] + 2.0 * (p2 * p3 + p0 * p1) * v[1]
           + (p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3) * v[2];
}

/* the fraction gain of d from the identity: LERP (eq. 50) above 0.9, else SLERP (eq. 52), normalised */
static void val_scale(real gain, real d[4])
{
    real n;
    int i;
    if (d[0] < VAL_EPS_LERP) {
        real om = acos(d[0]), so = sin(om), a = sin((1.0 - gain) * om) / so, b = sin(gain * om) / so;
        d[0] = a + b * d[0];
        d[1] *= b; d[2] *= b; d[3] *= b;
    } else {
        d[0] = (1.0 - gain) + gain * d[0];
        d[1] *= gain; d[2] *= gain; d[3] *= gain;
    }
    n = SQRT(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + d[3] * d[3]);
    for (i = 0; i < 4; i++) d[i] /= n;
}

/* eq. 61: 1 below t1 = 0.1, linear to 0 at t2 = 0.2 */
static real val_gain_factor(real e)
{
    if (e < 0.1) return 1.0;
    if (e < 0.2) return (0.2 - e) / (0.2 - 0.1);
    return 0.0;
}

/* ^L_G q from one sample: eq. 25, with the field eqs. 26-36 */
static void val_start(const real acc[3], const real *mag, real q[4])
{
    real n = norm3(acc), ax = acc[0] / n, ay = acc[1] / n, az = acc[2] / n, qa[4];
    if (az >= 0.0) {
        real w = SQRT((az + 1.0) * 0.5);
        qa[0] = w; qa[1] = -ay / (2.0 * w); qa[2] = ax / (2.0 * w); qa[3] = 0.0;
    } else {
        real x = SQRT((1.0 - az) * 0.5);
        qa[0] = -ay / (2.0 * x); qa[1] = x; qa[2] = 0.0; qa[3] = ax / (2.0 * x);
    }
    if (mag == 0) {
        q[0] = qa[0]; q[1] = qa[1]; q[2] = qa[2]; q[3] = qa[3];
        return;
    } else {
        real l[3], gam, sg, b, qm[4] = {0.0, 0.0, 0.0, 0.0};
        val_rotate(qa[0], -qa[1], -qa[2], -qa[3], mag, l);
        gam = l[0] * l[0] + l[1] * l[1];
        sg = SQRT(gam);
        if (l[0] >= 0.0) {
            b = SQRT(gam + l[0] * sg);
            qm[0] = b / SQRT(2.0 * gam); qm[3] = l[1] / (SQRT(2.0) * b);
        } else {
            b = SQRT(gam - l[0] * sg);
            qm[0] = l[1] / (SQRT(2.0) * b); qm[3] = b / SQRT(2.0 * gam);
        }
        qmul(qa, qm, q);
    }
}

static void node_given(PFX_filter *f, const real w[4])
{
    real n = SQRT(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3]);
    f->s[S_Q] = w[0] / n;
    f->s[S_Q + 1] = -w[1] / n;
    f->s[S_Q + 2] = -w[2] / n;
    f->s[S_Q + 3] = -w[3] / n;
    f->s[S_PHASE] = 2.0;
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    real *s = f->s, g = f->p.g_node, an, u[3], p[4], a[3], gp[3], d[4], q[4], n, alpha;
    int i, use_mag = mag != 0 && f->p.use_mag;
    if (s[S_PHASE] != 1.0) { /* the start sample: no filtering */
        if (s[S_PHASE] == 0.0) {
            if (f->p.init == 1) { /* BROAD's quatFromAccMag, sensor-to-earth in NWU */
                real w[4];
                start_quaternion(1, f->p.q0, acc, use_mag ? mag : 0, w);
                s[S_Q] = w[0]; s[S_Q + 1] = -w[1]; s[S_Q + 2] = -w[2]; s[S_Q + 3] = -w[3];
            } else {
                val_start(acc, use_mag ? mag : 0, s + S_Q);
            }
        }
        s[S_PHASE] = 1.0;
        return;
    }
    an = norm3(acc);
    if (f->p.do_bias_estimation) { /* steady state: the bias follows the rate */
        int steady = !(fabs(an - g) > 0.1 * g / 9.81);
        for (i = 0; i < 3; i++)
            if (fabs(gyr[i] - s[S_PREV + i]) > 0.01 || fabs(gyr[i] - s[S_BIAS + i]) > 0.2)
                steady = 0;
        if (steady)
            for (i = 0; i < 3; i++) s[S_BIAS + i] += f->p.bias_alpha * (gyr[i] - s[S_BIAS + i]);
        for (i = 0; i < 3; i++) s[S_PREV + i] = gyr[i];
    }
    for (i = 0; i < 3; i++) u[i] = gyr[i] - s[S_BIAS + i];
    for (i = 0; i < 4; i++) q[i] = s[S_Q + i];
    /* eqs. 38-42 */
    p[0] = q[0] + 0.5 * dt * (u[0] * q[1] + u[1] * q[2] + u[2] * q[3]);
    p[1] = q[1] + 0.5 * dt * (-u[0] * q[0] - u[1] * q[3] + u[2] * q[2]);
    p[2] = q[2] + 0.5 * dt * (u[0] * q[3] - u[1] * q[0] - u[2] * q[1]);
    p[3] = q[3] + 0.5 * dt * (-u[0] * q[2] + u[1] * q[1] - u[2] * q[0]);
    n = SQRT(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]);
    for (i = 0; i < 4; i++) p[i] /= n;
    /* eqs. 44-47 */
    for (i = 0; i < 3; i++) a[i] = acc[i] / an;
    val_rotate(p[0], -p[1], -p[2], -p[3], a, gp);
    d[0] = SQRT((gp[2] + 1.0) * 0.5);
    d[1] = -gp[1] / (2.0 * d[0]);
    d[2] = gp[0] / (2.0 * d[0]);
    d[3] = 0.0;
    alpha = f->p.do_adaptive_gain ? f->p.gain_acc * val_gain_factor(fabs(an - g) / g) : f->p.gain_acc;
    val_scale(alpha, d);
    qmul(p, d, q); /* eq. 53 */
    if (use_mag) { /* eqs. 54-59 */
        real l[3], gam, b;
        val_rotate(q[0], -q[1], -q[2], -q[3], mag, l);
        gam = l[0] * l[0] + l[1] * l[1];
        b = SQRT(gam + l[0] * SQRT(gam));
        d[0] = b / SQRT(2.0 * gam);
        d[1] = 0.0;
        d[2] = 0.0;
        d[3] = l[1] / (SQRT(2.0) * b);
        val_scale(f->p.gain_mag, d);
        qmul(q, d, p);
        for (i = 0; i < 4; i++) q[i] = p[i];
    }
    n = SQRT(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (i = 0; i < 4; i++) s[S_Q + i] = q[i] / n;
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    real w[4];
    w[0] = f->s[S_Q];
    w[1] = -f->s[S_Q + 1];
    w[2] = -f->s[S_Q + 2];
    w[3] = -f->s[S_Q + 3];
    to_output(w, q);
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    int i;
    for (i = 0; i < 3; i++) b[i] = f->s[S_BIAS + i];
}
