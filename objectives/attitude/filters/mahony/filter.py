"""Mahony's explicit complementary filter on SO(3) with gyro-bias integral (MARG and IMU).

R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear complementary filters on the special orthogonal
group", IEEE TAC 53(5), 2008, section V ("explicit complementary filter with bias correction",
eq. 32 for the quaternion form, here with ``k_i = 1`` weights for both directions):

    omega_mes = a x v_hat + m x w_hat                     (v_hat, w_hat predicted in the sensor frame)
    b_dot     = -Ki omega_mes
    q_dot     = 0.5 q (x) (0, omega_y - b + Kp omega_mes)

implemented as in the widely used 2010 C code (``MahonyAHRS.c``, x-io Technologies; the BROAD
example code), so that BROAD's published numbers are reproduced:

- ``Kp``, ``Ki`` are the paper's gains; the C code's ``twoKp = 2 Kp`` and ``twoKi = 2 Ki`` multiply
  half-errors, which is the same thing;
- the earth-field reference is rebuilt each sample from the measurement, ``h = q m q*``,
  ``b = (|h_xy|, 0, h_z)``, so the magnetometer only corrects heading (no dip angle parameter);
- the integral ``I = -b`` accumulates ``Ki omega_mes dt`` and is reset to zero when ``Ki <= 0``;
- forward-Euler quaternion step and normalisation.

Working frame: NWU (x north, y west, z up), ``q`` sensor-to-earth (w, x, y, z); the class converts
the output to the recording's frame.

Degenerate samples: acc zero or non-finite: no correction (the C code also skips the integral
there; this kernel still applies the integral bias estimate, which is the better bias model and
changes nothing on finite data); mag zero or non-finite (MARG): the IMU update for the sample; gyr
non-finite: treated as zero rate (orientation held, correction still applied).
"""

from __future__ import annotations

from objectives.attitude.filters._bias_filter import BiasKernelFilter, batch_on_arrays, bias_c_port, bias_options
from objectives.attitude.filters.mahony.kernel import coefficients, mahony_kernel
from objectives.attitude.filters.mahony.population import POPULATION
from objectives.params import NONNEG, Param, ParamSet

__all__ = ["Mahony", "mahony_batch", "DECL"]


#: the one declaration of Mahony's parameters (defaults, search space, validation, docs)
DECL = ParamSet("mahony", (
    Param("Kp", 0.5, (1e-2, 10.0), "log", "rad/s", "proportional gain", "TAC 2008 eq. 32 (k_P)", NONNEG),
    Param("Ki", 0.0, (1e-5, 1.0), "log", "rad/s^2", "integral gain (gyro bias)", "TAC 2008 eq. 32 (k_I)",
          NONNEG),
    *bias_options("a rejected field drops the magnetometer's error term m x w_hat, the gravity term stays"),
))


def mahony_batch(gyr, acc, mag, dt: float, q0, kp: float = 0.5, ki: float = 0.0,
                 with_bias: bool = False, **robust):
    """Run the Mahony kernel on raw arrays (NWU working frame, no frame conversion).

    Parameters
    ----------
    gyr, acc : (N, 3)
        rad/s; any unit.
    mag : (N, 3) or None
        Any unit; None runs the IMU version.
    dt : float
        Sample time, s.
    q0 : (4,)
        Initial sensor-to-earth quaternion, NWU.
    kp, ki : float
        ``Kp`` and ``Ki`` of :data:`DECL` (validated against it).
    with_bias : bool
        Also return the (N, 3) gyro bias estimate, rad/s.
    **robust
        The robust blocks' options of :data:`DECL` (``mag_rejection``, ``rest_bias``, ``acc_lp_tau_s``, ...).
    """
    return batch_on_arrays(DECL, mahony_kernel, coefficients, {"Kp": kp, "Ki": ki, **robust}, gyr, acc, mag, dt, q0,
                           with_bias)


#: the C port (port.c, ported from kernel.py; the prologue and robust blocks of the shared parts)
C_PORT = bias_c_port(__package__)


class Mahony(BiasKernelFilter, kernel=mahony_kernel, coef=coefficients, bias_param="Ki"):
    """Mahony's explicit complementary filter; output sensor-to-earth in the recording's frame.

    Parameters
    ----------
    Kp : float
        Proportional gain, rad/s. Default 0.5 (the C code's ``twoKp = 1``).
    Ki : float
        Integral (bias) gain, rad/s^2. Default 0.
    use_mag : bool
        MARG (True, default) or IMU version.
    mag_rejection : bool
        Magnetic disturbance rejection (default False): while the field's norm or dip departs from a
        reference learned when undisturbed (``mag_norm_th``, ``mag_dip_th_deg``), the magnetometer's
        error term is dropped (for at most ``mag_max_rejection_s``, then halved) and the gravity term
        alone corrects; a field that stays is accepted as the new reference. The first reference is the
        field at the start (``mag_ref_start``, default True; False: learned after 5 s of fast rotation).
    rest_bias : bool
        Gyro bias estimation at rest (default False): at detected rest the bias follows the low-passed
        gyro with ``rest_bias_tau_s``; held during motion, subtracted before the integral's estimate.
    acc_lp_tau_s : float
        Earth-frame accelerometer low-pass time constant, s (default 0: raw accelerometer).

    With every robust block off (the defaults) the output is the C code's algorithm bit for bit.

    Works in NWU; ``run_detailed`` adds the diagnostic ``gyr_bias`` (N, 3), rad/s, when ``Ki > 0``.
    :meth:`stream` updates in O(1) per sample (the kernel carries quaternion and integral in ``state``).
    """

    name = "mahony"
    decl = DECL
    population = POPULATION
    c_port = C_PORT
