/* ---- realtime: VQF's design (Laidig & Seel 2023) with the project's additions; ported from
   objectives/attitude/filters/realtime/kernel.py (the layouts C and S of coefficients.py are the enums above) */
/* second-order Butterworth low-pass (b0, b1, b2, a1, a2) of time constant tau at dt; pass-through below dt/2 */
static void rt_butter2(real tau, real dt, real *o)
{
    real fc, c, d, sn, cs;
    if (tau < dt / 2.0) {
        o[0] = 1.0; o[1] = 0.0; o[2] = 0.0; o[3] = 0.0; o[4] = 0.0;
        return;
    }
    fc = SQRT(2.0) / (2.0 * PI_ * tau);
    sincos_(PI_ * fc * dt, &sn, &cs);
    c = sn / cs;
    d = c * c + SQRT(2.0) * c + 1.0;
    o[0] = c * c / d;
    o[1] = 2.0 * o[0];
    o[2] = o[0];
    o[3] = 2.0 * (c * c - 1.0) / d;
    o[4] = (1.0 - SQRT(2.0) * c + c * c) / d;
}

static real rt_gain(real tau, real dt)
{
    if (tau < 0.0) return 0.0;
    if (tau == 0.0) return 1.0;
    return 1.0 - EXP(-dt / tau);
}

static void rt_coefficients(const PFX_params *v, real dt, int use_mag, real *c)
{
    int i;
    real p_motion, p_rest;
    for (i = 0; i < C_LEN; i++) c[i] = 0.0;
    c[C_DT] = dt;
    rt_butter2(v->tau_acc_s, dt, c + C_ACC_LP);
    c[C_TAU_ACC] = v->tau_acc_s;
    c[C_K_MAG] = rt_gain(v->tau_mag_s, dt);
    c[C_TAU_MAG] = v->tau_mag_s;
    c[C_USE_MAG] = use_mag ? 1.0 : 0.0;
    c[C_MOTION_BIAS] = v->motion_bias ? 1.0 : 0.0;
    c[C_REST_BIAS] = v->rest_bias ? 1.0 : 0.0;
    c[C_MAG_REJ] = v->mag_rejection ? 1.0 : 0.0;
    c[C_BIAS_CLIP] = DEG2RAD(v->bias_clip_dps);
    c[C_BIAS_P0] = (v->bias_sigma_init_dps * 100.0) * (v->bias_sigma_init_dps * 100.0);
    c[C_BIAS_V] = (0.1 * 100.0) * (0.1 * 100.0) * dt / v->bias_forgetting_s;
    p_motion = (v->bias_sigma_motion_dps * 100.0) * (v->bias_sigma_motion_dps * 100.0);
    c[C_BIAS_MOTION_W] = p_motion * p_motion / c[C_BIAS_V] + p_motion;
    c[C_BIAS_VERT_W] = c[C_BIAS_MOTION_W] / (v->bias_vertical_forgetting > 1e-10 ? v->bias_vertical_forgetting : 1e-10);
    p_rest = (v->bias_sigma_rest_dps * 100.0) * (v->bias_sigma_rest_dps * 100.0);
    c[C_BIAS_REST_W] = p_rest * p_rest / c[C_BIAS_V] + p_rest;
    rt_butter2(v->rest_filter_tau_s, dt, c + C_REST_LP);
    c[C_REST_TAU] = v->rest_filter_tau_s;
    c[C_REST_TH_GYR] = DEG2RAD(v->rest_th_gyr_dps);
    c[C_REST_TH_ACC] = v->rest_th_acc;
    c[C_REST_MIN] = v->rest_min_s;
    if (v->mag_current_tau_s > 0.0) rt_butter2(v->mag_current_tau_s, dt, c + C_MAG_LP);
    c[C_MAG_TAU] = v->mag_current_tau_s;
    c[C_K_MAG_REF] = rt_gain(v->mag_ref_tau_s, dt);
    c[C_MAG_NORM_TH] = v->mag_norm_th;
    c[C_MAG_DIP_TH] = DEG2RAD(v->mag_dip_th_deg);
    c[C_MAG_NEW] = v->mag_new_s;
    c[C_MAG_NEW_FIRST] = v->mag_new_first_s;
    c[C_MAG_NEW_MIN_GYR] = DEG2RAD(v->mag_new_min_gyr_dps);
    c[C_MAG_MIN_UNDIST] = v->mag_min_undisturbed_s;
    c[C_MAG_MAX_REJ] = v->mag_max_rejection_s;
    c[C_MAG_REJ_FACTOR] = v->mag_rejection_factor;
    c[C_MAG_FIRST_AT_REST] = v->mag_first_at_rest ? 1.0 : 0.0;
    c[C_K_MAG_REC] = v->mag_recover_tau_s > 0.0 ? rt_gain(v->mag_recover_tau_s, dt) : 0.0;
}

