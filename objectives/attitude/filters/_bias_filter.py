"""What Madgwick and Mahony share: a kernel ``kernel(gyr, acc, mag, coef, state, out, bias_out)`` whose
state is the quaternion and a gyro bias (``state`` (7,): q (4,), bias (3,)), called on whole arrays by
``run`` and on one sample at a time by ``stream``. Each filter supplies its kernel, the function that
builds its coefficient array, and the name of the parameter that switches the bias estimate on; the
coefficients and start state reach ``run``, ``stream`` and the population batch through
:meth:`BiasKernelFilter.kernel_setup` (:func:`bias_setup`).

The robust blocks (:mod:`objectives.attitude.filters.robust`) are options of both filters, all off by
default (the kernels then run the papers' algorithms, bit for bit):

- ``mag_rejection`` (block a): the magnetometer, rotated into the NWU earth frame with the current
  estimate, feeds the field norm and dip detector; while the field is disturbed its correction (Mahony's
  error term, Madgwick's gradient) is scaled by the block's gain (0, or ``1 / rejection_factor`` after
  ``mag_max_rejection_s``), the gravity correction goes on; the field at the start is the first reference
  (``mag_ref_start``, as the start orientation trusts it; off: learned after 5 s of fast rotation);
- ``rest_bias`` (block b): at detected rest the gyro's low-pass is the bias estimate (time constant
  ``rest_bias_tau_s``), subtracted from the gyro before the filter's own bias estimate (zeta / Ki);
- ``acc_lp_tau_s`` (block c): the accelerometer low-passed in the earth frame replaces the raw one in the
  gravity correction.

Layouts, declared once (:class:`~objectives.attitude.filters.layout.Layout`): the state :data:`S` (q and bias,
then with a block on the blocks' states, :func:`initial_state`) and the blocks' part of the coefficient array
:data:`RC`, which with a block on follows the filter's own coefficients (each unit's ``C``) padded to
:data:`ROBUST_AT` (:func:`with_robust`); the shared per-sample prologue is :func:`robust_sample`. The units' C
ports share their state members (:data:`C_MEMBERS`, sized from :data:`S`) and parts (:data:`C_PARTS`).

Both kernels run one loop, :func:`bias_kernel_loop`, with their own update and gains: numba inlines the loop
into each kernel body and the update into the loop (both ``inline="always"``), so each kernel compiles as
when the loop was written out in it. The loops differed only in where and how the bias output is written
(Madgwick before its update, ``b + offset``; Mahony after it, ``offset - I``), now the loop's ``bias_after``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from objectives.attitude.cexport.port import ROBUST_MEMBERS, CMember, CPort
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters import _scalar as sc
from objectives.attitude.filters._scalar import read_unit
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.robust import (
    ACC_COEF,
    ACC_STATE,
    MAG_COEF,
    MAG_STATE,
    REST_COEF,
    REST_STATE,
    _mag_dist_update,
    _rest_update,
    acc_lp_coefficients,
    acc_lp_step,
    mag_dist_coefficients,
    mag_dist_state,
    rest_coefficients,
)
from objectives.attitude.filters.robust_params import robust_decl
from objectives.attitude.filters.stream import StateStream
from objectives.params import POSITIVE, Param, ParamSet, check_number, imu_arrays, unit_quaternion

__all__ = ["BiasKernelFilter", "run_bias_kernel", "batch_on_arrays", "io_flags", "read_mag", "robust_options",
           "bias_options", "bias_c_port",
           "with_robust", "robust_coef", "initial_state", "bias_setup", "robust_sample", "sample_inputs", "robust_on",
           "bias_kernel_loop",
           "ROBUST_AT", "COEF_LEN", "STATE_LEN", "ROBUST_NAMES", "RC", "S", "C_PARTS", "C_MEMBERS"]

# --- layouts: the state, and the robust blocks' part of the coefficient array -------------------------------
#: index of the first robust coefficient (the filters' own coefficients fit before it)
ROBUST_AT = 8
#: the robust blocks' part of the coefficient array, from :data:`ROBUST_AT` (:func:`with_robust`)
RC = Layout("RC", (("FLAGS", 4, "mag_rejection, rest_bias, acc_lp, mag_ref_start (0/1)"),
                   ("MAG", MAG_COEF, "block a: robust.mag_dist_coefficients"),
                   ("REST", REST_COEF, "block b: robust.rest_coefficients"),
                   ("ACC", ACC_COEF, "block c: robust.acc_lp_coefficients")), start=ROBUST_AT)
#: length of a coefficient array with the blocks
COEF_LEN = RC.LEN
#: the state: quaternion and bias (all of it with the blocks off), then the blocks' states
S = Layout("S", (("Q", 4, "sensor-to-earth quaternion, NWU"),
                 ("BIAS", 3, "gyro bias (Madgwick: omega_b; Mahony: the integral I = -b), rad/s"),
                 ("MAG", MAG_STATE, "block a: robust.mag_dist_state"),
                 ("REST", REST_STATE, "block b: robust.rest_state"),
                 ("ACC", ACC_STATE, "block c: robust.acc_lp_state")))
#: length of the state array with the blocks (:data:`S`; the quaternion and bias alone: ``S.MAG``)
STATE_LEN = S.LEN
#: the C ports' shared parts: the blocks, then the prologue of the quaternion-and-bias filters
C_PARTS = ("robust.c", "bias_prologue.c")
#: the C ports' state (``bias_prologue.c`` and ``robust.c`` read and write it), sized by :data:`S`
C_MEMBERS = (CMember("real", "q", (S.field("Q").size,), "sensor-to-earth quaternion, working frame"),
             CMember("real", "b", (S.field("BIAS").size,), S.field("BIAS").doc),
             *ROBUST_MEMBERS)
#: the options of the robust blocks in Madgwick and Mahony
ROBUST_NAMES = ("acc_lp_tau_s", "mag_rejection", "mag_max_rejection_s", "mag_norm_th", "mag_dip_th_deg", "rest_bias",
                "rest_bias_tau_s", "mag_ref_start")
#: rest detection on unit accelerometer vectors: VQF's 0.5 m/s^2 relative to g
_REST_TH_ACC = 0.5 / 9.81


def bias_c_port(package: str, **options: Any) -> CPort:
    """The C port of the unit ``package``: its ``port.c`` after the shared parts (:data:`C_PARTS`), the state
    :data:`C_MEMBERS`; ``options`` as :class:`~objectives.attitude.cexport.port.CPort` takes them."""
    return CPort((package, "port.c"), C_PARTS, C_MEMBERS, **options)


def bias_options(rejected: str) -> tuple[Param, ...]:
    """The options both filters declare after their own gains: ``use_mag``, then :func:`robust_options`."""
    return (Param("use_mag", True, doc="MARG (true) or IMU (false)"), *robust_options(rejected))


def robust_options(rejected: str) -> tuple[Param, ...]:
    """The robust blocks' parameter declarations for Madgwick and Mahony (``rejected``: what a rejected field
    does in this filter, for the docs): the shared ``robust_decl`` ones these kernels use, and ``rest_bias_tau_s``.
    """
    shared = tuple(p for p in robust_decl("the gravity correction", rejected) if p.name in ROBUST_NAMES)
    return shared + (
        Param("mag_ref_start", True, choices=(True, False),
              doc="the field at the start is the first reference (mag_rejection; the start orientation already "
                  "trusts it); false: learned as a new field, after new_first_time_s of rotation faster than "
                  "20 deg/s, the magnetometer used fully until then"),
        Param("rest_bias_tau_s", 2.0, unit="s", allowed=POSITIVE,
              doc="time constant with which the bias estimate follows the low-passed gyro at rest (rest_bias)"),
    )


def _blocks_on(v: dict) -> tuple[bool, bool, bool]:
    return bool(v.get("mag_rejection", False)), bool(v.get("rest_bias", False)), float(v.get("acc_lp_tau_s", 0.0)) > 0


def with_robust(coef: np.ndarray, v: dict, dt: float) -> np.ndarray:
    """``coef`` unchanged when every robust block of the validated values ``v`` is off; else ``coef`` padded to
    :data:`ROBUST_AT`, then the flags and the coefficients of blocks a, b and c (:data:`COEF_LEN` in all)."""
    rej, rest, alp = _blocks_on(v)
    if not (rej or rest or alp):
        return coef
    out = np.zeros(COEF_LEN)
    out[:coef.shape[0]] = coef
    out[RC.START:] = RC.pack(
        FLAGS=(float(rej), float(rest), float(alp), float(bool(v["mag_ref_start"]))),
        MAG=mag_dist_coefficients(dt, norm_th=float(v["mag_norm_th"]), dip_th_deg=float(v["mag_dip_th_deg"]),
                                  max_rejection_s=float(v["mag_max_rejection_s"])),
        REST=rest_coefficients(dt, th_acc=_REST_TH_ACC, tau_bias_s=float(v["rest_bias_tau_s"])),
        ACC=acc_lp_coefficients(dt, tau_acc_s=float(v["acc_lp_tau_s"]) if alp else 0.0))
    return out


def robust_coef(coef: np.ndarray) -> bool:
    """True when the coefficient array switches a robust block on (the kernel then needs :data:`STATE_LEN`)."""
    return coef.shape[0] >= COEF_LEN and bool(np.any(coef[RC.FLAGS:RC.MAG] != 0.0))


def initial_state(q0: np.ndarray, robust: bool) -> np.ndarray:
    """The kernels' start state: q0 and zero bias (7,), followed by the blocks' initial states when ``robust``."""
    state = np.zeros(STATE_LEN if robust else S.MAG)
    state[S.Q:S.Q + 4] = q0
    if robust:
        state[S.MAG:S.REST] = mag_dist_state()
    return state


def bias_setup(coef: np.ndarray, q0: np.ndarray) -> KernelSetup:
    """``coef`` and the kernels' start state at ``q0`` (:func:`initial_state`, the blocks' states too when
    ``coef`` switches a robust block on)."""
    return KernelSetup(coef, initial_state(q0, robust_coef(coef)))


@njit(cache=True, inline="always")
def robust_on(coef, state):
    """The kernels' switch: a robust block is on (``ValueError`` when the state has no room for the blocks)."""
    on = coef.shape[0] >= COEF_LEN and (coef[RC.FLAGS] != 0.0 or coef[RC.FLAGS + 1] != 0.0
                                        or coef[RC.FLAGS + 2] != 0.0)
    if on and state.shape[0] < STATE_LEN:
        raise ValueError("robust blocks on: the state array needs STATE_LEN entries (initial_state)")
    return on


