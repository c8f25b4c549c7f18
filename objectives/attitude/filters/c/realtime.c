/* realtime attitude filter: see realtime.h. Layouts and steps as objectives/attitude/filters/_realtime_kernel.py. */
#include <math.h>
#include <stddef.h>
#include <float.h>

#include "realtime.h"

#define RT_PI 3.14159265358979323846

enum {
    C_DT = 0, C_ACC_LP = 1, C_TAU_ACC = 6, C_K_MAG = 7, C_TAU_MAG = 8, C_USE_MAG = 9, C_MOTION_BIAS = 10,
    C_REST_BIAS = 11, C_MAG_REJ = 12, C_BIAS_CLIP = 13, C_BIAS_P0 = 14, C_BIAS_V = 15, C_BIAS_MOTION_W = 16,
    C_BIAS_VERT_W = 17, C_BIAS_REST_W = 18, C_REST_LP = 19, C_REST_TAU = 24, C_REST_TH_GYR = 25,
    C_REST_TH_ACC = 26, C_REST_MIN = 27, C_MAG_LP = 28, C_MAG_TAU = 33, C_K_MAG_REF = 34, C_MAG_NORM_TH = 35,
    C_MAG_DIP_TH = 36, C_MAG_NEW = 37, C_MAG_NEW_FIRST = 38, C_MAG_NEW_MIN_GYR = 39, C_MAG_MIN_UNDIST = 40,
    C_MAG_MAX_REJ = 41, C_MAG_REJ_FACTOR = 42, C_MAG_FIRST_AT_REST = 43, C_K_MAG_REC = 44
};
enum {
    S_GYR_Q = 0, S_ACC_Q = 4, S_DELTA = 8, S_BIAS = 9, S_BIAS_P = 12, S_ACC_LP = 21, S_R_LP = 27, S_BLP = 45,
    S_REST_GYR_LP = 49, S_REST_ACC_LP = 55, S_REST_T = 61, S_REST = 62, S_REST_GYR = 63, S_MAG_LP = 66,
    S_MAG_REF_NORM = 70, S_MAG_REF_DIP = 71, S_MAG_UNDIST_T = 72, S_MAG_REJECT_T = 73, S_MAG_CAND_NORM = 74,
    S_MAG_CAND_DIP = 75, S_MAG_CAND_T = 76, S_MAG_DIST = 77, S_K_MAG_INIT = 78
};

static double deg2rad(double x) { return x * (RT_PI / 180.0); }

/* second-order Butterworth low-pass (b0, b1, b2, a1, a2) of time constant tau at dt; pass-through below dt/2 */
static void butter2(double tau, double dt, double *o)
{
    double fc, c, d;
    if (tau < dt / 2.0) {
        o[0] = 1.0; o[1] = 0.0; o[2] = 0.0; o[3] = 0.0; o[4] = 0.0;
        return;
    }
    fc = sqrt(2.0) / (2.0 * RT_PI * tau);
    c = tan(RT_PI * fc * dt);
    d = c * c + sqrt(2.0) * c + 1.0;
    o[0] = c * c / d;
    o[1] = 2.0 * o[0];
    o[2] = o[0];
    o[3] = 2.0 * (c * c - 1.0) / d;
    o[4] = (1.0 - sqrt(2.0) * c + c * c) / d;
}

static double gain(double tau, double dt)
{
    if (tau < 0.0) return 0.0;
    if (tau == 0.0) return 1.0;
    return 1.0 - exp(-dt / tau);
}