/* n-channel low-pass step with the averaging start (state s[off .. off + 2n)) */
/* the kernel marks a low-pass not yet started by NaN in its state; here a phase flag does (0: no sample yet,
   1: averaging, 2: filtering), which -ffast-math cannot optimise away */
static void rt_lp(real *s, int *phase, int off, int n, const real *x, real *y, const real *c, real tau, real dt)
{
    real b0 = c[0], b1 = c[1], b2 = c[2], a1 = c[3], a2 = c[4], cnt, yj;
    int j;
    if (*phase < 2) {
        if (*phase == 0) {
            *phase = 1;
            s[off + 1] = 0.0;
            for (j = 0; j < n; j++) s[off + n + j] = 0.0;
        }
        s[off + 1] += 1.0;
        cnt = s[off + 1];
        for (j = 0; j < n; j++) {
            s[off + n + j] += x[j];
            y[j] = s[off + n + j] / cnt;
        }
        if (cnt * dt >= tau) {
            *phase = 2;
            for (j = 0; j < n; j++) {
                s[off + j] = y[j] * (1.0 - b0);
                s[off + n + j] = y[j] * (b2 - a2);
            }
        }
        return;
    }
    for (j = 0; j < n; j++) {
        yj = b0 * x[j] + s[off + j];
        s[off + j] = b1 * x[j] - a1 * yj + s[off + n + j];
        s[off + n + j] = b2 * x[j] - a2 * yj;
        y[j] = yj;
    }
}


static void rt_rotate(const real *q, const real *v, real *o)
{
    real q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3], v0 = v[0], v1 = v[1], v2 = v[2];
    o[0] = (1 - 2 * q2 * q2 - 2 * q3 * q3) * v0 + 2 * v1 * (q2 * q1 - q0 * q3) + 2 * v2 * (q0 * q2 + q3 * q1);
    o[1] = 2 * v0 * (q0 * q3 + q2 * q1) + v1 * (1 - 2 * q1 * q1 - 2 * q3 * q3) + 2 * v2 * (q2 * q3 - q1 * q0);
    o[2] = 2 * v0 * (q3 * q1 - q0 * q2) + 2 * v1 * (q0 * q1 + q3 * q2) + v2 * (1 - 2 * q1 * q1 - 2 * q2 * q2);
}

static void rt_normq(real *q)
{
    real n = SQRT(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int j;
    if (n != 0.0)
        for (j = 0; j < 4; j++) q[j] /= n;
}

static void rt_inv3(const real *m, real *o)
{
    real a = m[0], b = m[1], c = m[2], d = m[3], e = m[4], f = m[5], g = m[6], h = m[7], k = m[8];
    real c00 = e * k - f * h, c01 = f * g - d * k, c02 = d * h - e * g;
    real det = a * c00 + b * c01 + c * c02;
    o[0] = c00 / det; o[1] = (c * h - b * k) / det; o[2] = (b * f - c * e) / det;
    o[3] = c01 / det; o[4] = (a * k - c * g) / det; o[5] = (c * d - a * f) / det;
    o[6] = c02 / det; o[7] = (b * g - a * h) / det; o[8] = (a * e - b * d) / det;
}

/* o = a b (bt 0) or a b^T (bt 1), 3x3 row-major, each entry summed over m = 0, 1, 2 in that order */
static void rt_mul3(const real *a, const real *b, int bt, real *o)
{
    real acc;
    int i, j, m;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += a[3 * i + m] * (bt ? b[3 * j + m] : b[3 * m + j]);
            o[3 * i + j] = acc;
        }
}

