"""Quaternion unscented Kalman filters QUKF and QRAUKF (Chiella, Teixeira & Pereira, Sensors 19:2372, 2019).

Both filters estimate the unit quaternion ``e`` and the gyroscope bias ``beta`` (state ``x`` of
eqs. 17-20) with an unscented Kalman filter whose sigma points, means and differences live on the
unit-quaternion manifold (section 3): covariances are 3-D rotation vectors in the tangent space,
``e (+) r = R2Q(r) * e`` (eq. 4, a perturbation in the earth frame) and ``e_a (-) e_b =
Q2R(e_a * e_b^*)`` (eq. 3). The quaternion is only ever changed through ``R2Q`` (eq. 2) and
quaternion products, so it keeps unit norm to rounding without any normalisation step.

The accelerometer and magnetometer are turned into one quaternion pseudo-measurement by the
algebraic quaternion of eqs. 22-24 (Valenti et al. 2016), and the measurement noise ``R_k`` of that
quaternion is obtained by passing the acc/mag noise through the same function with the unscented
transform (eq. 25). QRAUKF adds covariance matching of ``R_k`` over a sliding window of innovations
(eqs. 34-35, 37) and a Hampel-identifier gain that shrinks outlying innovations (eqs. 36, 38).

Implementation notes and deviations
-----------------------------------
- Frames. The algebraic quaternion of eqs. 22-24 is sensor-to-earth in NWU (x magnetic north,
  z up); it is rotated into ENU by the constant ``Q_ENU_FROM_NWU`` (a relabelling of the earth
  axes), so the filters work in ENU (``working_frame = "ENU"``) and the base class converts the
  output to the recording's frame. The propagation of eq. 17 is ``e_k = e_{k-1} * (cos(T|w|/2),
  sin(T|w|/2) w/|w|)``, the body-rate form of the sensor-to-earth quaternion: no conversion needed.
- Eq. 24 is garbled in the text conversion; we use Valenti et al.'s published form
  ``q_mag = (lam3/sqrt(2 Gamma), 0, 0, l_y/(sqrt2 lam3))`` for ``l_x >= 0`` and
  ``(l_y/(sqrt2 lam4), 0, 0, lam4/sqrt(2 Gamma))`` for ``l_x < 0`` (the only unit-norm reading).
- Q2R (eq. 1) is evaluated as ``2 atan2(|n|, |v|) sign(v) n/|n|``, equal to eq. 1 for unit
  quaternions and accurate for small angles where ``acos`` loses digits.
- Weighted mean (eqs. 5, 13). The paper allows the eigenvector of eq. 6 or an iterative
  (gradient-descent) mean; we use the iterative intrinsic mean ``e <- R2Q(sum w_j (Y_j (-) e)) (+) e``
  started from the mean-input image and iterated until the step is below 1e-12 rad (at most 6
  iterations). It stays on the manifold, which the eigenvector solution would not without a
  normalisation.
- Evaluation (:mod:`objectives.attitude.filters.ukf.kernel`, which has the per-part profile): the
  forecast's sigma points are stored one per column and propagated and compared with their mean in
  branch-free loops that run as vector code, with eqs. 1-2 by their power series inside the series'
  range (0.2 and 0.5 rad, truncation below 1e-19 relative) and the exact trigonometric forms for a
  whole loop when any point is outside it. This changes the arithmetic at rounding level only: the
  output equals the earlier scalar kernel's to 3e-11 rad (bias 8e-12 rad/s) over 60 s of
  ``bench6dof`` at 1 kHz and BROAD trials 07 and 24, and the literal reference
  ``tests/reference/ukf_reference.py`` to 1e-10 rad on the tests' recordings.
- Eq. 28 with ``h(x) = e`` (the quaternion part of the state, measurement noise added by eq. 29):
  the sigma points of eq. 9 are symmetric, so eqs. 13-15 give exactly ``y_hat = e_hat``,
  ``P~yy = P_ee`` and ``Pxy = P[:, :3]`` (for rotation vectors below pi). The kernel uses these
  closed forms; ``tests/reference/ukf_reference.py`` evaluates eq. 28 literally and the test
  compares both.
- Eq. 37 is ``max(CM - P~yy, R0)`` taken element by element with ``R0`` the nominal ``R_k`` of
  eq. 25 at the same sample (section 5.2: "negative values are replaced by the nominal value").
  The element-wise maximum can lose positive definiteness; when ``R_hat`` has no Cholesky factor
  (an indefinite ``R_hat`` would make eq. 33 indefinite) the sample uses the nominal ``R0``
  (counted in the ``fallback`` diagnostic).
- Hampel gain (eq. 36): the window holds the raw innovations ``v_j`` of the last ``N`` samples
  including the current one; medians and MAD are taken over the samples available during the first
  ``N - 1`` steps. Where the deviation from the median is zero the gain is 1; where the MAD is zero
  and the deviation is not, the gain is 0 (a constant window rejects any jump).
- Parameters. The paper's gyroscope, accelerometer and magnetometer standard deviations are per
  sample (40 Hz data). We keep ``sigma_gyr`` (rad/s) and ``sigma_acc`` (m/s^2) per sample, express
  ``sigma_mag`` relative to the field magnitude (recordings use any mag unit; the paper's
  0.001 G on an Earth field of about 0.25 G gives 0.004), and express the additive process noise
  of ``Q2`` as random-walk densities so they do not depend on the rate: ``att_rw`` (rad/sqrt(s)) and
  ``bias_rw`` (rad/s/sqrt(s)), per-step std ``= density * sqrt(dt)``. The paper's per-step values
  at 40 Hz (1e-20 rad and 1e-9 rad/s) become ``att_rw = 6.3e-20`` and ``bias_rw = 6.3e-9``.
  The paper gives no initial covariance: ``p0_att = 0.1`` rad and ``p0_bias = 0.01`` rad/s
  (standard deviations of the initial attitude and bias) are documented choices.
- The sample order follows the paper: the forecast from ``k-1`` to ``k`` uses ``u_{k-1} =
  gyr[k-1]`` (eq. 20), then the acc/mag of sample ``k`` are assimilated; sample 0 is assimilated
  from ``q0``.
- 9-D only: the pseudo-measurement of eq. 22 needs the magnetometer (``needs_mag = True``).

Degenerate input
----------------
A zero or non-finite acc or mag vector, or a magnetic field parallel to gravity (``Gamma = 0`` in
eq. 24), skips the data assimilation of that sample (forecast only; QRAUKF's window is not fed);
a non-finite gyroscope sample holds the attitude and bias for that step while the covariance still
grows by ``Q2``; a forecast covariance without a Cholesky factor is replaced by its diagonal. The
``skipped`` diagnostic marks samples without assimilation. :class:`Recording` already rejects NaN
samples; the array entry point :func:`run_ukf` accepts them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup, gravity_in_units
from objectives.attitude.filters.robust import (
    acc_lp_coefficients,
    acc_lp_state,
    mag_dist_coefficients,
    mag_dist_state,
    rest_coefficients,
    rest_state,
)
from objectives.attitude.filters.robust_params import ROBUST_SWITCHES, robust_decl
from objectives.attitude.filters.stream import StateStream
from objectives.attitude.filters.ukf.kernel import C, _ukf_run, new_state, new_work, ukf_chunk
from objectives.attitude.filters.ukf.population import POPULATION
from objectives.attitude.filters.ukf.robust import _ukf_robust_loop, ukf_robust_run
from objectives.params import NONNEG, POSITIVE, Interval, Param, ParamSet

__all__ = ["QUKF", "QRAUKF", "run_ukf", "ukf_setup", "run_setup"]


def run_ukf(gyr, acc, mag, dt, q0, *, sigma_gyr, att_rw, bias_rw, sigma_acc, sigma_mag,
            p0_att=0.1, p0_bias=0.01, robust=False, window=20, n_sigma=3.0,
            blocks: dict[str, Any] | None = None) -> dict[str, np.ndarray]:
    """Array entry point of QUKF (``robust=False``) and QRAUKF (``robust=True``), ENU frame.

    Parameters
    ----------
    gyr, acc, mag : (N, 3) arrays, rad/s, m/s^2, any unit. NaN samples are allowed here (see the
        module docstring for what each does).
    dt : float, s.
    q0 : (4,) initial sensor-to-earth quaternion in ENU, unit norm.
    sigma_gyr ... n_sigma : see :class:`QUKF` and :class:`QRAUKF`.
    blocks : robust blocks, ``{"acc_lp_tau_s", "mag_rejection", "mag_norm_th", "mag_dip_th_deg",
        "mag_max_rejection_s", "rest_bias", "rest_bias_var", "gravity"}`` (see :class:`QRAUKF`); ``None``
        or all off: the paper's filter, bit for bit. With a block on the outputs add ``mag_gain`` and ``rest``.

    Returns
    -------
    dict with ``quat`` (N, 4) ENU, ``bias`` (N, 3) rad/s, ``lam`` (N, 3) Hampel gains (ones for QUKF),
    ``skipped`` (N,) bool (no assimilation), ``fallback`` (N,) bool (eq. 37 replaced by R0).
    """
    arrs = []
    for name, a in (("gyr", gyr), ("acc", acc), ("mag", mag)):
        a = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
        if a.ndim != 2 or a.shape[1] != 3:
            raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
        arrs.append(a)
    gyr, acc, mag = arrs
    n = gyr.shape[0]
    if acc.shape[0] != n or mag.shape[0] != n:
        raise ValueError(f"gyr, acc, mag need the same length, got {n}, {acc.shape[0]}, {mag.shape[0]}")
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    q0 = np.asarray(q0, dtype=np.float64).reshape(-1)
    if q0.shape != (4,) or not np.all(np.isfinite(q0)) or abs(np.linalg.norm(q0) - 1.0) > 1e-9:
        raise ValueError(f"q0 must be a finite unit (4,) quaternion, got {q0!r}")
    coef = np.array([sigma_gyr, att_rw, bias_rw, sigma_acc, sigma_mag, n_sigma, p0_att, p0_bias], float)
    names = ["sigma_gyr", "att_rw", "bias_rw", "sigma_acc", "sigma_mag", "n_sigma", "p0_att", "p0_bias"]
    for nm, v in zip(names, coef):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{nm} must be a finite number >= 0, got {v!r}")
    for nm in ("sigma_acc", "sigma_mag", "p0_att", "p0_bias"):
        if coef[names.index(nm)] <= 0:
            raise ValueError(f"{nm} must be > 0, got {coef[names.index(nm)]!r}")
    window = int(window)
    if robust and window < 2:
        raise ValueError(f"window must be an integer >= 2, got {window!r}")
    setup = ukf_setup(dt, q0, sigma_gyr=sigma_gyr, att_rw=att_rw, bias_rw=bias_rw, sigma_acc=sigma_acc,
                      sigma_mag=sigma_mag, p0_att=p0_att, p0_bias=p0_bias, robust=robust, window=window,
                      n_sigma=n_sigma, blocks=blocks)
    return run_setup(setup, gyr, acc, mag)


def _blocks_on(b: dict[str, Any]) -> bool:
    return bool(b.get("mag_rejection")) or bool(b.get("rest_bias")) or float(b.get("acc_lp_tau_s", 0.0)) > 0


def ukf_setup(dt: float, q0: np.ndarray, *, sigma_gyr, att_rw, bias_rw, sigma_acc, sigma_mag, p0_att=0.1,
              p0_bias=0.01, robust=False, window=20, n_sigma=3.0, blocks: dict[str, Any] | None = None) -> KernelSetup:
    """The kernel start of a run from checked values (arguments as :func:`run_ukf`): what
    :meth:`QUKF.kernel_setup` returns and :func:`run_setup` runs.

    ``coef`` (layout :data:`~objectives.attitude.filters.ukf.kernel.C`): the kernel's 7 coefficients and 1.0 for
    the QRAUKF (``robust``), 0.0 for the QUKF; ``state``: :func:`new_state` (the innovation window
    of ``window`` samples for the QRAUKF, of 1 for the QUKF); ``extra``: ``(istate,)``, with a robust block on
    ``(istate, flags, mcoef, rcoef, acoef, ms, rs, ast)`` (:func:`~objectives.attitude.filters.ukf.robust.
    ukf_robust_run`'s block coefficients and the blocks' start states).
    """
    state, istate = new_state(q0, p0_att, p0_bias, window if robust else 1)
    kcoef = C.pack(DT=dt, SIGMA_GYR=sigma_gyr, ATT_RW=att_rw, BIAS_RW=bias_rw, SIGMA_ACC=sigma_acc,
                   SIGMA_MAG=sigma_mag, N_SIGMA=n_sigma, ROBUST=1.0 if robust else 0.0)
    b = blocks or {}
    if not _blocks_on(b):
        return KernelSetup(kcoef, state, (istate,))
    tau = float(b.get("acc_lp_tau_s", 0.0))
    g = float(b.get("gravity", 9.81))
    flags = np.array([float(bool(b.get("mag_rejection"))), float(bool(b.get("rest_bias"))), float(tau > 0),
                      float(b.get("rest_bias_var", 3e-6))])
    mcoef = mag_dist_coefficients(dt, norm_th=float(b.get("mag_norm_th", 0.1)),
                                  dip_th_deg=float(b.get("mag_dip_th_deg", 10.0)),
                                  max_rejection_s=float(b.get("mag_max_rejection_s", 60.0)))
    rcoef = rest_coefficients(dt, th_acc=0.5 * g / 9.81)
    acoef = acc_lp_coefficients(dt, tau_acc_s=tau, gravity=g)
    return KernelSetup(kcoef, state, (istate, flags, mcoef, rcoef, acoef, mag_dist_state(), rest_state(),
                                      acc_lp_state()))


def run_setup(setup: KernelSetup, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray) -> dict[str, np.ndarray]:
    """The kernel (with a robust block on, the blocks' driver) from ``setup`` (:func:`ukf_setup`) over
    contiguous float64 (N, 3) arrays; the outputs of :func:`run_ukf`. The setup's arrays are updated in place."""
    robust = bool(setup.coef[C.ROBUST] != 0.0)
    if len(setup.extra) > 1:
        istate, flags, mcoef, rcoef, acoef, *states = setup.extra
        return ukf_robust_run(gyr, acc, mag, setup.coef, robust, setup.state, istate, new_work(), flags, mcoef,
                              rcoef, acoef, tuple(states))
    return ukf_chunk(gyr, acc, mag, setup.coef, robust, setup.state, setup.extra[0])


# ----------------------------------------------------------------------------------------------
#: parameters shared by the QUKF and the QRAUKF (one declaration; see the module docstring for units)
_COMMON = (
    Param("sigma_gyr", 0.0077, (1e-4, 1e-1), "log", "rad/s",
          "gyroscope noise std per sample (Q1; paper 0.0077 rad/s at 40 Hz)", "eq. 18 q_u", NONNEG),
    Param("sigma_acc", 0.038, (1e-3, 10.0), "log", "m/s^2",
          "accelerometer noise std per axis (R_a of eq. 25; paper 0.038)", "eq. 25 R_a", POSITIVE),
    Param("sigma_mag", 0.004, (1e-4, 1.0), "log", "1",
          "magnetometer noise std relative to the field norm (R_b of eq. 25; paper about 0.004)", "eq. 25 R_b",
          POSITIVE),
    Param("bias_rw", 6.3e-9, (1e-10, 1e-2), "log", "rad/s/sqrt(s)",
          "gyro bias random walk density (Q2 bias block; paper 6.3e-9)", "eq. 19 q_beta", NONNEG),
    Param("att_rw", 6.3e-20, (1e-20, 1e-1), "log", "rad/sqrt(s)",
          "additive attitude random walk density (Q2 attitude block; paper 6.3e-20)", "eq. 20 Q2", NONNEG),
    Param("p0_att", 0.1, unit="rad", doc="initial attitude std", allowed=POSITIVE),
    Param("p0_bias", 0.01, unit="rad/s", doc="initial gyro bias std", allowed=POSITIVE),
)
_KERNEL_KEYS = ("sigma_gyr", "sigma_acc", "sigma_mag", "bias_rw", "att_rw", "p0_att", "p0_bias")

#: robust blocks of the QRAUKF (objectives.attitude.filters.robust, driver ukf/robust.py); all off by default
#: = the paper's QRAUKF, bit for bit
_ROBUST_DECL = robust_decl("the pseudo-measurement", "a rejected field is replaced by the predicted heading direction")
_BLOCK_SWITCHES = ROBUST_SWITCHES
_BLOCK_KEYS = tuple(p.name for p in _ROBUST_DECL)


class QUKF(AttitudeFilter):
    """Quaternion-based unscented Kalman filter, eqs. 1-33 of Chiella et al. 2019 (see module docstring).

    State: sensor-to-earth quaternion (ENU working frame) and gyro bias (rad/s); 9-D (needs mag).
    Output: sensor-to-earth ``(w, x, y, z)`` in the recording's frame. Diagnostics: ``bias`` (N, 3)
    rad/s, ``skipped`` (N,) samples without assimilation.

    Parameters (defaults from the paper's section 6, converted as the module docstring says)
    ----------
    sigma_gyr : float, rad/s, gyro noise std per sample (Q1).
    sigma_acc : float, m/s^2, accelerometer noise std (R_a).
    sigma_mag : float, 1, magnetometer noise std relative to the field magnitude (R_b).
    bias_rw : float, rad/s/sqrt(s), bias random walk density (Q2).
    att_rw : float, rad/sqrt(s), additive attitude random walk density (Q2).
    p0_att, p0_bias : fixed options, initial std of attitude (rad) and bias (rad/s).

    :meth:`kernel_setup` builds the kernel's start (:func:`ukf_setup`), which :meth:`_run`, :func:`run_ukf`
    and :meth:`stream` (O(1) per sample: the kernel on one sample with its state carried) all run.
    """

    name = "qukf"
    working_frame = "ENU"
    needs_mag = True
    decl = ParamSet("qukf", _COMMON)
    #: the QRAUKF's covariance matching and Hampel gain (eqs. 34-38), the kernel's ``robust`` argument
    adaptive = False
    population = POPULATION

    @property
    def robust(self) -> bool:
        """True when a robust block is on (QRAUKF options; the blocks' driver runs, as for the EKF's ``robust``)."""
        return self._block_values(G_SI) is not None

    def _kwargs(self) -> dict[str, Any]:
        v = self.values
        return {k: v[k] for k in _KERNEL_KEYS}

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's start on a recording (:func:`ukf_setup`): coefficients (the 7 of the kernel, then 1.0
        for the QRAUKF), the float state (quaternion ``q0``, zero bias, the initial covariance, the innovation
        window) and in ``extra`` the integer state, then with a robust block on the blocks' ``flags, mcoef,
        rcoef, acoef`` (``g_ref``: g in acc units, for the rest detection and the acc low-pass) and their start
        states. ``frame`` does not enter (ENU); ValueError without the magnetometer (``use_mag`` False)."""
        if not use_mag:
            raise ValueError(f"{self.name}: needs a magnetometer (the pseudo-measurement of eq. 22)")
        return ukf_setup(float(dt), q0, robust=self.adaptive, **self._kwargs(), blocks=self._block_values(g_ref))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        g = gravity_in_units(rec) if self.robust else G_SI
        c = np.ascontiguousarray
        out = run_setup(self.kernel_setup(rec.dt, True, q0, rec.frame, g), c(rec.gyr, dtype=np.float64),
                        c(rec.acc, dtype=np.float64), c(rec.mag, dtype=np.float64))
        diag = {"bias": out["bias"], "skipped": out["skipped"]}
        if self.adaptive:
            diag["lam"] = out["lam"]
            diag["fallback"] = out["fallback"]
        for key in ("mag_gain", "rest"):
            if key in out:
                diag[key] = out[key]
        return FilterResult(out["quat"], "ENU", diag)

    def _block_values(self, g_ref: float) -> dict[str, Any] | None:
        """The robust blocks' values for :func:`ukf_setup` (``gravity`` = ``g_ref``) when one is on (QRAUKF),
        else None."""
        v = self.values
        if not any(bool(v.get(k)) for k in _BLOCK_SWITCHES):
            return None
        return {**{k: v[k] for k in _BLOCK_KEYS}, "gravity": float(g_ref)}

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample filter: the kernel (with a robust block on, the blocks' driver) on one sample at a
        time with the float, integer and block states carried (equal to :meth:`run` on the samples seen so
        far); the accelerometer is in m/s^2 (``g_ref`` = 9.80665) as for :meth:`run` on arrays."""
        return _UKFStream(self, rate_hz, dt, q0, frame)


