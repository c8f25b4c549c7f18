/* ---- robust blocks (ported from objectives/attitude/filters/robust.py) ------------------------------ */
/* gain of a first-order low-pass, 1 - exp(-dt/tau) (Laidig & Seel 2023, eq. 8); tau = 0: 1 */
static real lp_gain(real tau_s, real dt_s)
{
    return tau_s == 0.0 ? 1.0 : 1.0 - EXP(-dt_s / tau_s);
}

/* block (a) coefficients: mag_dist_coefficients(dt, norm_th, dip_th_deg, max_rejection_s), the rest default */
static void mag_dist_coefficients(real *c, real dt, real norm_th, real dip_th_deg, real max_rejection_s)
{
    c[0] = dt; c[1] = norm_th; c[2] = DEG2RAD(dip_th_deg); c[3] = lp_gain(20.0, dt); c[4] = lp_gain(0.05, dt);
    c[5] = 0.5; c[6] = 20.0; c[7] = 5.0; c[8] = DEG2RAD(20.0); c[9] = max_rejection_s; c[10] = 2.0;
}

static void mag_dist_state(real *s, int n)
{
    int i;
    for (i = 0; i < n; i++)
        s[i] = 0.0;
    s[3] = -1.0;
    s[6] = 1.0;
}

/* block (b) coefficients: rest_coefficients(dt, th_acc=th_acc, tau_bias_s=tau_bias_s), the rest default */
static void rest_coefficients(real *c, real dt, real th_acc, real tau_bias_s)
{
    real th_g = DEG2RAD(2.0);
    c[0] = dt; c[1] = lp_gain(0.5, dt); c[2] = th_g * th_g; c[3] = th_acc * th_acc; c[4] = 1.5;
    c[5] = lp_gain(tau_bias_s, dt); c[6] = DEG2RAD(2.0);
}

static real clampr(real v, real lo, real hi)
{
    return v > hi ? hi : (v < lo ? lo : v);
}

/* one magnetometer sample in an inclination-corrected earth frame (z up): robust._mag_dist_update */
static real mag_dist_update(real *s, const real *c, real mx, real my, real mz, real gyr_lp_norm)
{
    real dt = c[0], norm_th = c[1], dip_th = c[2], k_ref = c[3], k_cur = c[4];
    real min_und = c[5], new_t = c[6], new_first = c[7], new_gyr = c[8], max_rej = c[9], fac = c[10];
    real n = SQRT(mx * mx + my * my + mz * mz), dip, t;
    if (n == 0.0)
        return 1.0;
    dip = -ASIN(clampr(mz / n, -1.0, 1.0));
    if (s[10] == 0.0) {
        s[8] = n;
        s[9] = dip;
    } else {
        s[8] += k_cur * (n - s[8]);
        s[9] += k_cur * (dip - s[9]);
    }
    s[10] += 1.0;
    n = s[8];
    dip = s[9];
    if (fabs(n - s[0]) < norm_th * s[0] && fabs(dip - s[1]) < dip_th) {
        s[2] += dt;
        if (s[2] >= min_und) {
            s[6] = 0.0;
            s[0] += k_ref * (n - s[0]);
            s[1] += k_ref * (dip - s[1]);
        }
    } else {
        s[2] = 0.0;
        s[6] = 1.0;
    }
    if (fabs(n - s[3]) < norm_th * s[3] && fabs(dip - s[4]) < dip_th) {
        if (gyr_lp_norm >= new_gyr)
            s[5] += dt;
        s[3] += k_ref * (n - s[3]);
        s[4] += k_ref * (dip - s[4]);
        if (s[6] != 0.0 && (s[5] >= new_t || (s[0] == 0.0 && s[5] >= new_first))) {
            s[0] = s[3];
            s[1] = s[4];
            s[6] = 0.0;
            s[2] = min_und;
        }
    } else {
        s[5] = 0.0;
        s[3] = n;
        s[4] = dip;
    }
    if (s[6] != 0.0) {
        if (s[7] <= max_rej) {
            s[7] += dt;
            return 0.0;
        }
        return 1.0 / fac;
    }
    t = s[7] - fac * dt;
    s[7] = t > 0.0 ? t : 0.0;
    return 1.0;
}