static void rt_bias_update(real *s, const real *r, const real *e, const real *w)
{
    real t1[9], t2[9], t3[9];
    const real *p = s + S_BIAS_P;
    int i;
    rt_mul3(p, r, 1, t1);  /* P R^T */
    rt_mul3(r, t1, 0, t2); /* R P R^T + W */
    for (i = 0; i < 3; i++) t2[4 * i] += w[i];
    rt_inv3(t2, t3);
    rt_mul3(t1, t3, 0, t2); /* the gain K = P R^T (R P R^T + W)^-1 */
    for (i = 0; i < 3; i++) s[S_BIAS + i] += t2[3 * i] * e[0] + t2[3 * i + 1] * e[1] + t2[3 * i + 2] * e[2];
    rt_mul3(t2, r, 0, t3);  /* K R */
    rt_mul3(t3, p, 0, t1);  /* K R P, subtracted from P */
    for (i = 0; i < 9; i++) s[S_BIAS_P + i] -= t1[i];
}

static real rt_max3(real a, real b, real c) { real m = a > b ? a : b; return m > c ? m : c; }

static real rt_clip(real x, real lim) { return x < -lim ? -lim : (x > lim ? lim : x); }

static void rt_q6(const real *s, real *o) { qmul(s + S_ACC_Q, s + S_GYR_Q, o); }



