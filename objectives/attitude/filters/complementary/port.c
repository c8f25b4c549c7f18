/* ---- LCF / NCF / CCF on ZYX Euler angles (ported from objectives/attitude/filters/complementary/kernel.py;
        Narkhede et al. 2021, eqs. (1)-(14)) ----------------------------------------------------------- */

/* angle wrapped to [-pi, pi): steps._wrap */
static real wrap_(real a)
{
    if (fabs(a) < 3.0) /* (a + pi) / (2 pi) in (0.02, 0.98): the floor below is 0, no division needed */
        return a;
    return a - TWO_PI_ * floor_((a + PI_) / TWO_PI_);
}

/* q = q_z(psi) q_y(theta) q_x(phi): steps._quat_zyx */
static void quat_zyx(real phi, real th, real psi, real q[4])
{
    real c1, s1, c2, s2, c3, s3;
    sincos_(0.5 * phi, &s1, &c1);
    sincos_(0.5 * th, &s2, &c2);
    sincos_(0.5 * psi, &s3, &c3);
    q[0] = c1 * c2 * c3 + s1 * s2 * s3;
    q[1] = s1 * c2 * c3 - c1 * s2 * s3;
    q[2] = c1 * s2 * c3 + s1 * c2 * s3;
    q[3] = c1 * c2 * s3 - s1 * s2 * c3;
}

/* (roll, pitch, yaw) of a quaternion: complementary.euler_zyx_from_quat */
static void euler_from_quat(const real q[4], real e[3])
{
    real w = q[0], x = q[1], y = q[2], z = q[3], s = 2.0 * (w * y - z * x);
    e[0] = ATAN2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
    e[1] = ASIN(s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
    e[2] = ATAN2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

/* (1 - exp(-x)) without cancellation for small x: -expm1(-x) */
static real one_minus_exp_neg(real x)
{
    if (fabs(x) < 1e-2)
        return x * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0)))));
    return 1.0 - EXP(-x);
}

/* the per-sample gains at dt (filters._ComplementaryBase.kernel_setup) and the blocks' coefficients */
static void set_rate(PFX_filter *f, real dt)
{
    const PFX_params *p = &f->p;
    real alpha = p->alpha, kp = p->Kp;
    if (p->alpha_mode == PFX_ALPHA_MODE_TAU) { /* tau: tau_gains */
        alpha = p->tau_s / (p->tau_s + dt);
        kp = one_minus_exp_neg(kp * dt) / dt;
    } else if (!(p->alpha_rate_hz == 0.0 || alpha <= 0.0 || alpha >= 1.0)) { /* alpha_at_rate */
        real tau = alpha / (p->alpha_rate_hz * (1.0 - alpha));
        alpha = tau / (tau + dt);
    }
    f->alpha = alpha;
    f->kp = kp;
    robust_rate(f, dt, 0.5 * p->g / 9.81, 2.0);
}

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    int i;
    robust_init(f, p);
    for (i = 0; i < 3; i++) {
        f->x[i] = 0.0;
        f->integ[i] = 0.0;
        f->out[i] = 0.0;
    }
    set_rate(f, p->dt_s);
}

