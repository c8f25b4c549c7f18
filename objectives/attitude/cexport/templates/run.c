/* ---- whole recordings ----------------------------------------------------------------------------- */
void PFX_run(const PFX_params *p, long n, const PFX_real *gyr, const PFX_real *acc, const PFX_real *mag,
             PFX_real dt_s, const PFX_real *q0, PFX_real *q_out)
{
    PFX_filter f;
    long i;
    PFX_init(&f, p);
    if (q0 != 0)
        PFX_set_quaternion(&f, q0);
    for (i = 0; i < n; i++) {
        PFX_update(&f, gyr + 3 * i, acc + 3 * i, mag != 0 ? mag + 3 * i : 0, dt_s);
        PFX_quaternion(&f, q_out + 4 * i);
    }
}