static void rt_step(const real *c, real *s, int *lpf, const real *gyr, const real *acc, const real *mag)
{
    real dt = c[C_DT], clip_r = c[C_BIAS_CLIP];
    int rest_bias = c[C_REST_BIAS] != 0.0, motion_bias = c[C_MOTION_BIAS] != 0.0, mag_rej = c[C_MAG_REJ] != 0.0;
    /* the first field at rest: the rest detector runs on the accelerometer too, with or without the rest bias */
    int first_at_rest = mag_rej && c[C_USE_MAG] != 0.0 && c[C_MAG_FIRST_AT_REST] != 0.0;
    real x[9], y[9], r[9], e[3], w[3], q[4], p6[4], u[3], h[3], d0, d1, d2, un, ang, ex, ey, ez, en, qw;
    int j;
    /* gyroscope: rest detection, strapdown integration */
    if (rest_bias || mag_rej) {
        rt_lp(s, lpf + LP_REST_GYR_LP, S_REST_GYR_LP, 3, gyr, y, c + C_REST_LP, c[C_REST_TAU], dt);
        d0 = gyr[0] - y[0]; d1 = gyr[1] - y[1]; d2 = gyr[2] - y[2];
        if (d0 * d0 + d1 * d1 + d2 * d2 >= c[C_REST_TH_GYR] * c[C_REST_TH_GYR]
            || rt_max3(fabs(y[0]), fabs(y[1]), fabs(y[2])) > clip_r) {
            s[S_REST_T] = 0.0;
            s[S_REST] = 0.0;
        }
        for (j = 0; j < 3; j++) s[S_REST_GYR + j] = y[j];
    }
    for (j = 0; j < 3; j++) u[j] = gyr[j] - s[S_BIAS + j];
    un = SQRT(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (un > 2.220446049250313e-16) {
        real dq[4], sw;
        ang = un * dt;
        sincos_(ang / 2.0, &sw, &dq[0]);
        sw = sw / un;
        dq[1] = sw * u[0]; dq[2] = sw * u[1]; dq[3] = sw * u[2];
        qmul(s + S_GYR_Q, dq, q);
        for (j = 0; j < 4; j++) s[S_GYR_Q + j] = q[j];
        rt_normq(s + S_GYR_Q);
    }
    /* accelerometer: inclination correction from the low-passed inertial-frame acc, gyro bias */
    if (!(acc[0] == 0.0 && acc[1] == 0.0 && acc[2] == 0.0)) {
        if (rest_bias || first_at_rest) {
            rt_lp(s, lpf + LP_REST_ACC_LP, S_REST_ACC_LP, 3, acc, y, c + C_REST_LP, c[C_REST_TAU], dt);
            d0 = acc[0] - y[0]; d1 = acc[1] - y[1]; d2 = acc[2] - y[2];
            if (d0 * d0 + d1 * d1 + d2 * d2 >= c[C_REST_TH_ACC] * c[C_REST_TH_ACC]) {
                s[S_REST_T] = 0.0;
                s[S_REST] = 0.0;
            } else {
                s[S_REST_T] += dt;
                if (s[S_REST_T] >= c[C_REST_MIN]) s[S_REST] = 1.0;
            }
        }
        rt_rotate(s + S_GYR_Q, acc, x);
        rt_lp(s, lpf + LP_ACC_LP, S_ACC_LP, 3, x, y, c + C_ACC_LP, c[C_TAU_ACC], dt);
        rt_rotate(s + S_ACC_Q, y, h);
        ex = h[0]; ey = h[1]; ez = h[2];
        en = SQRT(ex * ex + ey * ey + ez * ez);
        if (en != 0.0) { ex /= en; ey /= en; ez /= en; }
        qw = SQRT((ez + 1.0) / 2.0);
        {
            real cq[4];
            if (qw > 1e-6) { cq[0] = qw; cq[1] = 0.5 * ey / qw; cq[2] = -0.5 * ex / qw; cq[3] = 0.0; }
            else { cq[0] = 0.0; cq[1] = 1.0; cq[2] = 0.0; cq[3] = 0.0; }
            qmul(cq, s + S_ACC_Q, q);
        }
        for (j = 0; j < 4; j++) s[S_ACC_Q + j] = q[j];
        rt_normq(s + S_ACC_Q);
        if (motion_bias || rest_bias) {
            real b0 = s[S_BIAS], b1 = s[S_BIAS + 1], b2 = s[S_BIAS + 2], a[9];
            int has = 1;
            rt_q6(s, p6);
            a[0] = 1 - 2 * p6[2] * p6[2] - 2 * p6[3] * p6[3];
            a[1] = 2 * (p6[2] * p6[1] - p6[0] * p6[3]);
            a[2] = 2 * (p6[0] * p6[2] + p6[3] * p6[1]);
            a[3] = 2 * (p6[0] * p6[3] + p6[2] * p6[1]);
            a[4] = 1 - 2 * p6[1] * p6[1] - 2 * p6[3] * p6[3];
            a[5] = 2 * (p6[2] * p6[3] - p6[1] * p6[0]);
            a[6] = 2 * (p6[3] * p6[1] - p6[0] * p6[2]);
            a[7] = 2 * (p6[0] * p6[1] + p6[3] * p6[2]);
            a[8] = 1 - 2 * p6[1] * p6[1] - 2 * p6[2] * p6[2];
            x[0] = a[0] * b0 + a[1] * b1 + a[2] * b2;
            x[1] = a[3] * b0 + a[4] * b1 + a[5] * b2;
            rt_lp(s, lpf + LP_R_LP, S_R_LP, 9, a, r, c + C_ACC_LP, c[C_TAU_ACC], dt);
            rt_lp(s, lpf + LP_BLP, S_BLP, 2, x, y, c + C_ACC_LP, c[C_TAU_ACC], dt);
            if (s[S_REST] != 0.0 && rest_bias) {
                for (j = 0; j < 3; j++) { e[j] = s[S_REST_GYR + j] - s[S_BIAS + j]; w[j] = c[C_BIAS_REST_W]; }
                for (j = 0; j < 9; j++) r[j] = (j % 4 == 0) ? 1.0 : 0.0;
            } else if (motion_bias) {
                e[0] = -ey / dt + y[0] - r[0] * b0 - r[1] * b1 - r[2] * b2;
                e[1] = ex / dt + y[1] - r[3] * b0 - r[4] * b1 - r[5] * b2;
                e[2] = -r[6] * b0 - r[7] * b1 - r[8] * b2;
                w[0] = c[C_BIAS_MOTION_W]; w[1] = c[C_BIAS_MOTION_W]; w[2] = c[C_BIAS_VERT_W];
            } else {
                has = 0;
            }
            for (j = 0; j < 3; j++)
                if (s[S_BIAS_P + 4 * j] < c[C_BIAS_P0]) s[S_BIAS_P + 4 * j] += c[C_BIAS_V];
            if (has) {
                for (j = 0; j < 3; j++) e[j] = rt_clip(e[j], clip_r);
                rt_bias_update(s, r, e, w);
                for (j = 0; j < 3; j++) s[S_BIAS + j] = rt_clip(s[S_BIAS + j], clip_r);
            }
        }
    }
    /* magnetometer: the heading offset delta only */
    if (c[C_USE_MAG] != 0.0 && mag != 0 && !(mag[0] == 0.0 && mag[1] == 0.0 && mag[2] == 0.0)) {
        real k, dis, dd, kin;
        rt_q6(s, p6);
        rt_rotate(p6, mag, h);
        if (mag_rej) {
            real nrm = SQRT(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]), nd, dip, kref = c[C_K_MAG_REF], refn, cn;
            x[0] = nrm;
            x[1] = -ASIN(h[2] / nrm);
            if (c[C_MAG_TAU] > 0.0) rt_lp(s, lpf + LP_MAG_LP, S_MAG_LP, 2, x, y, c + C_MAG_LP, c[C_MAG_TAU], dt);
            else { y[0] = x[0]; y[1] = x[1]; }
            nd = y[0]; dip = y[1];
            refn = s[S_MAG_REF_NORM];
            if (fabs(nd - refn) < c[C_MAG_NORM_TH] * refn && fabs(dip - s[S_MAG_REF_DIP]) < c[C_MAG_DIP_TH]) {
                s[S_MAG_UNDIST_T] += dt;
                if (s[S_MAG_UNDIST_T] >= c[C_MAG_MIN_UNDIST]) {
                    s[S_MAG_DIST] = 0.0;
                    s[S_MAG_REF_NORM] += kref * (nd - s[S_MAG_REF_NORM]);
                    s[S_MAG_REF_DIP] += kref * (dip - s[S_MAG_REF_DIP]);
                }
            } else {
                s[S_MAG_UNDIST_T] = 0.0;
                s[S_MAG_DIST] = 1.0;
            }
            cn = s[S_MAG_CAND_NORM];
            if (fabs(nd - cn) < c[C_MAG_NORM_TH] * cn && fabs(dip - s[S_MAG_CAND_DIP]) < c[C_MAG_DIP_TH]) {
                real gl = SQRT(s[S_REST_GYR] * s[S_REST_GYR] + s[S_REST_GYR + 1] * s[S_REST_GYR + 1]
                                 + s[S_REST_GYR + 2] * s[S_REST_GYR + 2]);
                if (gl >= c[C_MAG_NEW_MIN_GYR] || (first_at_rest && refn == 0.0 && s[S_REST] != 0.0))
                    s[S_MAG_CAND_T] += dt;
                s[S_MAG_CAND_NORM] += kref * (nd - s[S_MAG_CAND_NORM]);
                s[S_MAG_CAND_DIP] += kref * (dip - s[S_MAG_CAND_DIP]);
                if (s[S_MAG_DIST] != 0.0 && (s[S_MAG_CAND_T] >= c[C_MAG_NEW]
                    || (s[S_MAG_REF_NORM] == 0.0 && s[S_MAG_CAND_T] >= c[C_MAG_NEW_FIRST]))) {
                    s[S_MAG_REF_NORM] = s[S_MAG_CAND_NORM];
                    s[S_MAG_REF_DIP] = s[S_MAG_CAND_DIP];
                    s[S_MAG_DIST] = 0.0;
                    s[S_MAG_UNDIST_T] = c[C_MAG_MIN_UNDIST];
                }
            } else {
                s[S_MAG_CAND_T] = 0.0;
                s[S_MAG_CAND_NORM] = nd;
                s[S_MAG_CAND_DIP] = dip;
            }
        }
        dis = ATAN2(h[0], h[1]) - s[S_DELTA];
        if (dis > PI_) dis -= 2.0 * PI_;
        else if (dis < -PI_) dis += 2.0 * PI_;
        k = c[C_K_MAG];
        if (mag_rej) {
            if (s[S_MAG_DIST] != 0.0) {
                if (s[S_MAG_REJECT_T] <= c[C_MAG_MAX_REJ]) {
                    s[S_MAG_REJECT_T] += dt;
                    k = 0.0;
                } else {
                    k /= c[C_MAG_REJ_FACTOR];
                }
            } else {
                if (s[S_MAG_REJECT_T] > 0.0 && c[C_K_MAG_REC] > k) k = c[C_K_MAG_REC];
                s[S_MAG_REJECT_T] = s[S_MAG_REJECT_T] - c[C_MAG_REJ_FACTOR] * dt > 0.0 ? s[S_MAG_REJECT_T] - c[C_MAG_REJ_FACTOR] * dt : 0.0;
            }
        }
        kin = s[S_K_MAG_INIT];
        if (kin != 0.0) {
            if (k < kin) k = kin;
            kin = kin / (kin + 1.0);
            if (kin * c[C_TAU_MAG] < dt) kin = 0.0;
            s[S_K_MAG_INIT] = kin;
        }
        dd = s[S_DELTA] + k * dis;
        if (dd > PI_) dd -= 2.0 * PI_;
        else if (dd < -PI_) dd += 2.0 * PI_;
        s[S_DELTA] = dd;
    }
}