@njit(cache=True, inline="always")
def robust_sample(coef, state, gyr, acc, mag, i, use_mag, q0, q1, q2, q3):
    """The robust blocks' prologue of sample ``i`` at the previous estimate ``q`` (sensor-to-earth, NWU).

    Returns ``(bx, by, bz, ax, ay, az, acc_ok, gm)``: the rest bias to subtract from the gyro (rad/s, 0 when
    ``rest_bias`` is off), the unit accelerometer for the gravity correction (earth-frame low-passed when
    ``acc_lp`` is on; ``acc_ok`` as :func:`~objectives.attitude.filters._scalar.read_unit`) and the
    magnetometer gain (1: use fully; 0: rejected; with ``mag_ref_start`` the first field is block a's
    reference, else the gain is 1 until block a has learned one, as in the EKF).
    The blocks' states live in ``state[S.MAG:]`` and are updated in place.
    """
    rej, rest, alp = coef[RC.FLAGS] != 0.0, coef[RC.FLAGS + 1] != 0.0, coef[RC.FLAGS + 2] != 0.0
    gx, gy, gz, g_ok = sc.read_vec(gyr, i)
    ax, ay, az, a_ok = sc.unit(acc[i, 0], acc[i, 1], acc[i, 2])
    rs = state[S.REST:S.ACC]
    if (rej or rest) and g_ok and a_ok:
        _rest_update(rs, coef[RC.REST:RC.ACC], gx, gy, gz, ax, ay, az)
    bx, by, bz = 0.0, 0.0, 0.0
    if rest:
        bx, by, bz = rs[8], rs[9], rs[10]
    if alp and a_ok:
        o = S.ACC
        state[o], state[o + 1], state[o + 2], state[o + 3], ax, ay, az = acc_lp_step(
            coef[RC.ACC], state[o], state[o + 1], state[o + 2], state[o + 3], q0, q1, q2, q3, ax, ay, az)
        ax, ay, az, a_ok = sc.unit(ax, ay, az)
    gm = 1.0
    if rej and use_mag:
        mx, my, mz, m_ok = sc.read_vec(mag, i)
        if m_ok:
            hx, hy, hz = sc.rotate_sensor_to_earth(q0, q1, q2, q3, mx, my, mz)  # NWU: z up, as block a expects
            gl = math.sqrt(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2])
            ms = state[S.MAG:S.REST]
            g = _mag_dist_update(ms, coef[RC.MAG:RC.REST], hx, hy, hz, gl)
            if ms[0] == 0.0 and coef[RC.FLAGS + 3] != 0.0:  # mag_ref_start: the first field is the reference
                ms[0], ms[1], ms[2], ms[6] = ms[8], ms[9], coef[RC.MAG + 5], 0.0
                g = 1.0
            gm = 1.0 if ms[0] == 0.0 else g
    return bx, by, bz, ax, ay, az, a_ok, gm