static void coefficients(const rt_params *v, double dt, int use_mag, double *c)
{
    int i;
    double p_motion, p_rest;
    for (i = 0; i < RT_COEF_LEN; i++) c[i] = 0.0;
    c[C_DT] = dt;
    butter2(v->tau_acc_s, dt, c + C_ACC_LP);
    c[C_TAU_ACC] = v->tau_acc_s;
    c[C_K_MAG] = gain(v->tau_mag_s, dt);
    c[C_TAU_MAG] = v->tau_mag_s;
    c[C_USE_MAG] = use_mag ? 1.0 : 0.0;
    c[C_MOTION_BIAS] = v->motion_bias ? 1.0 : 0.0;
    c[C_REST_BIAS] = v->rest_bias ? 1.0 : 0.0;
    c[C_MAG_REJ] = v->mag_rejection ? 1.0 : 0.0;
    c[C_BIAS_CLIP] = deg2rad(v->bias_clip_dps);
    c[C_BIAS_P0] = (v->bias_sigma_init_dps * 100.0) * (v->bias_sigma_init_dps * 100.0);
    c[C_BIAS_V] = (0.1 * 100.0) * (0.1 * 100.0) * dt / v->bias_forgetting_s;
    p_motion = (v->bias_sigma_motion_dps * 100.0) * (v->bias_sigma_motion_dps * 100.0);
    c[C_BIAS_MOTION_W] = p_motion * p_motion / c[C_BIAS_V] + p_motion;
    c[C_BIAS_VERT_W] = c[C_BIAS_MOTION_W] / (v->bias_vertical_forgetting > 1e-10 ? v->bias_vertical_forgetting : 1e-10);
    p_rest = (v->bias_sigma_rest_dps * 100.0) * (v->bias_sigma_rest_dps * 100.0);
    c[C_BIAS_REST_W] = p_rest * p_rest / c[C_BIAS_V] + p_rest;
    butter2(v->rest_filter_tau_s, dt, c + C_REST_LP);
    c[C_REST_TAU] = v->rest_filter_tau_s;
    c[C_REST_TH_GYR] = deg2rad(v->rest_th_gyr_dps);
    c[C_REST_TH_ACC] = v->rest_th_acc;
    c[C_REST_MIN] = v->rest_min_s;
    if (v->mag_current_tau_s > 0.0) butter2(v->mag_current_tau_s, dt, c + C_MAG_LP);
    c[C_MAG_TAU] = v->mag_current_tau_s;
    c[C_K_MAG_REF] = gain(v->mag_ref_tau_s, dt);
    c[C_MAG_NORM_TH] = v->mag_norm_th;
    c[C_MAG_DIP_TH] = deg2rad(v->mag_dip_th_deg);
    c[C_MAG_NEW] = v->mag_new_s;
    c[C_MAG_NEW_FIRST] = v->mag_new_first_s;
    c[C_MAG_NEW_MIN_GYR] = deg2rad(v->mag_new_min_gyr_dps);
    c[C_MAG_MIN_UNDIST] = v->mag_min_undisturbed_s;
    c[C_MAG_MAX_REJ] = v->mag_max_rejection_s;
    c[C_MAG_REJ_FACTOR] = v->mag_rejection_factor;
    c[C_MAG_FIRST_AT_REST] = v->mag_first_at_rest ? 1.0 : 0.0;
    c[C_K_MAG_REC] = v->mag_recover_tau_s > 0.0 ? gain(v->mag_recover_tau_s, dt) : 0.0;
}

