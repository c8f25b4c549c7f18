/* ---- the thesis's 2-state tilt Kalman filter (ported from objectives/attitude/filters/kf1d/kernel.py,
        thesis eqs. 3.9-3.13, 3.17): the tilt about the sensor y axis from gyr[1], acc[0] and acc[2] ------ */
#define TILT_RUN 1 /* run.c: the state is the angle th alone */

#if AKF
/* ---- AKF1D (thesis 3.1.4): R_k = K_k rho, K_k the Sugeno system of eq. 3.24 / Table 3.2 over the packet
        measures of eqs. 3.19-3.22 (objectives/attitude/disturbance.py), held over the next packet ---------- */
static const real AKF_MF[2][3][4] = AKF_MF_INIT;   /* set parameters (fuzzy.trapmf; a tri has b == c) */
static const int AKF_KIND[2][3] = AKF_KIND_INIT;   /* 1 tri, 2 trap */
static const int AKF_RULES[AKF_NRULES][2] = AKF_RULES_INIT;
static const real AKF_CONS[AKF_NRULES] = AKF_CONS_INIT;

/* fuzzy.trapmf */
static real trapmf_(real x, real a, real b, real c, real d)
{
    if (x < a || x > d)
        return 0.0;
    if (x < b)
        return (x - a) / (b - a);
    if (x > c)
        return (d - x) / (d - c);
    return 1.0;
}

/* fuzzy.sugeno with min-AND: the weighted average of the singletons */
static real fis_(real f_hz, real a_g)
{
    real mu[2][3], x[2], num = 0.0, den = 0.0, w, m;
    int i, j, s;
    x[0] = f_hz;
    x[1] = a_g;
    for (j = 0; j < 2; j++)
        for (s = 0; s < 3; s++) {
            const real *p = AKF_MF[j][s];
            mu[j][s] = AKF_KIND[j][s] == 1 ? trapmf_(x[j], p[0], p[1], p[1], p[2])
                                            : trapmf_(x[j], p[0], p[1], p[2], p[3]);
        }
    for (i = 0; i < AKF_NRULES; i++) {
        w = 1.0;
        for (j = 0; j < 2; j++) {
            m = mu[j][AKF_RULES[i][j]];
            if (m < w)
                w = m;
        }
        num += w * AKF_CONS[i];
        den += w;
    }
    if (den > 0.0)
        return num / den;
    for (i = 0, num = 0.0; i < AKF_NRULES; i++)
        num += AKF_CONS[i];
    return num / AKF_NRULES;
}

/* exp(-2 pi i m / AKF_NFFT) = cs + i sn, 0 <= m < AKF_NFFT */
#ifdef AKF_TW_INIT
static const real AKF_TW[AKF_NFFT / 4 + 1] = AKF_TW_INIT; /* sin(2 pi r / AKF_NFFT), r <= AKF_NFFT / 4 */

static void twiddle_(int m, real *sn, real *cs)
{
    int quarter = AKF_NFFT / 4, r = m % quarter;
    real s = AKF_TW[r], c = AKF_TW[quarter - r];
    switch (m / quarter) { /* the angle is (m / quarter) pi / 2 + 2 pi r / AKF_NFFT */
    case 0: *cs = c; *sn = -s; break;
    case 1: *cs = -s; *sn = -c; break;
    case 2: *cs = -c; *sn = s; break;
    default: *cs = s; *sn = c; break;
    }
}
#else
static void twiddle_(int m, real *sn, real *cs)
{
    sincos_(-TWO_PI_ * (real)m / (real)AKF_NFFT, sn, cs);
}
#endif

/* a complete packet: the dominant gyro frequency up to f_thr (eqs. 3.19-3.21: zero-padded DFT of length
   AKF_NFFT, amplitudes 2 |W_i| / L, 0 below omega_thr) and the mean external acceleration (eq. 3.22) */
