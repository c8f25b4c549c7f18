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
from numba import njit

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import AttitudeFilter, FilterResult
from objectives.params import NONNEG, POSITIVE, Interval, Param, ParamSet

__all__ = ["QUKF", "QRAUKF", "run_ukf"]

_S2 = 1.0 / math.sqrt(2.0)
_TOL_MEAN = 1e-12
_MAX_MEAN_ITER = 6


# ----------------------------------------------------------------------------------------------
# scalar quaternion helpers (tuples: no allocation)
@njit(cache=True, inline="always")
def _qm(a0, a1, a2, a3, b0, b1, b2, b3):
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@njit(cache=True, inline="always")
def _r2q(rx, ry, rz):
    """Exponential map, eq. 2: rotation vector (rad) -> unit quaternion."""
    th = math.sqrt(rx * rx + ry * ry + rz * rz)
    if th == 0.0:
        return 1.0, 0.0, 0.0, 0.0
    h = 0.5 * th
    s = math.sin(h) / th
    return math.cos(h), s * rx, s * ry, s * rz


@njit(cache=True, inline="always")
def _q2r(w, x, y, z):
    """Logarithm map, eq. 1 (atan2 form, antipodal sign handled): unit quaternion -> rotation vector."""
    nn = math.sqrt(x * x + y * y + z * z)
    if nn == 0.0:
        return 0.0, 0.0, 0.0
    if w >= 0.0:
        f = 2.0 * math.atan2(nn, w) / nn
    else:
        f = -2.0 * math.atan2(nn, -w) / nn
    return f * x, f * y, f * z


@njit(cache=True, inline="always")
def _qdiff(a0, a1, a2, a3, b0, b1, b2, b3):
    """Eq. 3: ``e_a (-) e_b = Q2R(e_a * e_b^*)`` (rad, earth-frame rotation vector)."""
    w, x, y, z = _qm(a0, a1, a2, a3, b0, -b1, -b2, -b3)
    return _q2r(w, x, y, z)


@njit(cache=True, inline="always")
def _aqua_enu(ax, ay, az, bx, by, bz):
    """Eqs. 22-24: sensor-to-earth quaternion (ENU) from unit acc and mag vectors.

    Returns (ok, w, x, y, z); ``ok`` is False where Gamma = 0 (field parallel to gravity).
    """
    if az >= 0.0:
        l1 = math.sqrt(0.5 * (az + 1.0))
        a0, a1, a2, a3 = l1, -ay / (2.0 * l1), ax / (2.0 * l1), 0.0
    else:
        l2 = math.sqrt(0.5 * (1.0 - az))
        a0, a1, a2, a3 = -ay / (2.0 * l2), l2, 0.0, ax / (2.0 * l2)
    # (0, l) = e_acc^* (0, b) e_acc  -> l = R(e_acc)^T b
    t0, t1, t2, t3 = _qm(a0, -a1, -a2, -a3, 0.0, bx, by, bz)
    _, lx, ly, _lz = _qm(t0, t1, t2, t3, a0, a1, a2, a3)
    gam = lx * lx + ly * ly
    if not gam > 1e-12:  # unit vectors: field within 1e-6 rad of gravity
        return False, 1.0, 0.0, 0.0, 0.0
    sg = math.sqrt(gam)
    if lx >= 0.0:
        l3 = math.sqrt(gam + lx * sg)
        m0, m3 = l3 / math.sqrt(2.0 * gam), ly / (math.sqrt(2.0) * l3)
    else:
        l4 = math.sqrt(gam - lx * sg)
        m0, m3 = ly / (math.sqrt(2.0) * l4), l4 / math.sqrt(2.0 * gam)
    c0, c1, c2, c3 = _qm(a0, a1, a2, a3, m0, 0.0, 0.0, m3)
    # e_m = conj(e_acc * e_mag) in NWU; ENU = Q_ENU_FROM_NWU * e_m
    w, x, y, z = _qm(_S2, 0.0, 0.0, _S2, c0, -c1, -c2, -c3)
    return True, w, x, y, z