/* one gyro (rad/s) and acc sample; rest flag and bias in place, 1 at rest: robust._rest_update */
static int rest_update(real *s, const real *c, real gx, real gy, real gz, real ax, real ay, real az)
{
    real dt = c[0], k = c[1], th_g2 = c[2], th_a2 = c[3], min_t = c[4], k_b = c[5], clip = c[6];
    real dg, da, m, b;
    int still, i;
    if (s[11] == 0.0) {
        s[0] = gx; s[1] = gy; s[2] = gz;
        s[3] = ax; s[4] = ay; s[5] = az;
    } else {
        s[0] += k * (gx - s[0]);
        s[1] += k * (gy - s[1]);
        s[2] += k * (gz - s[2]);
        s[3] += k * (ax - s[3]);
        s[4] += k * (ay - s[4]);
        s[5] += k * (az - s[5]);
    }
    s[11] += 1.0;
    dg = (gx - s[0]) * (gx - s[0]) + (gy - s[1]) * (gy - s[1]) + (gz - s[2]) * (gz - s[2]);
    da = (ax - s[3]) * (ax - s[3]) + (ay - s[4]) * (ay - s[4]) + (az - s[5]) * (az - s[5]);
    m = fabs(s[0]);
    if (fabs(s[1]) > m)
        m = fabs(s[1]);
    if (fabs(s[2]) > m)
        m = fabs(s[2]);
    still = dg < th_g2 && da < th_a2 && m <= clip;
    if (still)
        s[6] += dt;
    else
        s[6] = 0.0;
    s[7] = (still && s[6] >= min_t) ? 1.0 : 0.0;
    if (s[7] != 0.0) {
        for (i = 0; i < 3; i++) {
            b = s[8 + i] + k_b * (s[i] - s[8 + i]);
            s[8 + i] = clampr(b, -clip, clip);
        }
    }
    return s[7] != 0.0;
}

/* v rotated by q (sign +1) or by conj(q) (sign -1): robust._rot */
static void rot_(real qw, real qx, real qy, real qz, real vx, real vy, real vz, real sign, real out[3])
{
    real tx, ty, tz;
    qx = sign * qx;
    qy = sign * qy;
    qz = sign * qz;
    tx = 2.0 * (qy * vz - qz * vy);
    ty = 2.0 * (qz * vx - qx * vz);
    tz = 2.0 * (qx * vy - qy * vx);
    out[0] = vx + qw * tx + qy * tz - qz * ty;
    out[1] = vy + qw * ty + qz * tx - qx * tz;
    out[2] = vz + qw * tz + qx * ty - qy * tx;
}

/* the acc low-passed in the earth frame of q, back in sensor coordinates: robust.acc_lp_step */
static void acc_lp_update(real *s, real k, const real *q, real ax, real ay, real az, real out[3])
{
    real e[3];
    rot_(q[0], q[1], q[2], q[3], ax, ay, az, 1.0, e);
    if (s[3] == 0.0) {
        s[0] = e[0]; s[1] = e[1]; s[2] = e[2];
    } else {
        s[0] += k * (e[0] - s[0]);
        s[1] += k * (e[1] - s[1]);
        s[2] += k * (e[2] - s[2]);
    }
    s[3] += 1.0;
    rot_(q[0], q[1], q[2], q[3], s[0], s[1], s[2], -1.0, out);
}

/* ---- the blocks' part of the init and set_rate of every filter that has them (members ms, rs, as, mc, rc,
        alp_k, dt_s, started, p of the struct) ---------------------------------------------------------- */
/* the params and the blocks' start state; the filter zeroes its own state and then calls its set_rate */
static void robust_init(PFX_filter *f, const PFX_params *p)
{
    int i;
    f->p = *p;
    f->started = 0;
    mag_dist_state(f->ms, COUNT_(f->ms));
    for (i = 0; i < COUNT_(f->rs); i++)
        f->rs[i] = 0.0;
    for (i = 0; i < COUNT_(f->as); i++)
        f->as[i] = 0.0;
}

/* the blocks' coefficients at dt; rest detection with acc threshold th_acc and bias time constant tau_bias_s */
static void robust_rate(PFX_filter *f, real dt, real th_acc, real tau_bias_s)
{
    const PFX_params *p = &f->p;
    f->dt_s = dt;
    mag_dist_coefficients(f->mc, dt, p->mag_norm_th, p->mag_dip_th_deg, p->mag_max_rejection_s);
    rest_coefficients(f->rc, dt, th_acc, tau_bias_s);
    f->alp_k = lp_gain(p->acc_lp_tau_s > 0.0 ? p->acc_lp_tau_s : 0.0, dt);
}