static real atan2_mag_yaw(real mx, real my, real mz, real sphi, real cphi, real sth, real cth)
{
    return ATAN2(mz * sphi - my * cphi, mx * cth + my * sth * sphi + mz * sth * cphi);
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    const PFX_params *pp = &f->p;
    int use_mag = pp->use_mag && mag != 0, static_ = pp->alpha_mode == PFX_ALPHA_MODE_STATIC, acc_ok, mag_ok = 0, yaw_ok;
    int use_rej = pp->mag_rejection, use_alp = pp->acc_lp_tau_s > 0.0;
    real p = 0.0, q = 0.0, r = 0.0, phi, th, psi, sp, cp, st, ct, u, d0, d1, d2, dx, dy, dz, an;
    real mx = 0.0, my = 0.0, mz = 0.0, gm = pp->mag_weight, phi_a = 0.0, th_a = 0.0, psi_m = 0.0;
    real alpha, kp, ki = pp->Ki, blend, o0, o1, o2;
    if (!f->started) {
        real q0[4];
        start_quaternion(pp->init, pp->q0, acc, use_mag ? mag : 0, q0);
        euler_from_quat(q0, f->x);
        f->started = 1;
    }
    if (dt != f->dt_s)
        set_rate(f, dt);
    alpha = f->alpha;
    kp = f->kp;
    blend = 1.0 - alpha;
    phi = f->x[0];
    th = f->x[1];
    psi = f->x[2];
    if (finite3(gyr)) {
        p = gyr[0];
        q = gyr[1];
        r = gyr[2];
    }
    sincos_(phi, &sp, &cp);
    sincos_(th, &st, &ct);
    {
        real cth = ct;
        if (fabs(ct) < 1e-6)
            ct = ct >= 0.0 ? 1e-6 : -1e-6;
        u = q * sp + r * cp;
        /* eqs. (1)-(3), standard ZYX kinematics */
        d0 = p + u * st / ct;
        d1 = q * cp - r * sp;
        d2 = u / ct;
        dx = -acc[0];
        dy = -acc[1];
        dz = -acc[2];
        an = dx * dx + dy * dy + dz * dz;
        acc_ok = an > 0.0 && an < (real)INFINITY;
        if (use_alp && acc_ok) { /* block (c): earth-frame low-pass with the current estimate */
            real qb[4], lp[3], n2;
            quat_zyx(phi, th, psi, qb);
            acc_lp_update(f->as, f->alp_k, qb, -dx, -dy, -dz, lp);
            dx = -lp[0];
            dy = -lp[1];
            dz = -lp[2];
            n2 = dx * dx + dy * dy + dz * dz;
            acc_ok = n2 > 0.0 && n2 < (real)INFINITY;
        }
        if (acc_ok && pp->acc_gate < (real)INFINITY)
            acc_ok = fabs(SQRT(an) - pp->g) <= pp->acc_gate * pp->g;
        if (use_mag) {
            real n2;
            mx = mag[0];
            my = mag[1];
            mz = mag[2];
            n2 = mx * mx + my * my + mz * mz;
            mag_ok = n2 > 0.0 && n2 < (real)INFINITY;
        }
        if (use_rej) { /* block (a): the field in the level frame of the current roll and pitch, z up */
            rest_update(f->rs, f->rc, p, q, r, -acc[0], -acc[1], -acc[2]);
            if (mag_ok) {
                real v2 = sp * my + cp * mz, lx = cth * mx + st * v2, ly = cp * my - sp * mz;
                real lz = -st * mx + cth * v2, *rs = f->rs;
                real gl = SQRT(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2]);
                gm = mag_dist_update(f->ms, f->mc, lx, ly, -lz, gl);
                gm = f->ms[0] == 0.0 ? pp->mag_weight : gm * pp->mag_weight;
            }
        }
    }
    f->mag_gain = gm;
    yaw_ok = acc_ok && mag_ok && gm > 0.0;
    if (acc_ok) {
        real spa, cpa, sta, cta, e0, e1, e2 = 0.0;
        phi_a = ATAN2(dy, dz);
        sincos_(phi_a, &spa, &cpa);
        th_a = ATAN2(-dx, dy * spa + dz * cpa);
        e0 = wrap_(phi_a - phi);
        e1 = wrap_(th_a - th);
        if (yaw_ok) {
            sincos_(th_a, &sta, &cta);
            psi_m = atan2_mag_yaw(mx, my, mz, spa, cpa, sta, cta);
            e2 = gm * wrap_(psi_m - psi);
        }
        if (static_) { /* eq. (14): the PI acts on x_a - x_hat = alpha (x_a - integrator) */
            e0 *= alpha;
            e1 *= alpha;
            e2 *= alpha;
        }
        /* eqs. (10), (12) */
        f->integ[0] = f->integ[0] + ki * e0 * dt;
        d0 = d0 + kp * e0;
        f->integ[1] = f->integ[1] + ki * e1 * dt;
        d1 = d1 + kp * e1;
        if (yaw_ok) {
            f->integ[2] = f->integ[2] + ki * e2 * dt;
            d2 = d2 + kp * e2;
        }
    }
    d0 += f->integ[0];
    d1 += f->integ[1];
    d2 += f->integ[2];
    /* gyro (NCF) prediction, pitch kept in [-pi/2, pi/2] */
    phi = phi + dt * d0;
    th = th + dt * d1;
    psi = psi + dt * d2;
    if (th > 0.5 * PI_) {
        th = PI_ - th;
        phi += PI_;
        psi += PI_;
    } else if (th < -0.5 * PI_) {
        th = -PI_ - th;
        phi += PI_;
        psi += PI_;
    }
    /* eqs. (8), (14): linear blend with the measurement angles, fed back (per sample) or static */
    o0 = phi;
    o1 = th;
    o2 = psi;
    if (acc_ok && blend != 0.0) {
        o0 = phi + blend * wrap_(phi_a - phi);
        o1 = th + blend * wrap_(th_a - th);
        if (yaw_ok)
            o2 = psi + blend * gm * wrap_(psi_m - psi);
    }
    o0 = wrap_(o0);
    o2 = wrap_(o2);
    if (static_) {
        phi = wrap_(phi);
        psi = wrap_(psi);
    } else {
        phi = o0;
        th = o1;
        psi = o2;
    }
    f->x[0] = phi;
    f->x[1] = th;
    f->x[2] = psi;
    f->out[0] = o0;
    f->out[1] = o1;
    f->out[2] = o2;
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    real w[4];
    quat_zyx(f->out[0], f->out[1], f->out[2], w);
    to_output(w, q);
}

void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    from_output(q, w);
    euler_from_quat(w, f->x);
    f->started = 1;
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    b[0] = -f->integ[0];
    b[1] = -f->integ[1];
    b[2] = -f->integ[2];
}