static void packet_done(PFX_filter *f)
{
    real best = -1.0, vib, re, im, sn, cs, amp;
    int i, k, best_i = 0;
    for (i = 0; i < AKF_NBINS; i++) {
        re = 0.0;
        im = 0.0;
        for (k = 0; k < AKF_WINDOW; k++) {
            twiddle_((i * k) % AKF_NFFT, &sn, &cs);
            re += f->buf[k] * cs;
            im += f->buf[k] * sn;
        }
        amp = SQRT(re * re + im * im) * (2.0 / (real)AKF_WINDOW);
        if (amp > best) {
            best = amp;
            best_i = i;
        }
    }
    vib = best < AKF_OMEGA_THR ? 0.0 : (real)best_i * AKF_DF;
    f->vib_hz = vib;
    f->ext_g = f->ext_sum / (real)AKF_WINDOW;
    f->kscale = fis_(vib, f->ext_g);
}

/* sample k into the current packet; a full packet updates the held scale */
static void packet_add(PFX_filter *f, const real *gyr, const real *acc)
{
    real a = SQRT(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2]);
    f->buf[f->nbuf] = gyr[1];
    f->ext_sum += fabs(a - 9.81) / 9.81;
    f->nbuf++;
    if (f->nbuf == AKF_WINDOW) {
        packet_done(f);
        f->nbuf = 0;
        f->ext_sum = 0.0;
    }
}
#endif

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    f->p = *p;
    f->started = 0;
    f->th = 0.0;
    f->b = 0.0;
    f->p00 = p->p0_theta;
    f->p01 = 0.0;
    f->p11 = p->p0_bias;
    f->prev_gyr = 0.0;
    f->dt_s = p->dt_s;
#if AKF
    f->nbuf = 0;
    f->ext_sum = 0.0;
    f->vib_hz = 0.0;
    f->ext_g = 0.0;
    f->kscale = fis_(0.0, 0.0); /* the first packet: no disturbance measured yet */
#endif
}

/* the tilt of a start quaternion (working frame ENU) from its up vector: kf1d.tilt_from_quat */
static real tilt_from_quat(const real q[4], real s)
{
    real w = q[0], x = q[1], y = q[2], z = q[3];
    real ux = 2.0 * (x * z - w * y), uz = w * w - x * x - y * y + z * z;
    return ATAN2(-s * ux, s * uz);
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    const PFX_params *pp = &f->p;
    real s = pp->up_sign, m00, m01, m11, z, res, sk, g0, g1;
    if (f->started < 2) { /* sample 0 is the initial state (theta0, 0), P0 */
        if (!f->started) {
            real q[4];
            start_quaternion(pp->init, pp->q0, acc, pp->use_mag ? mag : 0, q);
            f->th = tilt_from_quat(q, s);
        }
        f->prev_gyr = gyr[1];
        f->started = 2;
#if AKF
        packet_add(f, gyr, acc);
#endif
        return;
    }
    f->dt_s = dt;
    /* time update (3.11) with the previous gyro sample */
    f->th += dt * (f->prev_gyr - f->b);
    m00 = f->p00 - 2.0 * dt * f->p01 + dt * dt * f->p11 + pp->q00;
    m01 = f->p01 - dt * f->p11;
    m11 = f->p11 + pp->q11;
    f->prev_gyr = gyr[1];
    /* measurement update (3.12, 3.13) with the accelerometer angle (3.6), residual wrapped */
    z = ATAN2(-s * acc[0], s * acc[2]);
    res = z - f->th;
    if (res > PI_ || res < -PI_)
        res -= TWO_PI_ * floor_((res + PI_) / TWO_PI_);
#if AKF
    sk = m00 + pp->rho * f->kscale;
#else
    sk = m00 + pp->rho * 1.0;
#endif
    g0 = m00 / sk;
    g1 = m01 / sk;
    f->th += g0 * res;
    f->b += g1 * res;
    f->p00 = (1.0 - g0) * m00;
    f->p01 = (1.0 - g0) * m01;
    f->p11 = m11 - g1 * m01;
#if AKF
    packet_add(f, gyr, acc);
#endif
}

/* the rotation about y by the tilt, (cos(theta/2), 0, sin(theta/2), 0), in the frame of up_sign */
void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    real sn, cs;
    sincos_(0.5 * f->th, &sn, &cs);
    q[0] = cs;
    q[1] = 0.0;
    q[2] = sn;
    q[3] = 0.0;
}

/* start from a known orientation (its tilt about y) instead of the first sample's */
void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    from_output(q, w);
    f->th = tilt_from_quat(w, f->p.up_sign);
    f->started = 1;
}

void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3])
{
    b[0] = 0.0;
    b[1] = f->b;
    b[2] = 0.0;
    (void)to_output;
}