static void rt_reset(PFX_filter *f)
{
    real *s = f->s;
    int i;
    for (i = 0; i < S_LEN; i++) s[i] = 0.0; /* unused entries; low-pass phases below */
    for (i = 0; i < LP_LEN; i++) f->lpf[i] = 0;
    s[S_GYR_Q] = 1.0; s[S_GYR_Q + 1] = 0.0; s[S_GYR_Q + 2] = 0.0; s[S_GYR_Q + 3] = 0.0;
    s[S_ACC_Q] = 1.0; s[S_ACC_Q + 1] = 0.0; s[S_ACC_Q + 2] = 0.0; s[S_ACC_Q + 3] = 0.0;
    s[S_DELTA] = 0.0;
    for (i = 0; i < 3; i++) s[S_BIAS + i] = 0.0;
    for (i = 0; i < 9; i++) s[S_BIAS_P + i] = (i % 4 == 0) ? f->c[C_BIAS_P0] : 0.0;
    s[S_REST_T] = 0.0; s[S_REST] = 0.0;
    for (i = 0; i < 3; i++) s[S_REST_GYR + i] = 0.0;
    s[S_MAG_REF_NORM] = 0.0; s[S_MAG_REF_DIP] = 0.0; s[S_MAG_UNDIST_T] = 0.0;
    s[S_MAG_REJECT_T] = f->c[C_MAG_MAX_REJ];
    s[S_MAG_CAND_NORM] = -1.0; s[S_MAG_CAND_DIP] = 0.0; s[S_MAG_CAND_T] = 0.0;
    s[S_MAG_DIST] = 1.0; s[S_K_MAG_INIT] = 1.0;
}

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    f->p = *p;
    f->dt_s = p->dt_s;
    rt_coefficients(&f->p, p->dt_s, p->use_mag, f->c);
    rt_reset(f);
    f->started = p->start != PFX_START_Q0; /* start self: identity strapdown start, nothing to take from a sample */
}

