/* ---- the public API: the streaming functions above are static, so that the whole-recording loop below
        inlines them also in a shared library (an exported function called from the same library is not
        inlined there, the dynamic linker may replace it); the exported names call them ---------------- */
void PFX_init(PFX_filter *f, const PFX_params *p)
{
    PFX_init_(f, p);
}

void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt)
{
    PFX_update_(f, gyr, acc, mag, dt);
}

void PFX_quaternion(const PFX_filter *f, PFX_real q[4])
{
    PFX_quaternion_(f, q);
}

void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4])
{
    PFX_set_quaternion_(f, q);
}

/* ---- whole recordings ----------------------------------------------------------------------------- */
void PFX_run(const PFX_params *p, long n, const PFX_real *gyr, const PFX_real *acc, const PFX_real *mag,
             PFX_real dt_s, const PFX_real *q0, PFX_real *q_out)
{
    PFX_filter f;
    long i;
    PFX_init_(&f, p);
    if (q0 != 0)
        PFX_set_quaternion_(&f, q0);
#ifdef TILT_RUN
    /* the tilt filters: the angles first, then their quaternions (a loop without a carried dependency,
       so that the processor overlaps the sines and cosines of successive samples) */
    for (i = 0; i < n; i++) {
        PFX_update_(&f, gyr + 3 * i, acc + 3 * i, mag != 0 ? mag + 3 * i : 0, dt_s);
        q_out[4 * i] = f.th;
    }
    for (i = 0; i < n; i++) {
        f.th = q_out[4 * i];
        PFX_quaternion_(&f, q_out + 4 * i);
    }
#else
    for (i = 0; i < n; i++) {
        PFX_update_(&f, gyr + 3 * i, acc + 3 * i, mag != 0 ? mag + 3 * i : 0, dt_s);
        PFX_quaternion_(&f, q_out + 4 * i);
    }
#endif
}
