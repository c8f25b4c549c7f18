/* ---- what the ports of a ROS node's filters share (state vector s with S_Q, S_PHASE and S_LEN): the start from
   the first sample unless a start is given; node_given(f, q) (the port's) takes a start in the working frame */
static void node_given(PFX_filter *f, const real q[4]);

void PFX_init(PFX_filter *f, const PFX_params *p)
{
    int i;
    f->p = *p;
    for (i = 0; i < S_LEN; i++) f->s[i] = 0.0;
    f->s[S_Q] = 1.0;
    if (p->init == 2)
        node_given(f, p->q0);
}

void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    real w[4];
    from_output(q, w);
    node_given(f, w);
}
