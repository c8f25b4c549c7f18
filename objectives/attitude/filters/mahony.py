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

import math

import numpy as np
from numba import njit

from objectives.attitude.filters import _scalar as sc
from objectives.attitude.filters._bias_filter import (
    BiasKernelFilter,
    batch_on_arrays,
    io_flags,
    robust_on,
    robust_options,
    sample_inputs,
    with_robust,
)
from objectives.params import NONNEG, Param, ParamSet

__all__ = ["Mahony", "mahony_batch", "DECL"]


@njit(cache=True, inline="always")
def _update(q0_, q1, q2, q3, ix, iy, iz, gx, gy, gz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm, dt, kp, ki):
    """One sample from the estimate ``q`` and integral ``I``: the new ``(q, I)`` (module docstring: predicted
    gravity and field directions, the cross-product error, PI feedback, first-order integration); ``gm``
    scales the magnetometer's error term (1: the C code; below 1: a field block a finds disturbed). The
    kernel's one recursion, with the robust blocks on or off.
    """
    if acc_ok:
        # predicted gravity direction v_hat = R(q)^T (0, 0, 1)
        vx = 2.0 * (q1 * q3 - q0_ * q2)
        vy = 2.0 * (q0_ * q1 + q2 * q3)
        vz = q0_ * q0_ - q1 * q1 - q2 * q2 + q3 * q3
        # omega_mes = a x v_hat
        ex = ay * vz - az * vy
        ey = az * vx - ax * vz
        ez = ax * vy - ay * vx
        if mag_ok:
            # earth-field reference b = (|h_xy|, 0, h_z), h = q (x) m (x) q*; predicted w_hat = R(q)^T b
            hx, hy, bz = sc.rotate_sensor_to_earth(q0_, q1, q2, q3, mx, my, mz)
            bx = math.sqrt(hx * hx + hy * hy)
            wx = 2.0 * gm * (bx * (0.5 - q2 * q2 - q3 * q3) + bz * (q1 * q3 - q0_ * q2))
            wy = 2.0 * gm * (bx * (q1 * q2 - q0_ * q3) + bz * (q0_ * q1 + q2 * q3))
            wz = 2.0 * gm * (bx * (q0_ * q2 + q1 * q3) + bz * (0.5 - q1 * q1 - q2 * q2))
            ex += my * wz - mz * wy
            ey += mz * wx - mx * wz
            ez += mx * wy - my * wx
        if ki > 0.0:
            ix += ki * ex * dt
            iy += ki * ey * dt
            iz += ki * ez * dt
        else:
            ix = 0.0
            iy = 0.0
            iz = 0.0
        gx += kp * ex
        gy += kp * ey
        gz += kp * ez
    h = 0.5 * dt
    gx = (gx + ix) * h
    gy = (gy + iy) * h
    gz = (gz + iz) * h
    n0 = q0_ + (-q1 * gx - q2 * gy - q3 * gz)
    n1 = q1 + (q0_ * gx + q2 * gz - q3 * gy)
    n2 = q2 + (q0_ * gy - q1 * gz + q3 * gx)
    n3 = q3 + (q0_ * gz + q1 * gy - q2 * gx)
    q0_, q1, q2, q3 = sc.normalized_q(n0, n1, n2, n3)
    return q0_, q1, q2, q3, ix, iy, iz


@njit
def _mahony_kernel_inner(gyr, acc, mag, coef, state, out, bias_out):
    """Mahony filter over whole arrays (see module docstring).

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, any unit, any unit; ``mag`` may be (0, 3) for the IMU version.
    coef : (4,) or (COEF_LEN,) float64
        ``dt`` s, ``Kp`` rad/s per unit error, ``Ki`` rad/s^2 per unit error, ``use_mag`` (0/1); with a
        robust block on, the blocks' flags and coefficients from index ``ROBUST_AT``
        (:func:`~._bias_filter.with_robust`).
    state : (7,) or (STATE_LEN,) float64
        Read and written: the sensor-to-earth quaternion (NWU) and the integral ``I`` (rad/s), then the
        robust blocks' states when they are on; in: before the first sample, out: after the last.
    out : (N, 4) float64
        Written: estimate after each sample.
    bias_out : (N, 3) or (0, 3) float64
        Written when not empty: gyro bias estimate ``b = -I`` used at each sample (plus the rest bias of
        ``rest_bias``), rad/s.
    """
    robust = robust_on(coef, state)
    dt, kp, ki = coef[0], coef[1], coef[2]
    use_mag, write_bias = io_flags(coef[3], gyr, mag, bias_out)
    q0_, q1, q2, q3, ix, iy, iz = sc.load_q_bias(state)
    for i in range(gyr.shape[0]):
        gx, gy, gz, ox, oy, oz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm = sample_inputs(
            robust, coef, state, gyr, acc, mag, i, use_mag, q0_, q1, q2, q3)
        q0_, q1, q2, q3, ix, iy, iz = _update(q0_, q1, q2, q3, ix, iy, iz, gx, gy, gz, ax, ay, az, acc_ok, mx, my,
                                              mz, mag_ok, gm, dt, kp, ki)
        if write_bias:  # the bias used at this sample: the integral after its update, plus the rest bias
            sc.write_vec(bias_out, i, ox - ix, oy - iy, oz - iz)
        sc.write_q(out, i, q0_, q1, q2, q3)
    sc.store_q_bias(state, q0_, q1, q2, q3, ix, iy, iz)


@njit(cache=True)
def _mahony_kernel(gyr, acc, mag, coef, state, out, bias_out):
    """:func:`_mahony_kernel_inner`, cached: the entry Python calls. The population kernel calls the uncached body
    itself (rule 2 of :mod:`objectives.jit`), so a process compiles it once, not once more for a twin."""
    _mahony_kernel_inner(gyr, acc, mag, coef, state, out, bias_out)


#: the one declaration of Mahony's parameters (defaults, search space, validation, docs)
DECL = ParamSet("mahony", (
    Param("Kp", 0.5, (1e-2, 10.0), "log", "rad/s", "proportional gain", "TAC 2008 eq. 32 (k_P)", NONNEG),
    Param("Ki", 0.0, (1e-5, 1.0), "log", "rad/s^2", "integral gain (gyro bias)", "TAC 2008 eq. 32 (k_I)",
          NONNEG),
    Param("use_mag", True, doc="MARG (true) or IMU (false)"),
    *robust_options("a rejected field drops the magnetometer's error term m x w_hat, the gravity term stays"),
))


def _coef(v: dict, dt: float, has_mag: bool) -> np.ndarray:
    """The kernel's coefficient array from validated values (the only place it is built)."""
    return with_robust(np.array([dt, float(v["Kp"]), float(v["Ki"]), 1.0 if has_mag else 0.0]), v, dt)


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
    return batch_on_arrays(DECL, _mahony_kernel, _coef, {"Kp": kp, "Ki": ki, **robust}, gyr, acc, mag, dt, q0,
                           with_bias)


class Mahony(BiasKernelFilter, kernel=_mahony_kernel, coef=_coef, bias_param="Ki"):
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
    batch_kernel = "mahony"
    decl = DECL