# ----------------------------------------------------------------------------------------------
# small linear algebra on preallocated arrays
@njit(cache=True)
def _chol(A, L, n):
    """Lower Cholesky factor of A[:n, :n] into L; False if A is not positive definite."""
    for i in range(n):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if not s > 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
        for j in range(i + 1, n):
            L[i, j] = 0.0
    return True


@njit(cache=True)
def _inv3_spd(A, L, Ainv):
    """Inverse of a 3x3 symmetric positive definite matrix through Cholesky; False if not SPD."""
    if not _chol(A, L, 3):
        return False
    # inverse of L (lower)
    i00 = 1.0 / L[0, 0]
    i11 = 1.0 / L[1, 1]
    i22 = 1.0 / L[2, 2]
    i10 = -L[1, 0] * i00 * i11
    i21 = -L[2, 1] * i11 * i22
    i20 = -(L[2, 0] * i00 + L[2, 1] * i10) * i22
    # A^-1 = Linv^T Linv
    Ainv[0, 0] = i00 * i00 + i10 * i10 + i20 * i20
    Ainv[0, 1] = i10 * i11 + i20 * i21
    Ainv[0, 2] = i20 * i22
    Ainv[1, 1] = i11 * i11 + i21 * i21
    Ainv[1, 2] = i21 * i22
    Ainv[2, 2] = i22 * i22
    Ainv[1, 0] = Ainv[0, 1]
    Ainv[2, 0] = Ainv[0, 2]
    Ainv[2, 1] = Ainv[1, 2]
    return True