/* n-channel low-pass step with the averaging start (state s[off .. off + 2n)) */
static void lp(double *s, int off, int n, const double *x, double *y, const double *c, double tau, double dt)
{
    double b0 = c[0], b1 = c[1], b2 = c[2], a1 = c[3], a2 = c[4], cnt, yj;
    int j;
    if (isnan(s[off])) {
        if (isnan(s[off + 1])) {
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

static void qmul(const double *a, const double *b, double *o)
{
    double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    o[0] = w; o[1] = x; o[2] = y; o[3] = z;
}

static void rotate(const double *q, const double *v, double *o)
{
    double q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3], v0 = v[0], v1 = v[1], v2 = v[2];
    o[0] = (1 - 2 * q2 * q2 - 2 * q3 * q3) * v0 + 2 * v1 * (q2 * q1 - q0 * q3) + 2 * v2 * (q0 * q2 + q3 * q1);
    o[1] = 2 * v0 * (q0 * q3 + q2 * q1) + v1 * (1 - 2 * q1 * q1 - 2 * q3 * q3) + 2 * v2 * (q2 * q3 - q1 * q0);
    o[2] = 2 * v0 * (q3 * q1 - q0 * q2) + 2 * v1 * (q0 * q1 + q3 * q2) + v2 * (1 - 2 * q1 * q1 - 2 * q2 * q2);
}

static void normq(double *q)
{
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int j;
    if (n != 0.0)
        for (j = 0; j < 4; j++) q[j] /= n;
}

static void inv3(const double *m, double *o)
{
    double a = m[0], b = m[1], c = m[2], d = m[3], e = m[4], f = m[5], g = m[6], h = m[7], k = m[8];
    double c00 = e * k - f * h, c01 = f * g - d * k, c02 = d * h - e * g;
    double det = a * c00 + b * c01 + c * c02;
    o[0] = c00 / det; o[1] = (c * h - b * k) / det; o[2] = (b * f - c * e) / det;
    o[3] = c01 / det; o[4] = (a * k - c * g) / det; o[5] = (c * d - a * f) / det;
    o[6] = c02 / det; o[7] = (b * g - a * h) / det; o[8] = (a * e - b * d) / det;
}

static void bias_update(double *s, const double *r, const double *e, const double *w)
{
    double t1[9], t2[9], t3[9], acc;
    const double *p = s + S_BIAS_P;
    int i, j, m;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += p[3 * i + m] * r[3 * j + m];
            t1[3 * i + j] = acc;
        }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += r[3 * i + m] * t1[3 * m + j];
            t2[3 * i + j] = acc + (i == j ? w[i] : 0.0);
        }
    inv3(t2, t3);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += t1[3 * i + m] * t3[3 * m + j];
            t2[3 * i + j] = acc;
        }
    for (i = 0; i < 3; i++) s[S_BIAS + i] += t2[3 * i] * e[0] + t2[3 * i + 1] * e[1] + t2[3 * i + 2] * e[2];
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += t2[3 * i + m] * r[3 * m + j];
            t3[3 * i + j] = acc;
        }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            for (acc = 0.0, m = 0; m < 3; m++) acc += t3[3 * i + m] * s[S_BIAS_P + 3 * m + j];
            t1[3 * i + j] = acc;
        }
    for (i = 0; i < 9; i++) s[S_BIAS_P + i] -= t1[i];
}

static double clip(double x, double lim) { return x < -lim ? -lim : (x > lim ? lim : x); }

static void q6(const double *s, double *o) { qmul(s + S_ACC_Q, s + S_GYR_Q, o); }

static void init_state(double *s, const double *c, const double *q0)
{
    int i;
    double n;
    for (i = 0; i < RT_STATE_LEN; i++) s[i] = NAN;
    if (q0 == NULL) {
        s[S_GYR_Q] = 1.0; s[S_GYR_Q + 1] = 0.0; s[S_GYR_Q + 2] = 0.0; s[S_GYR_Q + 3] = 0.0;
    } else {
        n = sqrt(q0[0] * q0[0] + q0[1] * q0[1] + q0[2] * q0[2] + q0[3] * q0[3]);
        for (i = 0; i < 4; i++) s[S_GYR_Q + i] = q0[i] / n;
    }
    s[S_ACC_Q] = 1.0; s[S_ACC_Q + 1] = 0.0; s[S_ACC_Q + 2] = 0.0; s[S_ACC_Q + 3] = 0.0;
    s[S_DELTA] = 0.0;
    for (i = 0; i < 3; i++) s[S_BIAS + i] = 0.0;
    for (i = 0; i < 9; i++) s[S_BIAS_P + i] = (i % 4 == 0) ? c[C_BIAS_P0] : 0.0;
    s[S_REST_T] = 0.0; s[S_REST] = 0.0;
    for (i = 0; i < 3; i++) s[S_REST_GYR + i] = 0.0;
    s[S_MAG_REF_NORM] = 0.0; s[S_MAG_REF_DIP] = 0.0; s[S_MAG_UNDIST_T] = 0.0;
    s[S_MAG_REJECT_T] = c[C_MAG_MAX_REJ];
    s[S_MAG_CAND_NORM] = -1.0; s[S_MAG_CAND_DIP] = 0.0; s[S_MAG_CAND_T] = 0.0;
    s[S_MAG_DIST] = 1.0; s[S_K_MAG_INIT] = 1.0;
}

