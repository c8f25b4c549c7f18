"""Madgwick's gradient-descent orientation filter (MARG and IMU), with gyro bias drift compensation.

S. O. H. Madgwick, "An efficient orientation filter for inertial and inertial/magnetic sensor
arrays", report, University of Bristol, 2010 (the "report" below), and Madgwick et al., ICORR 2011.

Two variants of the magnetometer term (``variant``):

``paper`` (default)
    The earth-field reference of report eqs. 45-46: ``h = q m q*``, ``b = (|h_xy|, 0, h_z)``, used
    as ``b`` in the objective function of eq. 29.
``original_c``
    The widely copied 2010 C code (``MadgwickAHRS.c``, x-io Technologies) stores ``|h_xy|`` and
    ``h_z`` in variables named ``_2bx`` and ``_2bz`` and uses them as ``2 b_x`` and ``2 b_z``: its
    reference field is half as long as the measured (unit) field. Documented publicly in issue 1
    of the BROAD repository (dlaidig/broad) and issue 50 of the Arduino MadgwickAHRS library. The
    BROAD published results were made with this code; the two variants are otherwise identical.

Conventions: the kernel works like the C code, in the NWU earth frame (x north, y west, z up) with
``q`` sensor-to-earth ``(w, x, y, z)`` and ``q_dot = 0.5 q (x) (0, omega)``; the class converts the
output to the recording's frame (ENU/NED).

Degenerate samples (zero or non-finite acc or mag, non-finite gyr), handled as the C code does
where it defines the behaviour and never producing NaN from one bad sample:

- acc zero or non-finite: no correction; the sample propagates with the gyroscope only;
- mag zero or non-finite (MARG mode): the IMU update (gravity only) for this sample;
- gyr non-finite: treated as zero rate (the orientation is held, corrections still apply).
"""

from __future__ import annotations

from objectives.attitude.cexport.port import CField
from objectives.attitude.filters._bias_filter import BiasKernelFilter, batch_on_arrays, bias_c_port, bias_options
from objectives.attitude.filters.madgwick.kernel import VARIANTS, coefficients, madgwick_kernel
from objectives.attitude.filters.madgwick.population import POPULATION
from objectives.params import NONNEG, Param, ParamSet

__all__ = ["Madgwick", "madgwick_batch", "DECL"]

#: the one declaration of Madgwick's parameters (defaults, search space, validation, docs)
DECL = ParamSet("madgwick", (
    Param("beta", 0.1, (1e-3, 1.0), "log", "rad/s", "gradient step gain (eq. 33)", "report eq. 33", NONNEG),
    Param("zeta", 0.0, None, unit="1/s", doc="gyro bias drift gain (eq. 48), 0 = off", eq="report eq. 48",
          allowed=NONNEG),
    Param("variant", "paper", choices=tuple(VARIANTS), doc="'paper' or 'original_c' (2010 C code field scale)",
          eq="report eqs. 45-46"),
    *bias_options("a rejected field drops the magnetometer's gradient (eq. 34), the gravity gradient stays"),
))


def madgwick_batch(gyr, acc, mag, dt: float, q0, beta: float = 0.1, zeta: float = 0.0,
                   variant: str = "paper", with_bias: bool = False, **robust):
    """Run the Madgwick kernel on raw arrays (NWU working frame, no frame conversion).

    Parameters
    ----------
    gyr, acc : (N, 3)
        rad/s; any unit (normalised per sample).
    mag : (N, 3) or None
        Any unit; None runs the IMU (gravity only) version.
    dt : float
        Sample time, s (``1 / sampleFreq`` of the C code).
    q0 : (4,)
        Initial sensor-to-earth quaternion (w, x, y, z), NWU.
    beta, zeta, variant :
        As :data:`DECL` declares them (validated against it).
    with_bias : bool
        Also return the (N, 3) bias estimate.
    **robust
        The robust blocks' options of :data:`DECL` (``mag_rejection``, ``rest_bias``, ``acc_lp_tau_s``, ...).

    Returns
    -------
    quat : (N, 4), or (quat, bias) when ``with_bias``.
    """
    values = {"beta": beta, "zeta": zeta, "variant": variant, **robust}
    return batch_on_arrays(DECL, madgwick_kernel, coefficients, values, gyr, acc, mag, dt, q0, with_bias)


def _c_fields(v: dict, ctx) -> list[CField]:
    """The C port's field scale, from ``variant`` (the declaration's choice, which the port leaves out)."""
    return [CField("real", "field_k", VARIANTS[v["variant"]], f"field scale ({v['variant']!r}: 2 paper, 1 2010 C)")]


#: the C port (port.c, ported from kernel.py; the prologue and robust blocks of the shared parts)
C_PORT = bias_c_port(__package__, skip=("variant",), fields=_c_fields)


class Madgwick(BiasKernelFilter, kernel=madgwick_kernel, coef=coefficients, bias_param="zeta"):
    """Madgwick's gradient-descent filter; output sensor-to-earth in the recording's frame.

    Parameters
    ----------
    beta : float
        Gradient step gain, rad/s (report eq. 33: ``sqrt(3/4) * gyro error``). Default 0.1.
    zeta : float
        Gyro bias drift gain, 1/s (report eq. 48: ``sqrt(3/4) * bias drift``). Default 0 (off).
    variant : {"paper", "original_c"}
        Field reference of the report (default) or the 2010 C code's (half length).
    use_mag : bool
        MARG (True, default) or IMU version (False).
    mag_rejection : bool
        Magnetic disturbance rejection (default False): while the field's norm or dip departs from a
        reference learned when undisturbed (``mag_norm_th``, ``mag_dip_th_deg``), the magnetometer's
        gradient is dropped (for at most ``mag_max_rejection_s``, then halved) and the gravity gradient
        alone corrects; a field that stays is accepted as the new reference. The first reference is the
        field at the start (``mag_ref_start``, default True; False: learned after 5 s of fast rotation).
    rest_bias : bool
        Gyro bias estimation at rest (default False): at detected rest the bias follows the low-passed
        gyro with ``rest_bias_tau_s``; held during motion, subtracted before ``zeta``'s estimate.
    acc_lp_tau_s : float
        Earth-frame accelerometer low-pass time constant, s (default 0: raw accelerometer).

    With every robust block off (the defaults) the output is the paper's algorithm bit for bit.
    The kernel works in NWU (``working_frame``); :meth:`run` returns quaternions in ``rec.frame``.
    ``run_detailed`` adds the diagnostic ``gyr_bias`` (N, 3), rad/s, when ``zeta > 0``.
    :meth:`stream` updates in O(1) per sample (the kernel carries quaternion and bias in ``state``).
    """

    name = "madgwick"
    decl = DECL
    population = POPULATION
    c_port = C_PORT
