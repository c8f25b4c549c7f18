
static PFX_real clip(PFX_real v, PFX_real lo, PFX_real hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* a PID block's coefficients from its ideal form (K, Ti, Td) at the period, the declaration's common values
   and its output limits (Astrom & Murray, Feedback Systems, 2nd ed., section 11.5; the loop's pid_coeffs) */
static void pid_coeffs(PFX_pid_coeffs *k, PFX_real K, PFX_real Ti, PFX_real Td, PFX_real u_min, PFX_real u_max,
                       const PFX_params *p)
{
    PFX_real n = p->N, h = p->period_s, tt;
    k->K = K;
    k->b = p->b;
    k->c = p->c;
    k->ki = isinf(Ti) ? (PFX_real)0 : K * h / Ti;
    k->ad = Td > 0 ? Td / (Td + n * h) : (PFX_real)0;
    k->bd = Td > 0 ? K * Td * n / (Td + n * h) : (PFX_real)0;
    tt = p->Tt_s != 0 ? p->Tt_s : (Td > 0 ? (PFX_real)sqrt(Ti * Td) : (PFX_real)0.5 * Ti);
    k->kt = isinf(tt) ? (PFX_real)0 : h / tt;
    k->aw = p->antiwindup;
    k->u_min = u_min;
    k->u_max = u_max;
}

/* one PID block: v = K (b r - y) + I + D, D <- ad D + bd ((c r - y) - (c r - y)_prev), u = clip(v),
   I <- I + ki (r - y) + anti-windup (back-calculation kt (u - v), or no integration while saturated
   towards the error) */
static PFX_real pid_step(const PFX_pid_coeffs *k, PFX_pid_state *s, PFX_real r, PFX_real y)
{
    PFX_real yc = k->c * r - y, v, u, e;
    if (!s->started) {
        s->yc_prev = yc;
        s->started = 1;
    }
    s->D = k->ad * s->D + k->bd * (yc - s->yc_prev);
    s->yc_prev = yc;
    v = k->K * (k->b * r - y) + s->I + s->D;
    u = clip(v, k->u_min, k->u_max);
    e = r - y;
    if (k->aw == PFX_ANTIWINDUP_BACKCALC) {
        s->I += k->ki * e + k->kt * (u - v);
    } else if (k->aw == PFX_ANTIWINDUP_CLAMP) {
        if (!((v > k->u_max && e > 0) || (v < k->u_min && e < 0)))
            s->I += k->ki * e;
    } else {
        s->I += k->ki * e;
    }
    return u;
}