void rt_init(rt_filter *f, const rt_params *p, double dt_s, const double q0[4])
{
    coefficients(p, dt_s, p->use_mag, f->c);
    f->dt = dt_s;
    init_state(f->s, f->c, q0);
}

static void step(const double *c, double *s, const double *gyr, const double *acc, const double *mag)
{
    double dt = c[C_DT], clip_r = c[C_BIAS_CLIP];
    int rest_bias = c[C_REST_BIAS] != 0.0, motion_bias = c[C_MOTION_BIAS] != 0.0, mag_rej = c[C_MAG_REJ] != 0.0;
    double x[9], y[9], r[9], e[3], w[3], q[4], p6[4], u[3], h[3], d0, d1, d2, un, ang, ex, ey, ez, en, qw;
    int j;
    /* gyroscope: rest detection, strapdown integration */
    if (rest_bias || mag_rej) {
        lp(s, S_REST_GYR_LP, 3, gyr, y, c + C_REST_LP, c[C_REST_TAU], dt);
        d0 = gyr[0] - y[0]; d1 = gyr[1] - y[1]; d2 = gyr[2] - y[2];
        if (d0 * d0 + d1 * d1 + d2 * d2 >= c[C_REST_TH_GYR] * c[C_REST_TH_GYR]
            || fmax(fabs(y[0]), fmax(fabs(y[1]), fabs(y[2]))) > clip_r) {
            s[S_REST_T] = 0.0;
            s[S_REST] = 0.0;
        }
        for (j = 0; j < 3; j++) s[S_REST_GYR + j] = y[j];
    }
    for (j = 0; j < 3; j++) u[j] = gyr[j] - s[S_BIAS + j];
    un = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (un > DBL_EPSILON) {
        double dq[4], sw;
        ang = un * dt;
        sw = sin(ang / 2.0) / un;
        dq[0] = cos(ang / 2.0); dq[1] = sw * u[0]; dq[2] = sw * u[1]; dq[3] = sw * u[2];
        qmul(s + S_GYR_Q, dq, q);
        for (j = 0; j < 4; j++) s[S_GYR_Q + j] = q[j];
        normq(s + S_GYR_Q);
    }
    /* accelerometer: inclination correction from the low-passed inertial-frame acc, gyro bias */
    if (!(acc[0] == 0.0 && acc[1] == 0.0 && acc[2] == 0.0)) {
        if (rest_bias) {
            lp(s, S_REST_ACC_LP, 3, acc, y, c + C_REST_LP, c[C_REST_TAU], dt);
            d0 = acc[0] - y[0]; d1 = acc[1] - y[1]; d2 = acc[2] - y[2];
            if (d0 * d0 + d1 * d1 + d2 * d2 >= c[C_REST_TH_ACC] * c[C_REST_TH_ACC]) {
                s[S_REST_T] = 0.0;
                s[S_REST] = 0.0;
            } else {
                s[S_REST_T] += dt;
                if (s[S_REST_T] >= c[C_REST_MIN]) s[S_REST] = 1.0;
            }
        }
        rotate(s + S_GYR_Q, acc, x);
        lp(s, S_ACC_LP, 3, x, y, c + C_ACC_LP, c[C_TAU_ACC], dt);
        rotate(s + S_ACC_Q, y, h);
        ex = h[0]; ey = h[1]; ez = h[2];
        en = sqrt(ex * ex + ey * ey + ez * ez);
        if (en != 0.0) { ex /= en; ey /= en; ez /= en; }
        qw = sqrt((ez + 1.0) / 2.0);
        {
            double cq[4];
            if (qw > 1e-6) { cq[0] = qw; cq[1] = 0.5 * ey / qw; cq[2] = -0.5 * ex / qw; cq[3] = 0.0; }
            else { cq[0] = 0.0; cq[1] = 1.0; cq[2] = 0.0; cq[3] = 0.0; }
            qmul(cq, s + S_ACC_Q, q);
        }
        for (j = 0; j < 4; j++) s[S_ACC_Q + j] = q[j];
        normq(s + S_ACC_Q);
        if (motion_bias || rest_bias) {
            double b0 = s[S_BIAS], b1 = s[S_BIAS + 1], b2 = s[S_BIAS + 2], a[9];
            int has = 1;
            q6(s, p6);
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
            lp(s, S_R_LP, 9, a, r, c + C_ACC_LP, c[C_TAU_ACC], dt);
            lp(s, S_BLP, 2, x, y, c + C_ACC_LP, c[C_TAU_ACC], dt);
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
                for (j = 0; j < 3; j++) e[j] = clip(e[j], clip_r);
                bias_update(s, r, e, w);
                for (j = 0; j < 3; j++) s[S_BIAS + j] = clip(s[S_BIAS + j], clip_r);
            }
        }
    }
    /* magnetometer: the heading offset delta only */
    if (c[C_USE_MAG] != 0.0 && mag != NULL && !(mag[0] == 0.0 && mag[1] == 0.0 && mag[2] == 0.0)) {
        double k, dis, dd, kin;
        q6(s, p6);
        rotate(p6, mag, h);
        if (mag_rej) {
            double nrm = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]), nd, dip, kref = c[C_K_MAG_REF], refn, cn;
            x[0] = nrm;
            x[1] = -asin(h[2] / nrm);
            if (c[C_MAG_TAU] > 0.0) lp(s, S_MAG_LP, 2, x, y, c + C_MAG_LP, c[C_MAG_TAU], dt);
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
                double gl = sqrt(s[S_REST_GYR] * s[S_REST_GYR] + s[S_REST_GYR + 1] * s[S_REST_GYR + 1]
                                 + s[S_REST_GYR + 2] * s[S_REST_GYR + 2]);
                if (gl >= c[C_MAG_NEW_MIN_GYR] || (c[C_MAG_FIRST_AT_REST] != 0.0 && refn == 0.0))
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
        dis = atan2(h[0], h[1]) - s[S_DELTA];
        if (dis > RT_PI) dis -= 2.0 * RT_PI;
        else if (dis < -RT_PI) dis += 2.0 * RT_PI;
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
                s[S_MAG_REJECT_T] = fmax(s[S_MAG_REJECT_T] - c[C_MAG_REJ_FACTOR] * dt, 0.0);
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
        if (dd > RT_PI) dd -= 2.0 * RT_PI;
        else if (dd < -RT_PI) dd += 2.0 * RT_PI;
        s[S_DELTA] = dd;
    }
}