@njit(cache=True)
def _select(buf, n, k):
    """k-th smallest of buf[:n] (quickselect, in place)."""
    lo, hi = 0, n - 1
    while lo < hi:
        pivot = buf[(lo + hi) >> 1]
        i, j = lo, hi
        while i <= j:
            while buf[i] < pivot:
                i += 1
            while buf[j] > pivot:
                j -= 1
            if i <= j:
                t = buf[i]
                buf[i] = buf[j]
                buf[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return buf[k]


@njit(cache=True)
def _median(buf, n):
    """Median of buf[:n] (reorders buf)."""
    h = n // 2
    m = _select(buf, n, h)
    if n % 2 == 1:
        return m
    lo = buf[0]
    for i in range(1, h):
        if buf[i] > lo:
            lo = buf[i]
    return 0.5 * (lo + m)


# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def _meas_ut(a, b, sig_a, sig_b, Y, Dm, out_y, R):
    """Eq. 25: quaternion pseudo-measurement (ENU) and its covariance R (3x3) by the UT of eqs. 9-15.

    ``a`` and ``b`` are (3,) raw acc and mag; the UT runs on the normalised vectors with the noise
    scaled by the norms (h of eq. 22 does not depend on the vectors' lengths). Returns False when the
    vectors are degenerate. ``Y`` (12, 4) and ``Dm`` (12, 3) are scratch arrays.
    """
    na = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    nb = math.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
    if not (na > 0.0 and nb > 0.0 and math.isfinite(na) and math.isfinite(nb)):
        return False
    ax, ay, az = a[0] / na, a[1] / na, a[2] / na
    bx, by, bz = b[0] / nb, b[1] / nb, b[2] / nb
    ok, r0, r1, r2, r3 = _aqua_enu(ax, ay, az, bx, by, bz)
    if not ok:
        return False
    sq = math.sqrt(6.0)
    da = sq * sig_a / na
    db = sq * sig_b
    for j in range(12):
        i = j % 3
        sgn = 1.0 if j < 6 else -1.0
        px, py, pz, mx, my, mz = ax, ay, az, bx, by, bz
        if (j % 6) < 3:
            if i == 0:
                px += sgn * da
            elif i == 1:
                py += sgn * da
            else:
                pz += sgn * da
        else:
            if i == 0:
                mx += sgn * db
            elif i == 1:
                my += sgn * db
            else:
                mz += sgn * db
        n1 = math.sqrt(px * px + py * py + pz * pz)
        n2 = math.sqrt(mx * mx + my * my + mz * mz)
        ok, w, x, y, z = _aqua_enu(px / n1, py / n1, pz / n1, mx / n2, my / n2, mz / n2)
        if not ok:
            return False
        Y[j, 0], Y[j, 1], Y[j, 2], Y[j, 3] = w, x, y, z
    return _wmean_cov(Y, 12, r0, r1, r2, r3, out_y, R, Dm)


@njit(cache=True)
def _wmean_cov(Y, m, r0, r1, r2, r3, out_y, P, D):
    """Eqs. 13-14 for equally weighted quaternions Y[:m]: iterative mean from (r0..r3), covariance P.

    D[:m, :3] receives the deviations ``Y_j (-) y_hat`` of the last iteration.
    """
    w = 1.0 / m
    for _ in range(_MAX_MEAN_ITER):
        sx = sy = sz = 0.0
        cxx = cxy = cxz = cyy = cyz = czz = 0.0
        for j in range(m):
            dx, dy, dz = _qdiff(Y[j, 0], Y[j, 1], Y[j, 2], Y[j, 3], r0, r1, r2, r3)
            D[j, 0], D[j, 1], D[j, 2] = dx, dy, dz
            sx += dx
            sy += dy
            sz += dz
            cxx += dx * dx
            cxy += dx * dy
            cxz += dx * dz
            cyy += dy * dy
            cyz += dy * dz
            czz += dz * dz
        sx *= w
        sy *= w
        sz *= w
        if sx * sx + sy * sy + sz * sz < _TOL_MEAN * _TOL_MEAN:
            break
        e0, e1, e2, e3 = _r2q(sx, sy, sz)
        r0, r1, r2, r3 = _qm(e0, e1, e2, e3, r0, r1, r2, r3)
    out_y[0], out_y[1], out_y[2], out_y[3] = r0, r1, r2, r3
    # covariance about the mean (the residual mean step is below 1e-12 rad)
    P[0, 0] = cxx * w
    P[0, 1] = P[1, 0] = cxy * w
    P[0, 2] = P[2, 0] = cxz * w
    P[1, 1] = cyy * w
    P[1, 2] = P[2, 1] = cyz * w
    P[2, 2] = czz * w
    return True


@njit(cache=True)
def _ukf_kernel(gyr, acc, mag, dt, q0, coef, robust, window,
                out_q, out_bias, out_lam, out_skip, out_fallback):
    """QUKF (eqs. 26-33) and, with ``robust``, QRAUKF (eqs. 34-38) over a whole recording.

    gyr, acc, mag : (N, 3) rad/s, m/s^2, any unit. dt : s. q0 : (4,) ENU sensor-to-earth.
    coef : (8,) sigma_gyr [rad/s], att_rw [rad/sqrt(s)], bias_rw [rad/s/sqrt(s)], sigma_acc [m/s^2],
        sigma_mag [1, relative], n_sigma [1], p0_att [rad], p0_bias [rad/s].
    window : int, N of eqs. 34-37. Outputs (N, 4), (N, 3), (N, 3), (N,) bool, (N,) bool.
    """
    n = gyr.shape[0]
    sig_g, att_rw, bias_rw, sig_a, sig_m, n_sig, p0a, p0b = (
        coef[0], coef[1], coef[2], coef[3], coef[4], coef[5], coef[6], coef[7])
    q2a = att_rw * att_rw * dt
    q2b = bias_rw * bias_rw * dt
    # scratch, allocated once per run
    P = np.zeros((6, 6))
    L = np.zeros((6, 6))
    E = np.empty((18, 4))       # forecast sigma quaternions (eq. 26)
    D = np.empty((18, 6))       # their deviations from the mean
    Bs = np.empty((18, 3))      # bias parts
    Ym = np.empty((12, 4))      # measurement UT sigma images (eq. 25)
    Dm = np.empty((12, 3))
    ymeas = np.empty(4)
    emean = np.empty(4)
    R0 = np.zeros((3, 3))
    Rh = np.zeros((3, 3))
    Pyy = np.zeros((3, 3))
    Lyy = np.zeros((3, 3))
    Syy = np.zeros((3, 3))
    K = np.zeros((6, 3))
    win = np.zeros((max(window, 1), 3))
    lamw = np.empty(3)
    buf = np.empty(max(window, 1))
    med = np.empty(3)
    mad = np.empty(3)
    nwin = 0
    iwin = 0

    e0, e1, e2, e3 = q0[0], q0[1], q0[2], q0[3]
    b = np.zeros(3)
    for i in range(3):
        P[i, i] = p0a * p0a
        P[i + 3, i + 3] = p0b * p0b
    sq9 = 3.0  # sqrt(n~ - 1) with the 9-D augmented tangent space (6 state + 3 gyro noise)

    for k in range(n):
        # ---------------- forecast, eqs. 26-27 -------------------------------------------------
        if k > 0:
            wx, wy, wz = gyr[k - 1, 0], gyr[k - 1, 1], gyr[k - 1, 2]
            if math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz):
                if not _chol(P, L, 6):
                    for i in range(6):
                        for j in range(6):
                            if i != j:
                                P[i, j] = 0.0
                        P[i, i] = max(abs(P[i, i]), 1e-30)
                    _chol(P, L, 6)
                # mean-input image as the start of the iterative mean
                ux, uy, uz = (wx - b[0]) * dt, (wy - b[1]) * dt, (wz - b[2]) * dt
                d0, d1, d2, d3 = _r2q(ux, uy, uz)
                r0, r1, r2, r3 = _qm(e0, e1, e2, e3, d0, d1, d2, d3)
                for j in range(18):
                    col = j % 9
                    sgn = sq9 if j < 9 else -sq9
                    dx = dy = dz = 0.0
                    db0 = db1 = db2 = 0.0
                    nq0 = nq1 = nq2 = 0.0
                    if col < 6:
                        dx, dy, dz = sgn * L[0, col], sgn * L[1, col], sgn * L[2, col]
                        db0, db1, db2 = sgn * L[3, col], sgn * L[4, col], sgn * L[5, col]
                    elif col == 6:
                        nq0 = sgn * sig_g
                    elif col == 7:
                        nq1 = sgn * sig_g
                    else:
                        nq2 = sgn * sig_g
                    # sigma point, eqs. 4 and 9: e_j = R2Q(d) * e
                    p0, p1, p2, p3 = _r2q(dx, dy, dz)
                    s0, s1, s2, s3 = _qm(p0, p1, p2, p3, e0, e1, e2, e3)
                    bj0, bj1, bj2 = b[0] + db0, b[1] + db1, b[2] + db2
                    # f of eqs. 17-20 with u = u_m - beta - q_u (eq. 18)
                    a0, a1, a2, a3 = _r2q((wx - bj0 - nq0) * dt, (wy - bj1 - nq1) * dt, (wz - bj2 - nq2) * dt)
                    E[j, 0], E[j, 1], E[j, 2], E[j, 3] = _qm(s0, s1, s2, s3, a0, a1, a2, a3)
                    Bs[j, 0], Bs[j, 1], Bs[j, 2] = bj0, bj1, bj2
                _wmean_cov(E, 18, r0, r1, r2, r3, emean, Pyy, D)
                e0, e1, e2, e3 = emean[0], emean[1], emean[2], emean[3]
                # bias mean (sigma points symmetric, mean unchanged) and deviations, eq. 14
                for j in range(18):
                    D[j, 3], D[j, 4], D[j, 5] = Bs[j, 0] - b[0], Bs[j, 1] - b[1], Bs[j, 2] - b[2]
                for r in range(6):
                    for c in range(r + 1):
                        s = 0.0
                        for j in range(18):
                            s += D[j, r] * D[j, c]
                        P[r, c] = s / 18.0
                        P[c, r] = P[r, c]
            # eq. 27: additive process noise Q2
            for i in range(3):
                P[i, i] += q2a
                P[i + 3, i + 3] += q2b

        # ---------------- data assimilation, eqs. 28-33 (and 34-38) ---------------------------
        skipped = True
        ok = math.isfinite(mag[k, 0] + mag[k, 1] + mag[k, 2] + acc[k, 0] + acc[k, 1] + acc[k, 2])
        if ok:
            ok = _meas_ut(acc[k], mag[k], sig_a, sig_m, Ym, Dm, ymeas, R0)
        lx = ly = lz = 1.0
        if ok:
            # eq. 28 closed form: y_hat = e, P~yy = P_ee, Pxy = P[:, :3]; eq. 30 innovation
            vx, vy, vz = _qdiff(ymeas[0], ymeas[1], ymeas[2], ymeas[3], e0, e1, e2, e3)
            use_nominal = True
            if robust:
                win[iwin, 0], win[iwin, 1], win[iwin, 2] = vx, vy, vz
                iwin = (iwin + 1) % window
                nwin = min(nwin + 1, window)
                # eq. 36: Hampel identifier per innovation component
                for c in range(3):
                    for j in range(nwin):
                        buf[j] = win[j, c]
                    med[c] = _median(buf, nwin)
                    for j in range(nwin):
                        buf[j] = abs(win[j, c] - med[c])
                    mad[c] = 1.4826 * _median(buf, nwin)
                # eq. 37: covariance matching with the Hampel-weighted innovations
                for r in range(3):
                    for c in range(3):
                        Syy[r, c] = 0.0
                for j in range(nwin):
                    for c in range(3):
                        dev = abs(win[j, c] - med[c])
                        lam = 1.0
                        if dev > n_sig * mad[c]:
                            lam = n_sig * mad[c] / dev
                        lamw[c] = lam * win[j, c]
                    for r in range(3):
                        for c in range(3):
                            Syy[r, c] += lamw[r] * lamw[c]
                for r in range(3):
                    for c in range(3):
                        Rh[r, c] = max(Syy[r, c] / nwin - P[r, c], R0[r, c])
                        Pyy[r, c] = P[r, c] + Rh[r, c]
                # R_hat must be a covariance (positive definite), else eq. 33 loses definiteness
                use_nominal = not (_chol(Rh, Lyy, 3) and _inv3_spd(Pyy, Lyy, Syy))
                out_fallback[k] = use_nominal
                # gain of the current innovation (eq. 38)
                vv = (vx, vy, vz)
                for c in range(3):
                    dev = abs(vv[c] - med[c])
                    lam = 1.0
                    if dev > n_sig * mad[c]:
                        lam = n_sig * mad[c] / dev
                    lamw[c] = lam
                lx, ly, lz = lamw[0], lamw[1], lamw[2]
            if use_nominal:
                for r in range(3):
                    for c in range(3):
                        Pyy[r, c] = P[r, c] + R0[r, c]  # eq. 29
                ok = _inv3_spd(Pyy, Lyy, Syy)
        if ok:
            # eq. 31: K = Pxy Pyy^-1 with Pxy = P[:, :3]
            for r in range(6):
                for c in range(3):
                    K[r, c] = P[r, 0] * Syy[0, c] + P[r, 1] * Syy[1, c] + P[r, 2] * Syy[2, c]
            gx, gy, gz = lx * vx, ly * vy, lz * vz
            # eq. 32 / 38: x = x (+) K lambda v
            cx = K[0, 0] * gx + K[0, 1] * gy + K[0, 2] * gz
            cy = K[1, 0] * gx + K[1, 1] * gy + K[1, 2] * gz
            cz = K[2, 0] * gx + K[2, 1] * gy + K[2, 2] * gz
            p0, p1, p2, p3 = _r2q(cx, cy, cz)
            e0, e1, e2, e3 = _qm(p0, p1, p2, p3, e0, e1, e2, e3)
            for r in range(3):
                b[r] += K[r + 3, 0] * gx + K[r + 3, 1] * gy + K[r + 3, 2] * gz
            # eq. 33: P = P - K Pyy K^T = P - K Pxy^T
            for r in range(6):
                for c in range(r + 1):
                    s = K[r, 0] * P[c, 0] + K[r, 1] * P[c, 1] + K[r, 2] * P[c, 2]
                    L[r, c] = s
            for r in range(6):
                for c in range(r + 1):
                    P[r, c] -= L[r, c]
                    P[c, r] = P[r, c]
            skipped = False
        out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = e0, e1, e2, e3
        out_bias[k, 0], out_bias[k, 1], out_bias[k, 2] = b[0], b[1], b[2]
        out_lam[k, 0], out_lam[k, 1], out_lam[k, 2] = lx, ly, lz
        out_skip[k] = skipped


