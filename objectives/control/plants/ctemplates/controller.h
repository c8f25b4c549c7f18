#ifndef PFX_H
#define PFX_H

#include <stddef.h>

typedef @REAL@ PFX_real;

/* sizes and indices: measurements PFX_update reads, actuator commands it writes */
enum {
    PFX_N_MEAS = @N_MEAS@, /* @MEAS_DOC@ */
    PFX_N_U = @N_U@, /* actuator commands (plant inputs) */
    PFX_OUTPUT = @OUTPUT@, /* the controlled output's index in meas */
    PFX_INNER_OUTPUT = @INNER@, /* the inner loop's output's index in meas (cascade) */
    PFX_N_BLOCKS = @N_BLOCKS@ /* PID blocks (0: state feedback) */
};
@ENUMS@
/* the deployed controller: every value of its declaration, the period and the actuator it was tuned with */
typedef struct {
    PFX_real period_s; /* controller period, s: call PFX_update once per period */
@PARAMS@
    PFX_real act_u_min; /* actuator lower limit (the loop's saturation), u */
    PFX_real act_u_max; /* actuator upper limit, u */
    PFX_real act_rate_limit; /* actuator rate limit, u/s (0: none) */
    PFX_real act_quantum; /* actuator command quantum, u (0: none) */
} PFX_params;

/* one PID block's discrete coefficients (made by PFX_init from PFX_params) and state */
typedef struct {
    PFX_real K, b, c, ki, ad, bd, kt, u_min, u_max;
    int aw;
} PFX_pid_coeffs;

typedef struct {
    PFX_real I, D, yc_prev;
    int started;
} PFX_pid_state;

typedef struct {
    PFX_params p;
    PFX_pid_coeffs blk[PFX_N_BLOCKS > 0 ? PFX_N_BLOCKS : 1];
    PFX_pid_state st[PFX_N_BLOCKS > 0 ? PFX_N_BLOCKS : 1];
    PFX_real du_max; /* rate limit per period */
    PFX_real u_prev[PFX_N_U]; /* the last actuator commands (rate limit) */
} PFX_controller;

/* the tuned values */
extern const PFX_params PFX_tuned;

/* coefficients from p (a copy is kept), state zeroed: the first PFX_update starts a new run */
void PFX_init(PFX_controller *c, const PFX_params *p);
/* state zeroed, coefficients kept */
void PFX_reset(PFX_controller *c);
/* one period: reference r and measurements meas[PFX_N_MEAS] in, actuator commands u[PFX_N_U] out */
void PFX_update(PFX_controller *c, PFX_real r, const PFX_real *meas, PFX_real *u);
/* sizeof(PFX_controller), for bindings that allocate it */
size_t PFX_controller_size(void);

#endif