@njit(cache=True, inline="always")
def sample_inputs(robust, coef, state, gyr, acc, mag, i, use_mag, q0, q1, q2, q3):
    """Sample ``i`` as the Madgwick and Mahony updates take it, at the previous estimate ``q``.

    Returns ``(gx, gy, gz, ox, oy, oz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm)``: the gyro rate less the
    rest bias, the rest bias to add to the bias output, the unit accelerometer, the unit magnetometer
    (``mag_ok`` false when block a rejects it fully) and block a's gain (:func:`robust_sample`). With the
    blocks off (``robust`` false): the raw rate, ``-0.0`` (adding it leaves every value and its sign as
    it is), the unit samples and gain 1, so the papers' recursions get their inputs bit for bit.
    """
    gx, gy, gz = sc.read_rate(gyr, i)
    if robust:
        rbx, rby, rbz, ax, ay, az, acc_ok, gm = robust_sample(coef, state, gyr, acc, mag, i, use_mag, q0, q1, q2, q3)
        mx, my, mz, mag_ok = read_mag(mag, i, use_mag)
        return (gx - rbx, gy - rby, gz - rbz, rbx, rby, rbz, ax, ay, az, acc_ok, mx, my, mz, mag_ok and gm > 0.0,
                gm)
    ax, ay, az, acc_ok = sc.read_unit(acc, i)
    mx, my, mz, mag_ok = read_mag(mag, i, use_mag)
    return gx, gy, gz, -0.0, -0.0, -0.0, ax, ay, az, acc_ok, mx, my, mz, mag_ok, 1.0


