/* realtime attitude filter (objectives/attitude/filters/realtime.py), C99, double precision.
 *
 * The design of VQF (D. Laidig, T. Seel, Information Fusion 91:187-204, 2023) with the project's two additions
 * (first field accepted at rest, fast heading re-convergence); a port of objectives/attitude/filters/
 * _realtime_kernel.py with the same coefficient and state layouts, checked against it in
 * tests/attitude/test_realtime_c.py. No heap, no global state. libm: sqrt, exp, sin, cos, tan, asin, atan2.
 *
 * Units: gyr rad/s, acc m/s^2, mag any unit (NULL: 6-D), dt_s seconds. Output: sensor-to-earth quaternion
 * (w, x, y, z), earth frame ENU (x east, y north, z up).
 */
#ifndef REALTIME_H_
#define REALTIME_H_

#ifdef __cplusplus
extern "C" {
#endif

#define RT_COEF_LEN 45
#define RT_STATE_LEN 79

/* every value of the filter, in the units of its declaration (tuner describe realtime) */
typedef struct {
    double tau_acc_s, tau_mag_s;
    int use_mag, motion_bias, rest_bias, mag_rejection;
    double bias_sigma_init_dps, bias_forgetting_s, bias_clip_dps, bias_sigma_motion_dps, bias_vertical_forgetting,
        bias_sigma_rest_dps, rest_min_s, rest_filter_tau_s, rest_th_gyr_dps, rest_th_acc, mag_current_tau_s,
        mag_ref_tau_s, mag_norm_th, mag_dip_th_deg, mag_new_s, mag_new_first_s, mag_new_min_gyr_dps,
        mag_min_undisturbed_s, mag_max_rejection_s, mag_rejection_factor;
    int mag_first_at_rest;
    double mag_recover_tau_s;
} rt_params;

typedef struct {
    double c[RT_COEF_LEN];  /* per-sample coefficients derived from the values at dt */
    double s[RT_STATE_LEN]; /* everything carried from one sample to the next */
    double dt;
} rt_filter;

/* reset f to the values p at sample time dt_s; q0 NULL: the identity start of VQF, else the strapdown
   quaternion starts at q0 (ENU, sensor-to-earth: option start q0) */
void rt_init(rt_filter *f, const rt_params *p, double dt_s, const double q0[4]);
/* one sample; the coefficients are recomputed when dt_s differs from the last one */
void rt_update(rt_filter *f, const rt_params *p, const double gyr[3], const double acc[3], const double mag[3],
               double dt_s);
/* the sensor-to-earth quaternion (9-D with magnetometer, else 6-D) */
void rt_quaternion(const rt_filter *f, double q[4]);
/* a whole recording (n x 3 row-major; mag NULL: 6-D) at a fixed dt_s; q_out n x 4 */
void rt_run(const rt_params *p, long n, const double *gyr, const double *acc, const double *mag, double dt_s,
            const double *q0, double *q_out);

#ifdef __cplusplus
}
#endif

#endif /* REALTIME_H_ */
