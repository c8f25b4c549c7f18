
void PFX_reset(PFX_controller *c)
{
    int i;
    for (i = 0; i < PFX_N_BLOCKS; ++i) {
        c->st[i].I = 0;
        c->st[i].D = 0;
        c->st[i].yc_prev = 0;
        c->st[i].started = 0;
    }
    for (i = 0; i < PFX_N_U; ++i)
        c->u_prev[i] = 0;
}

void PFX_init(PFX_controller *c, const PFX_params *p)
{
    c->p = *p;
    p = &c->p;
@INIT@
    c->du_max = p->act_rate_limit * p->period_s;
    PFX_reset(c);
}

void PFX_update(PFX_controller *c, PFX_real r, const PFX_real *meas, PFX_real *u)
{
    const PFX_params *p = &c->p;
    int i;
    for (i = 0; i < PFX_N_U; ++i)
        u[i] = 0;
@CONTROL@
    /* the actuator: saturation, rate limit, quantum */
    for (i = 0; i < PFX_N_U; ++i) {
        PFX_real v = clip(u[i], p->act_u_min, p->act_u_max);
        if (c->du_max > 0)
            v = clip(v, c->u_prev[i] - c->du_max, c->u_prev[i] + c->du_max);
        if (p->act_quantum > 0)
            v = p->act_quantum * (PFX_real)floor(v / p->act_quantum + (PFX_real)0.5);
        u[i] = v;
        c->u_prev[i] = v;
    }
}

size_t PFX_controller_size(void)
{
    return sizeof(PFX_controller);
}