@njit(cache=True, inline="always")
def io_flags(use_mag_coef, gyr, mag, bias_out):
    """The kernels' ``(use_mag, write_bias)``: the magnetometer is used when its coefficient is not 0 and
    it has a row per gyro sample; the bias is written when ``bias_out`` has a row per sample."""
    n = gyr.shape[0]
    return use_mag_coef != 0.0 and mag.shape[0] == n, bias_out.shape[0] == n


@njit(cache=True, inline="always")
def read_mag(mag, i, use_mag):
    """The kernels' magnetometer sample ``i``: ``(x, y, z, ok)``, the unit field when ``use_mag`` and the
    row is usable (:func:`~objectives.attitude.filters._scalar.read_unit`), else ``(0, 0, 0, False)``."""
    if use_mag:
        return read_unit(mag, i)
    return 0.0, 0.0, 0.0, False


@njit(inline="always")
def bias_kernel_loop(update, bias_after, gains, gyr, acc, mag, coef, state, out, bias_out, use_mag_coef):
    """A kernel over whole arrays from its per-sample ``update`` (module docstring), inlined into each kernel body.

    Parameters
    ----------
    update : a unit's per-sample recursion (``inline="always"``)
        ``update(q0, q1, q2, q3, b0, b1, b2, gx, gy, gz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm, gains)``:
        the new quaternion and bias state from the previous ones and the inputs of :func:`sample_inputs`.
    bias_after : bool
        Where ``bias_out`` is written (below).
    gains : tuple of float
        The coefficients ``update`` takes, read from ``coef`` by the kernel.
    gyr, acc, mag : (N, 3) float64
        rad/s, any unit, any unit (both normalised per sample); ``mag`` may be (0, 3) for the IMU version.
    coef : (C.LEN,) or (COEF_LEN,) float64
        The unit's layout ``C``; with a robust block on, the blocks' flags and coefficients from index
        :data:`ROBUST_AT` (:func:`with_robust`).
    state : (S.MAG,) or (STATE_LEN,) float64
        Read and written (layout :data:`S`): the sensor-to-earth quaternion (NWU) and the unit's bias state,
        then the robust blocks' states when they are on; in: before the first sample, out: after the last
        (for streaming).
    out : (N, 4) float64
        Written: the estimate after each sample's update.
    bias_out : (N, 3) or (0, 3) float64
        Written when it has a row per sample: the gyro bias used at each sample, rad/s: the bias state before
        the update plus the rest bias of ``rest_bias`` (``b + offset``), or with ``bias_after`` the rest bias
        less the updated state (``offset - I``).
    use_mag_coef : float
        The unit's ``USE_MAG`` coefficient (0: the IMU version).
    """
    robust = robust_on(coef, state)
    use_mag, write_bias = io_flags(use_mag_coef, gyr, mag, bias_out)
    q0, q1, q2, q3, b0, b1, b2 = sc.load_q_bias(state)
    for i in range(gyr.shape[0]):
        gx, gy, gz, ox, oy, oz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm = sample_inputs(
            robust, coef, state, gyr, acc, mag, i, use_mag, q0, q1, q2, q3)
        if write_bias and not bias_after:
            sc.write_vec(bias_out, i, b0 + ox, b1 + oy, b2 + oz)
        q0, q1, q2, q3, b0, b1, b2 = update(q0, q1, q2, q3, b0, b1, b2, gx, gy, gz, ax, ay, az, acc_ok, mx, my, mz,
                                            mag_ok, gm, gains)
        if write_bias and bias_after:
            sc.write_vec(bias_out, i, ox - b0, oy - b1, oz - b2)
        sc.write_q(out, i, q0, q1, q2, q3)
    sc.store_q_bias(state, q0, q1, q2, q3, b0, b1, b2)