def run_ukf(gyr, acc, mag, dt, q0, *, sigma_gyr, att_rw, bias_rw, sigma_acc, sigma_mag,
            p0_att=0.1, p0_bias=0.01, robust=False, window=20, n_sigma=3.0) -> dict[str, np.ndarray]:
    """Array entry point of QUKF (``robust=False``) and QRAUKF (``robust=True``), ENU frame.

    Parameters
    ----------
    gyr, acc, mag : (N, 3) arrays, rad/s, m/s^2, any unit. NaN samples are allowed here (see the
        module docstring for what each does).
    dt : float, s.
    q0 : (4,) initial sensor-to-earth quaternion in ENU, unit norm.
    sigma_gyr ... n_sigma : see :class:`QUKF` and :class:`QRAUKF`.

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
    out_q = np.empty((n, 4))
    out_b = np.empty((n, 3))
    out_l = np.empty((n, 3))
    out_s = np.zeros(n, dtype=np.bool_)
    out_f = np.zeros(n, dtype=np.bool_)
    _ukf_kernel(gyr, acc, mag, dt, q0, coef, bool(robust), max(window, 1), out_q, out_b, out_l, out_s, out_f)
    return {"quat": out_q, "bias": out_b, "lam": out_l, "skipped": out_s, "fallback": out_f}


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

    :meth:`stream` uses the buffered fallback of :mod:`objectives.attitude.filters.stream` (equal to
    the batch, O(n) per sample): the kernel does not yet take and return its state (quaternion, bias,
    covariance and, for the QRAUKF, the innovation window).
    """

    name = "qukf"
    working_frame = "ENU"
    needs_mag = True
    decl = ParamSet("qukf", _COMMON)
    robust = False

    def _kwargs(self) -> dict[str, Any]:
        v = self.values
        return {k: v[k] for k in _KERNEL_KEYS}

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        out = run_ukf(rec.gyr, rec.acc, rec.mag, rec.dt, q0, robust=self.robust, **self._kwargs())
        diag = {"bias": out["bias"], "skipped": out["skipped"]}
        if self.robust:
            diag["lam"] = out["lam"]
            diag["fallback"] = out["fallback"]
        return FilterResult(out["quat"], "ENU", diag)