/* start_q0: the strapdown quaternion starts at q; start self (VQF's identity start) takes no start
   orientation, as the model (filters/realtime/filter.py) ignores one */
void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    int i;
    if (f->p.start != PFX_START_Q0)
        return;
    from_output(q, w);
    for (i = 0; i < 4; i++) f->s[S_GYR_Q + i] = w[i];
    f->started = 1;
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt_s)
{
    if (dt_s != f->dt_s) { /* a new rate: the gains follow the time constants */
        rt_coefficients(&f->p, dt_s, f->c[C_USE_MAG] != 0.0, f->c);
        f->dt_s = dt_s;
    }
    if (!f->started) { /* start q0: the strapdown quaternion from the first sample (or init's q0) */
        real q[4];
        int i;
        start_quaternion(f->p.init, f->p.q0, acc, f->c[C_USE_MAG] != 0.0 ? mag : 0, q);
        for (i = 0; i < 4; i++) f->s[S_GYR_Q + i] = q[i];
        f->started = 1;
    }
    if (!finite3(gyr) || !finite3(acc))
        return; /* not a sample (the recordings the filter is scored on have none) */
    rt_step(f->c, f->s, f->lpf, gyr, acc, (mag != 0 && finite3(mag)) ? mag : 0);
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    real p[4], w[4], cd, sd;
    rt_q6(f->s, p);
    if (f->c[C_USE_MAG] != 0.0) {
        sincos_(f->s[S_DELTA] / 2.0, &sd, &cd);
        w[0] = cd * p[0] - sd * p[3];
        w[1] = cd * p[1] - sd * p[2];
        w[2] = cd * p[2] + sd * p[1];
        w[3] = cd * p[3] + sd * p[0];
    } else {
        w[0] = p[0]; w[1] = p[1]; w[2] = p[2]; w[3] = p[3];
    }
    to_output(w, q);
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    int i;
    for (i = 0; i < 3; i++) b[i] = f->s[S_BIAS + i];
}