class _UKFStream(StateStream):
    def _buffers(self) -> None:
        self._adaptive = bool(self._coef[C.ROBUST] != 0.0)
        self._work = new_work()
        self._bias = np.empty((1, 3))
        self._lam = np.empty((1, 3))
        self._skip = np.zeros(1, dtype=np.bool_)
        self._fallback = np.zeros(1, dtype=np.bool_)
        self._d = np.empty((1, 2))

    def _step(self, state, gyr, acc, mag):
        x = self._extra
        if len(x) == 1:
            _ukf_run(gyr, acc, mag, self._coef, self._adaptive, state, x[0], self._work, self._out, self._bias,
                     self._lam, self._skip, self._fallback)
        else:
            _ukf_robust_loop(gyr, acc, mag, self._coef, self._adaptive, state, x[0], self._work, *x[1:], self._out,
                             self._bias, self._lam, self._skip, self._fallback, self._d)
        return self._out[0]


class QRAUKF(QUKF):
    """Quaternion-based robust adaptive UKF, eqs. 1-38 of Chiella et al. 2019 (see module docstring).

    The QUKF plus covariance matching of R over a sliding window (eqs. 34-35, 37) and the Hampel
    outlier gain (eqs. 36, 38). Additional parameters:

    window : int, samples, length N of the sliding window (paper 20 at 40 Hz = 0.5 s).
    n_sigma : float, confidence region of the Hampel identifier in MAD standard deviations (paper 3).

    Diagnostics add ``lam`` (N, 3) Hampel gains and ``fallback`` (N,) samples where eq. 37 gave no
    positive definite covariance and the nominal R0 was used.

    Robust blocks (options, all off by default = the paper's filter, bit for bit; not in the default
    search space; :mod:`objectives.attitude.filters.ukf.robust`): ``acc_lp_tau_s`` (earth-frame
    accelerometer low-pass, s), ``mag_rejection`` (with ``mag_norm_th``, ``mag_dip_th_deg``,
    ``mag_max_rejection_s``), ``rest_bias`` (with ``rest_bias_var``). With a block on, diagnostics add
    ``mag_gain`` (N,) and ``rest`` (N,).
    """

    name = "qraukf"
    decl = ParamSet("qraukf", _COMMON + (
        Param("window", 20, (5, 400), unit="samples", doc="sliding window length N (paper 20)", eq="eqs. 34-35",
              allowed=Interval(2.0), integer=True),
        Param("n_sigma", 3.0, (1.0, 10.0), unit="1", doc="Hampel confidence region (paper 3)", eq="eq. 36",
              allowed=POSITIVE),
    ) + _ROBUST_DECL)
    adaptive = True
    population = POPULATION

    def _kwargs(self) -> dict[str, Any]:
        kw = super()._kwargs()
        kw["window"] = self.values["window"]
        kw["n_sigma"] = self.values["n_sigma"]
        return kw
