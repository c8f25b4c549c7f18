#ifndef PFX_H_
#define PFX_H_

#ifdef __cplusplus
extern "C" {
#endif

typedef @REAL@ PFX_real;
@ENUMS@

/* the filter's complete configuration (PFX_tuned holds the tuned values) */
typedef struct {
@PARAMS@
} PFX_params;

/* the whole state of one filter (no heap, no globals): allocate it where you like */
typedef struct {
@STATE@
} PFX_filter;

/* the tuned configuration this file was exported with */
extern const PFX_params PFX_tuned;

/* reset f to the configuration p (copied); the start orientation is taken from the first sample */
void PFX_init(PFX_filter *f, const PFX_params *p);
/* one sample: gyr rad/s, acc m/s^2, mag any unit (NULL: no magnetometer), dt_s seconds since the last sample */
void PFX_update(PFX_filter *f, const PFX_real gyr[3], const PFX_real acc[3], const PFX_real mag[3], PFX_real dt_s);
/* the sensor-to-earth quaternion (w, x, y, z) in the @FRAME@ earth frame */
void PFX_quaternion(const PFX_filter *f, PFX_real q[4]);
/* start from a known orientation (@FRAME@, sensor-to-earth) instead of the first sample's */
void PFX_set_quaternion(PFX_filter *f, const PFX_real q[4]);
/* the current gyro bias estimate, rad/s (0 when the filter has none) */
void PFX_gyro_bias(const PFX_filter *f, PFX_real b[3]);
/* a whole recording: n samples of gyr, acc, mag (n x 3, row-major; mag NULL: none) at a fixed dt_s;
   q0 NULL: the configured start, else a start quaternion as PFX_set_quaternion; q_out n x 4 */
void PFX_run(const PFX_params *p, long n, const PFX_real *gyr, const PFX_real *acc, const PFX_real *mag,
             PFX_real dt_s, const PFX_real *q0, PFX_real *q_out);

#ifdef __cplusplus
}
#endif

#endif /* PFX_H_ */