class QRAUKF(QUKF):
    """Quaternion-based robust adaptive UKF, eqs. 1-38 of Chiella et al. 2019 (see module docstring).

    The QUKF plus covariance matching of R over a sliding window (eqs. 34-35, 37) and the Hampel
    outlier gain (eqs. 36, 38). Additional parameters:

    window : int, samples, length N of the sliding window (paper 20 at 40 Hz = 0.5 s).
    n_sigma : float, confidence region of the Hampel identifier in MAD standard deviations (paper 3).

    Diagnostics add ``lam`` (N, 3) Hampel gains and ``fallback`` (N,) samples where eq. 37 gave no
    positive definite covariance and the nominal R0 was used.
    """

    name = "qraukf"
    decl = ParamSet("qraukf", _COMMON + (
        Param("window", 20, (5, 400), unit="samples", doc="sliding window length N (paper 20)", eq="eqs. 34-35",
              allowed=Interval(2.0), integer=True),
        Param("n_sigma", 3.0, (1.0, 10.0), unit="1", doc="Hampel confidence region (paper 3)", eq="eq. 36",
              allowed=POSITIVE),
    ))
    robust = True

    def _kwargs(self) -> dict[str, Any]:
        kw = super()._kwargs()
        kw["window"] = self.values["window"]
        kw["n_sigma"] = self.values["n_sigma"]
        return kw