def run_bias_kernel(kernel: Any, setup: KernelSetup, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray,
                    with_bias: bool):
    """One kernel call from ``setup`` on checked contiguous arrays: (N, 4) quaternions, and the (N, 3) bias
    if asked."""
    n = gyr.shape[0]
    out = np.empty((n, 4))
    bias = np.empty((n if with_bias else 0, 3))
    kernel(gyr, acc, mag, setup.coef, setup.state, out, bias)
    return (out, bias) if with_bias else out


def batch_on_arrays(decl: ParamSet, kernel: Any, coef: Any, values: dict, gyr, acc, mag, dt: float, q0,
                    with_bias: bool):
    """The ``*_batch`` functions: validate ``values`` against ``decl`` and the arrays, then one kernel call."""
    name = decl.owner
    v = decl.validate(values)
    gyr, acc, mag = imu_arrays(name, gyr, acc, mag)
    dt = check_number(name, "dt", dt, POSITIVE, "s")
    setup = bias_setup(coef(v, dt, mag.shape[0] > 0), unit_quaternion(name, "q0", q0))
    return run_bias_kernel(kernel, setup, gyr, acc, mag, with_bias)


class BiasKernelFilter(AttitudeFilter):
    """Base of Madgwick and Mahony (NWU working frame, ``gyr_bias`` diagnostic when the bias is on).

    Subclasses name, as class keywords, their ``kernel``, ``coef`` (``coef(values, dt, has_mag) -> array``,
    what :meth:`kernel_setup` builds the coefficients with) and ``bias_param``, the parameter whose positive
    value turns the bias estimate on::

        class Madgwick(BiasKernelFilter, kernel=madgwick_kernel, coef=coefficients, bias_param="zeta"): ...
    """

    working_frame = "NWU"
    needs_mag = True
    kernel: ClassVar[Any]
    _coef_of: ClassVar[Any]
    bias_param: ClassVar[str]

    def __init_subclass__(cls, kernel: Any = None, coef: Any = None, bias_param: str | None = None,
                          **kwargs: Any) -> None:
        if kernel is not None:
            cls.kernel = staticmethod(kernel)
            cls._coef_of = staticmethod(coef)
            cls.bias_param = bias_param
        super().__init_subclass__(**kwargs)

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The filter's coefficients (with a robust block on, the longer layout of :func:`with_robust`) and the
        start state at ``q0`` (:func:`bias_setup`); ``frame`` and ``g_ref`` do not enter (unit vectors, NWU)."""
        return bias_setup(self._coef_of(self.values, dt, use_mag), q0)

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        v = self.values
        gyr, acc, mag = imu_arrays(self.name, rec.gyr, rec.acc, rec.mag if v["use_mag"] else None)
        with_bias = v[self.bias_param] > 0 or bool(v.get("rest_bias", False))
        res = run_bias_kernel(self.kernel, self.kernel_setup(rec.dt, mag.shape[0] > 0, q0, rec.frame), gyr, acc, mag,
                              with_bias)
        if with_bias:
            return FilterResult(res[0], self.working_frame, {"gyr_bias": res[1]})
        return FilterResult(res, self.working_frame)

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0=None, frame: str = "ENU"):
        return _BiasKernelStream(self, rate_hz, dt, q0, frame)


class _BiasKernelStream(StateStream):
    """O(1) per-sample stream: the kernel on one sample with quaternion and bias carried in ``state``."""

    def _buffers(self) -> None:
        self._kernel = self.filter.kernel
        self._bias = np.empty((0, 3))

    def _step(self, state, gyr, acc, mag):
        self._kernel(gyr, acc, mag, self._coef, state, self._out, self._bias)
        return self._out[0]