void rt_update(rt_filter *f, const rt_params *p, const double gyr[3], const double acc[3], const double mag[3],
               double dt_s)
{
    if (dt_s != f->dt) { /* a new rate: the gains follow the time constants */
        coefficients(p, dt_s, f->c[C_USE_MAG] != 0.0, f->c);
        f->dt = dt_s;
    }
    step(f->c, f->s, gyr, acc, mag);
}

void rt_quaternion(const rt_filter *f, double q[4])
{
    double p[4], cd, sd;
    q6(f->s, p);
    if (f->c[C_USE_MAG] != 0.0) {
        cd = cos(f->s[S_DELTA] / 2.0);
        sd = sin(f->s[S_DELTA] / 2.0);
        q[0] = cd * p[0] - sd * p[3];
        q[1] = cd * p[1] - sd * p[2];
        q[2] = cd * p[2] + sd * p[1];
        q[3] = cd * p[3] + sd * p[0];
    } else {
        q[0] = p[0]; q[1] = p[1]; q[2] = p[2]; q[3] = p[3];
    }
}

void rt_run(const rt_params *p, long n, const double *gyr, const double *acc, const double *mag, double dt_s,
            const double *q0, double *q_out)
{
    rt_filter f;
    long i;
    coefficients(p, dt_s, p->use_mag && mag != NULL, f.c);
    f.dt = dt_s;
    init_state(f.s, f.c, q0);
    for (i = 0; i < n; i++) {
        step(f.c, f.s, gyr + 3 * i, acc + 3 * i, mag != NULL ? mag + 3 * i : NULL);
        rt_quaternion(&f, q_out + 4 * i);
    }
}
