"""Numba kernels of the quaternion UKFs (QUKF, QRAUKF; Chiella, Teixeira & Pereira, Sensors 19:2372, 2019).

The equations and deviations are documented in :mod:`objectives.attitude.filters.ukf`; this module
holds the per-sample arithmetic, written for the fixed sizes of the problem (6 error dimensions,
3 gyro-noise dimensions, 18 forecast and 12 measurement sigma points):

- The forecast (eq. 26) uses that the Cholesky factor ``L`` is lower triangular: only its first
  three columns move the attitude, so 6 of the 18 sigma points have a rotated attitude and the
  other 12 share ``e``; the bias-bias block of ``P`` is unchanged by the forecast (``L L^T``) and
  only the attitude-bias block is summed over the 12 points that carry a bias deviation.
- Sigma points are stored one per column (``(4, 18)`` quaternions, ``(3, 18)`` deviations), and the
  forecast's 18 points are built (``R2Q(d_j) * e * R2Q(u_j dt)``, with ``d_j = 0`` exactly for the 12
  unrotated ones) and compared with the mean (eq. 3) in loops without branches, which the compiler
  turns into vector code: eq. 2 by its power series (valid below 0.5 rad) and eq. 1 by its series
  (valid below ``|n| = 0.1``, 0.2 rad), both truncated below 1e-19 relative. When any point of a
  loop is beyond that range the loop is redone with the exact scalar maps (atan2, sin, cos), so the
  result never depends on a truncated series outside its range. The measurement UT's 12 points
  are padded to 16 columns (two vector iterations; 12 columns stayed scalar, the vector loop judged
  not worth it by LLVM) and get the scalar logarithm's own values, its two series computed and one
  selected without a branch (:mod:`objectives.attitude.filters.ukf.mean`).
- A vector loop holds no floating-point sum: without fast-math LLVM may not reassociate one, so a
  sum keeps the whole loop scalar; the means store the deviations first and sum them afterwards,
  in the same order (the forecast mean's column loop had run scalar since fast-math was dropped).
- The exponential and logarithm maps (eqs. 1-2) elsewhere use their power series for small angles
  (see :mod:`objectives.attitude.filters.ukf.scalar`, which holds the scalar helpers).
- The iterative mean (eqs. 5, 13) saves its last pass when the next step is predicted below
  1e-13 rad (:mod:`objectives.attitude.filters.ukf.mean`, which holds both means).
- The 6x6 Cholesky factor divides once per column (reciprocal of the pivot).
- QRAUKF's sorted innovation window finds the removal and insertion places by branch-free counts and
  the MAD merge uses selects (eq. 36; the same values bit for bit): innovations are noise, so the
  former bisection and insertion scans mispredicted most of their jumps.
- Compiled with the NumPy error model (no division checks) and, as every kernel, without fast-math flags
  (:mod:`objectives.jit`, rule 1; the profile below was measured with them).
- The pseudo-measurement UT (eq. 25) shares the accelerometer quaternion between the 6 magnetometer
  sigma points, and uses that the magnetometer quaternion of eq. 24 does not depend on the length
  of the field vector.
- All scratch lives in one ``work`` array allocated by the caller; nothing is allocated per sample.

Where the time goes
-------------------
Per sample on ``bench6dof`` at 1 kHz (one core of the shared 2-core machine, minimum over 25 interleaved
runs; each part's cost = the run time minus the run time with that part switched off in a scratch copy of
the kernel, so the parts overlap and do not add up exactly; the "rest" is everything switched off at once:
the update of eqs. 29-33, the nominal pseudo-measurement, the cross block of eq. 14, the outputs):

==========================  ==========  =========
part                        before, ns  after, ns
==========================  ==========  =========
QUKF total                  1119        980
measurement UT (eq. 25)     470         456
  of which its mean         248         229
forecast propagation        208         163
forecast mean (1.0 pass)    180         100
Cholesky 6x6                83          96 (*)
rest                        216         208
QRAUKF total                1623        1318
  Hampel window, eqs. 34-37 503         337
==========================  ==========  =========

(*) switching the factor off leaves the sigma points degenerate, so this difference is not a clean
cost. The forecast mean takes 1.0 pass per sample (the BCH shortcut in 21-99 % of them), the
measurement mean 2.0-2.5 passes (BCH in 57-93 %), measured on bench6dof and BROAD trial 07. What
was tried and measured slower, so left out: the 12 measurement sigma points as vector columns (a
branch-free eq. 22-24 and the series mean; 12 columns run mostly in the vector remainder), the same
padded to 16 columns, the magnetometer points' deviations in closed form (an earth-z rotation by the
heading change: an atan series per point costs as much as the logarithm it replaces), and the
forecast's first mean pass fused into the propagation loop in scalar form (those with fast-math).

The table was measured with fast-math. Without it (rule 1), best of 9 thread-CPU runs on bench6dof 60 s
at 1 kHz: QUKF 1277 ns per sample (0.180x the EKF's samples/s), 1129 ns (0.205x) once the forecast
mean's column loop vectorised again (its sums taken apart), 1076 ns (0.217x) with the measurement
mean's columns vectorised too (padded to 16, the scalar logarithm's values); QRAUKF 1653, 1543, 1493 ns.

State passed in and out
-----------------------
A run is ``_ukf_run(gyr, acc, mag, coef, robust, state, istate, work, outputs...)``: it reads the filter
state from ``state`` / ``istate``, processes the samples and writes the state back, so a recording
processed in pieces (down to one sample per call) gives the same result, bit for bit, as one call
over the whole of it. Layout (:func:`new_state` builds it):

``state`` float64 (46 + 6 W,)
    [0:4] quaternion ``e`` (ENU, sensor-to-earth), [4:7] gyro bias (rad/s), [7:43] ``P`` (6 x 6,
    row-major; rad^2, rad^2/s, rad^2/s^2), [43:46] the previous gyro sample (rad/s; the forecast
    into sample k uses gyr[k-1], eq. 20), [46:46 + 3 W] the innovation window of eqs. 34-37
    (W x 3, rad, ring buffer), [46 + 3 W:] the same innovations sorted per component (3 x W).
``istate`` int64 (4,)
    samples processed so far, next write position in the window, filled window length, ``W``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters._scalar import qmul
from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.ukf.mean import _r2q_series, _wmean_cov
from objectives.attitude.filters.ukf.scalar import (
    _R2Q_SERIES_TH2,
    _acc_frame,
    _acc_quat,
    _aqua_finish,
    _chol,
    _inv3_spd,
    _is_pd3,
    _mad_sorted,
    _median_sorted,
    _qdiff,
    _r2q,
    _sorted_update,
    _store_sym3,
)

__all__ = ["C", "S", "I", "W", "N_STATE_FIXED", "WORK_SIZE", "new_state", "new_work", "ukf_chunk"]

#: the coefficient array (the kernel reads the first 7; ROBUST says which filter a setup is)
C = Layout("C", (("DT", 1, "s"), ("SIGMA_GYR", 1, "rad/s"), ("ATT_RW", 1, "rad/sqrt(s)"),
                 ("BIAS_RW", 1, "rad/s/sqrt(s)"), ("SIGMA_ACC", 1, "m/s^2"),
                 ("SIGMA_MAG", 1, "1, relative to the field norm"),
                 ("N_SIGMA", 1, "Hampel threshold, MADs"), ("ROBUST", 1, "1: QRAUKF, 0: QUKF")))
#: the state before the innovation window (module docstring): quaternion, bias, P (6 x 6), the previous gyro
S = Layout("S", (("Q", 4, "ENU sensor-to-earth quaternion e"), ("BIAS", 3, "gyro bias, rad/s"),
                 ("P", 36, "covariance, row-major 6 x 6"), ("GYR", 3, "the previous gyro sample, rad/s")))
#: entries of ``state`` before the innovation window
N_STATE_FIXED = S.LEN
#: the integer state ``istate``
I = Layout("I", (("SEEN", 1, "samples processed"), ("IWIN", 1, "next write position in the window"),
                 ("NWIN", 1, "filled window length"), ("WINDOW", 1, "window length W")))
#: the scratch ``work`` (float64), sigma points one per column
W = Layout("W", (("E", 72, "forecast sigma quaternions (4, 18)"), ("D", 54, "their deviations (3, 18)"),
                 ("DB", 54, "their bias deviations (3, 18)"),
                 ("YM", 64, "measurement UT images (4, 16): 12 and 4 padding"), ("DM", 48, "(3, 16)"),
                 ("L", 36, "Cholesky factor (6, 6)"), ("R0", 9, "3 x 3"), ("RH", 9, "3 x 3"),
                 ("PYY", 9, "3 x 3"), ("SYY", 9, "3 x 3"), ("K", 18, "gain (6, 3)"), ("LD", 6, "1 / diag(L)"),
                 ("U", 54, "rotation vectors u dt (3, 18)"), ("PA", 54, "attitude deviations (3, 18)")))
#: size of ``work``
WORK_SIZE = W.LEN



@njit(error_model="numpy")
def _meas_ut(ax, ay, az, bx, by, bz, sig_a, sig_b, Y, D, R):
    """Eq. 25: quaternion pseudo-measurement (ENU) and its covariance R (3x3) by the UT of eqs. 9-15.

    ``(ax, ay, az)`` and ``(bx, by, bz)`` are the raw acc and mag; the UT runs on the normalised
    vectors with the noise scaled by the norms (h of eq. 22 does not depend on the vectors' lengths).
    Returns (ok, w, x, y, z); ``ok`` False when the vectors are degenerate. ``Y`` (4, 16) and ``D``
    (3, 16) are scratch, one sigma point per column (the last 4 padding).
    """
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nb = math.sqrt(bx * bx + by * by + bz * bz)
    if not (na > 0.0 and nb > 0.0 and math.isfinite(na) and math.isfinite(nb)):
        return False, 1.0, 0.0, 0.0, 0.0
    ax, ay, az = ax / na, ay / na, az / na
    bx, by, bz = bx / nb, by / nb, bz / nb
    a0, a1, a2, a3 = _acc_quat(ax, ay, az)
    r00, r01, r02, r10, r11, r12 = _acc_frame(a0, a1, a2, a3)
    lx = r00 * bx + r01 * by + r02 * bz
    ly = r10 * bx + r11 * by + r12 * bz
    ok, q0, q1, q2, q3 = _aqua_finish(a0, a1, a2, a3, lx, ly, 1.0)
    if not ok:
        return False, 1.0, 0.0, 0.0, 0.0
    sq = math.sqrt(6.0)
    da = sq * sig_a / na
    db = sq * sig_b
    for j in range(12):
        i = j % 3
        sgn = 1.0 if j < 6 else -1.0
        if (j % 6) < 3:
            # accelerometer sigma point: a new tilt quaternion, the same unit field
            px, py, pz = ax, ay, az
            if i == 0:
                px += sgn * da
            elif i == 1:
                py += sgn * da
            else:
                pz += sgn * da
            h = 1.0 / math.sqrt(px * px + py * py + pz * pz)
            c0, c1, c2, c3 = _acc_quat(px * h, py * h, pz * h)
            s00, s01, s02, s10, s11, s12 = _acc_frame(c0, c1, c2, c3)
            ok, w, x, y, z = _aqua_finish(c0, c1, c2, c3, s00 * bx + s01 * by + s02 * bz,
                                          s10 * bx + s11 * by + s12 * bz, 1.0)
        else:
            # magnetometer sigma point: the nominal tilt, the field moved along axis i (unnormalised)
            d = sgn * db
            if i == 0:
                mx, my = lx + d * r00, ly + d * r10
                n2 = (bx + d) * (bx + d) + by * by + bz * bz
            elif i == 1:
                mx, my = lx + d * r01, ly + d * r11
                n2 = bx * bx + (by + d) * (by + d) + bz * bz
            else:
                mx, my = lx + d * r02, ly + d * r12
                n2 = bx * bx + by * by + (bz + d) * (bz + d)
            ok, w, x, y, z = _aqua_finish(a0, a1, a2, a3, mx, my, n2)
        if not ok:
            return False, 1.0, 0.0, 0.0, 0.0
        Y[0, j] = w
        Y[1, j] = x
        Y[2, j] = y
        Y[3, j] = z
    # 12 points, padded to 16 columns with the nominal quaternion (a vector loop's count; never summed), and the
    # values of the scalar logarithm
    for j in range(12, 16):
        Y[0, j], Y[1, j], Y[2, j], Y[3, j] = q0, q1, q2, q3
    y0, y1, y2, y3, cxx, cxy, cxz, cyy, cyz, czz = _wmean_cov(Y, 12, 16, q0, q1, q2, q3, D, False)
    _store_sym3(R, cxx, cxy, cxz, cyy, cyz, czz)
    return True, y0, y1, y2, y3


@njit(cache=True, inline="always")
def _hampel_gain(v, med, thr):
    """Eq. 36: ``min(1, thr / |v - med|)`` with gain 1 where the deviation is zero."""
    dev = abs(v - med)
    if dev > thr:
        return thr / dev
    return 1.0


# ----------------------------------------------------------------------------------------------
@njit(error_model="numpy")
def _ukf_run_inner(gyr, acc, mag, coef, robust, state, istate, work, out_q, out_bias, out_lam, out_skip,
                   out_fallback):
    """QUKF (eqs. 26-33) and, with ``robust``, QRAUKF (eqs. 34-38) over the samples of ``gyr``.

    gyr, acc, mag : (N, 3) rad/s, m/s^2, any unit.
    coef : (7,) dt [s], sigma_gyr [rad/s], att_rw [rad/sqrt(s)], bias_rw [rad/s/sqrt(s)],
        sigma_acc [m/s^2], sigma_mag [1, relative], n_sigma [1].
    robust : bool, QRAUKF.
    state, istate : filter state (module docstring), read and updated in place.
    work : (WORK_SIZE,) scratch.
    Outputs (N, 4), (N, 3), (N, 3), (N,) bool, (N,) bool: ENU quaternion, bias, Hampel gains,
    sample without assimilation, eq. 37 replaced by R0.
    """
    n = gyr.shape[0]
    dt, sig_g, att_rw, bias_rw, sig_a, sig_m, n_sig = (
        coef[C.DT], coef[C.SIGMA_GYR], coef[C.ATT_RW], coef[C.BIAS_RW], coef[C.SIGMA_ACC], coef[C.SIGMA_MAG],
        coef[C.N_SIGMA])
    q2a = att_rw * att_rw * dt
    q2b = bias_rw * bias_rw * dt
    window = istate[I.WINDOW]
    P = state[S.P:S.P + 36].reshape((6, 6))
    win = state[N_STATE_FIXED:N_STATE_FIXED + 3 * window].reshape((window, 3))
    srt = state[N_STATE_FIXED + 3 * window:N_STATE_FIXED + 6 * window].reshape((3, window))
    E = work[W.E:W.E + 72].reshape((4, 18))       # forecast sigma quaternions (eq. 26), one per column
    D = work[W.D:W.D + 54].reshape((3, 18))       # their deviations from the mean
    DB = work[W.DB:W.DB + 54].reshape((3, 18))    # their bias deviations
    U = work[W.U:W.U + 54].reshape((3, 18))       # their rotation vectors u dt (eq. 17)
    PA = work[W.PA:W.PA + 54].reshape((3, 18))    # their attitude deviations (zero for 12 of them)
    Ym = work[W.YM:W.YM + 64].reshape((4, 16))    # measurement UT sigma images (eq. 25), one per column, padded
    Dm = work[W.DM:W.DM + 48].reshape((3, 16))
    L = work[W.L:W.L + 36].reshape((6, 6))
    R0 = work[W.R0:W.R0 + 9].reshape((3, 3))
    Rh = work[W.RH:W.RH + 9].reshape((3, 3))
    Pyy = work[W.PYY:W.PYY + 9].reshape((3, 3))
    Syy = work[W.SYY:W.SYY + 9].reshape((3, 3))
    K = work[W.K:W.K + 18].reshape((6, 3))
    Ld = work[W.LD:W.LD + 6]                      # reciprocals of L's diagonal
    seen, iwin, nwin = istate[I.SEEN], istate[I.IWIN], istate[I.NWIN]
    e0, e1, e2, e3 = state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3]
    b0, b1, b2 = state[S.BIAS], state[S.BIAS + 1], state[S.BIAS + 2]
    wx, wy, wz = state[S.GYR], state[S.GYR + 1], state[S.GYR + 2]
    sq9 = 3.0  # sqrt(n~ - 1) with the 9-D augmented tangent space (6 state + 3 gyro noise)

    for k in range(n):
        # ---------------- forecast, eqs. 26-27 (gyr of the previous sample, eq. 20) -----------
        if seen > 0:
            if math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz):
                if not _chol(P, L, 6, Ld):
                    for i in range(6):
                        for j in range(6):
                            if i != j:
                                P[i, j] = 0.0
                        P[i, i] = max(abs(P[i, i]), 1e-30)
                    _chol(P, L, 6, Ld)
                # mean-input image as the start of the iterative mean
                d0, d1, d2, d3 = _r2q((wx - b0) * dt, (wy - b1) * dt, (wz - b2) * dt)
                r0, r1, r2, r3 = qmul(e0, e1, e2, e3, d0, d1, d2, d3)
                for j in range(18):
                    col = j % 9
                    sgn = sq9 if j < 9 else -sq9
                    db0 = db1 = db2 = 0.0
                    nq0 = nq1 = nq2 = 0.0
                    if col < 6:
                        db0, db1, db2 = sgn * L[3, col], sgn * L[4, col], sgn * L[5, col]
                    elif col == 6:
                        nq0 = sgn * sig_g
                    elif col == 7:
                        nq1 = sgn * sig_g
                    else:
                        nq2 = sgn * sig_g
                    DB[0, j], DB[1, j], DB[2, j] = db0, db1, db2
                    # f of eqs. 17-20 with u = u_m - beta - q_u (eq. 18)
                    U[0, j] = (wx - (b0 + db0) - nq0) * dt
                    U[1, j] = (wy - (b1 + db1) - nq1) * dt
                    U[2, j] = (wz - (b2 + db2) - nq2) * dt
                    # sigma point, eqs. 4 and 9: e_j = R2Q(d) * e (L lower triangular: only its first
                    # three columns have an attitude part; R2Q(0) * e = e exactly for the others)
                    if col < 3:
                        PA[0, j], PA[1, j], PA[2, j] = sgn * L[0, col], sgn * L[1, col], sgn * L[2, col]
                    else:
                        PA[0, j] = PA[1, j] = PA[2, j] = 0.0
                # E_j = R2Q(PA_j) * e * R2Q(U_j) for all 18 columns at once (vectorised power series);
                # the trigonometric form for all of them when any angle is beyond the series' range
                far = 0
                for j in range(18):
                    a0, a1, a2, a3, ta = _r2q_series(U[0, j], U[1, j], U[2, j])
                    p0, p1, p2, p3, tp = _r2q_series(PA[0, j], PA[1, j], PA[2, j])
                    far += (ta >= _R2Q_SERIES_TH2) + (tp >= _R2Q_SERIES_TH2)
                    s0, s1, s2, s3 = qmul(p0, p1, p2, p3, e0, e1, e2, e3)
                    E[0, j], E[1, j], E[2, j], E[3, j] = qmul(s0, s1, s2, s3, a0, a1, a2, a3)
                if far > 0:
                    for j in range(18):
                        a0, a1, a2, a3 = _r2q(U[0, j], U[1, j], U[2, j])
                        p0, p1, p2, p3 = _r2q(PA[0, j], PA[1, j], PA[2, j])
                        s0, s1, s2, s3 = qmul(p0, p1, p2, p3, e0, e1, e2, e3)
                        E[0, j], E[1, j], E[2, j], E[3, j] = qmul(s0, s1, s2, s3, a0, a1, a2, a3)
                e0, e1, e2, e3, cxx, cxy, cxz, cyy, cyz, czz = _wmean_cov(E, 18, 18, r0, r1, r2, r3, D, True)
                # eq. 14: attitude block from the mean; the bias mean is unchanged (symmetric
                # points) and the bias block is L_b L_b^T = P_bb, so only the cross block is summed
                _store_sym3(P, cxx, cxy, cxz, cyy, cyz, czz)
                for r in range(3):
                    for c in range(3):
                        s = 0.0
                        for j in range(6):
                            s += D[r, j] * DB[c, j] + D[r, j + 9] * DB[c, j + 9]
                        P[r, c + 3] = P[c + 3, r] = s / 18.0
            # eq. 27: additive process noise Q2
            for i in range(3):
                P[i, i] += q2a
                P[i + 3, i + 3] += q2b
        wx, wy, wz = gyr[k, 0], gyr[k, 1], gyr[k, 2]
        seen += 1

        # ---------------- data assimilation, eqs. 28-33 (and 34-38) ---------------------------
        skipped = True
        ok = math.isfinite(mag[k, 0] + mag[k, 1] + mag[k, 2] + acc[k, 0] + acc[k, 1] + acc[k, 2])
        y0 = 1.0
        y1 = y2 = y3 = 0.0
        if ok:
            ok, y0, y1, y2, y3 = _meas_ut(acc[k, 0], acc[k, 1], acc[k, 2], mag[k, 0], mag[k, 1], mag[k, 2],
                                          sig_a, sig_m, Ym, Dm, R0)
        lx = ly = lz = 1.0
        if ok:
            # eq. 28 closed form: y_hat = e, P~yy = P_ee, Pxy = P[:, :3]; eq. 30 innovation
            vx, vy, vz = _qdiff(y0, y1, y2, y3, e0, e1, e2, e3)
            use_nominal = True
            if robust:
                # eq. 36: Hampel identifier per innovation component; the window is kept sorted per
                # component (one removal and one insertion per sample) for the median and the MAD
                full = nwin == window
                _sorted_update(srt[0], nwin, full, win[iwin, 0], vx)
                _sorted_update(srt[1], nwin, full, win[iwin, 1], vy)
                nwin = _sorted_update(srt[2], nwin, full, win[iwin, 2], vz)
                win[iwin, 0], win[iwin, 1], win[iwin, 2] = vx, vy, vz
                iwin = (iwin + 1) % window
                m0 = _median_sorted(srt[0], nwin)
                m1 = _median_sorted(srt[1], nwin)
                m2 = _median_sorted(srt[2], nwin)
                t0 = n_sig * (1.4826 * _mad_sorted(srt[0], nwin, m0))
                t1 = n_sig * (1.4826 * _mad_sorted(srt[1], nwin, m1))
                t2 = n_sig * (1.4826 * _mad_sorted(srt[2], nwin, m2))
                # eq. 37: covariance matching with the Hampel-weighted innovations
                sxx = sxy = sxz = syy = syz = szz = 0.0
                for j in range(nwin):
                    ux = _hampel_gain(win[j, 0], m0, t0) * win[j, 0]
                    uy = _hampel_gain(win[j, 1], m1, t1) * win[j, 1]
                    uz = _hampel_gain(win[j, 2], m2, t2) * win[j, 2]
                    sxx += ux * ux
                    sxy += ux * uy
                    sxz += ux * uz
                    syy += uy * uy
                    syz += uy * uz
                    szz += uz * uz
                Syy[0, 0], Syy[0, 1], Syy[0, 2] = sxx / nwin, sxy / nwin, sxz / nwin
                Syy[1, 1], Syy[1, 2], Syy[2, 2] = syy / nwin, syz / nwin, szz / nwin
                Syy[1, 0], Syy[2, 0], Syy[2, 1] = Syy[0, 1], Syy[0, 2], Syy[1, 2]
                for r in range(3):
                    for c in range(3):
                        Rh[r, c] = max(Syy[r, c] - P[r, c], R0[r, c])
                        Pyy[r, c] = P[r, c] + Rh[r, c]
                # R_hat must be a covariance (positive definite), else eq. 33 loses definiteness
                use_nominal = not (_is_pd3(Rh) and _inv3_spd(Pyy, Syy))
                out_fallback[k] = use_nominal
                # gain of the current innovation (eq. 38)
                lx = _hampel_gain(vx, m0, t0)
                ly = _hampel_gain(vy, m1, t1)
                lz = _hampel_gain(vz, m2, t2)
            if use_nominal:
                for r in range(3):
                    for c in range(3):
                        Pyy[r, c] = P[r, c] + R0[r, c]  # eq. 29
                ok = _inv3_spd(Pyy, Syy)
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
            e0, e1, e2, e3 = qmul(p0, p1, p2, p3, e0, e1, e2, e3)
            b0 += K[3, 0] * gx + K[3, 1] * gy + K[3, 2] * gz
            b1 += K[4, 0] * gx + K[4, 1] * gy + K[4, 2] * gz
            b2 += K[5, 0] * gx + K[5, 1] * gy + K[5, 2] * gz
            # eq. 33: P = P - K Pyy K^T = P - K Pxy^T (lower triangle first: P[:, :3] is read)
            for r in range(6):
                for c in range(r + 1):
                    L[r, c] = K[r, 0] * P[c, 0] + K[r, 1] * P[c, 1] + K[r, 2] * P[c, 2]
            for r in range(6):
                for c in range(r + 1):
                    P[r, c] -= L[r, c]
                    P[c, r] = P[r, c]
            skipped = False
        out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = e0, e1, e2, e3
        out_bias[k, 0], out_bias[k, 1], out_bias[k, 2] = b0, b1, b2
        out_lam[k, 0], out_lam[k, 1], out_lam[k, 2] = lx, ly, lz
        out_skip[k] = skipped

    state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3] = e0, e1, e2, e3
    state[S.BIAS], state[S.BIAS + 1], state[S.BIAS + 2] = b0, b1, b2
    state[S.GYR], state[S.GYR + 1], state[S.GYR + 2] = wx, wy, wz
    istate[I.SEEN], istate[I.IWIN], istate[I.NWIN] = seen, iwin, nwin


@njit(cache=True, error_model="numpy")
def _ukf_run(gyr, acc, mag, coef, robust, state, istate, work, out_q, out_bias, out_lam, out_skip, out_fallback):
    """:func:`_ukf_run_inner`, cached: the entry Python calls. The population and robust kernels call the uncached
    body itself (rule 2 of :mod:`objectives.jit`), so a process compiles it once, not once more for a twin."""
    _ukf_run_inner(gyr, acc, mag, coef, robust, state, istate, work, out_q, out_bias, out_lam, out_skip,
                   out_fallback)


# ----------------------------------------------------------------------------------------------
def new_state(q0: np.ndarray, p0_att: float, p0_bias: float, window: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Initial ``(state, istate)`` of a run (layout in the module docstring).

    q0 : (4,) unit ENU sensor-to-earth quaternion. p0_att : rad, p0_bias : rad/s, initial standard
    deviations (diagonal ``P``). window : int >= 1, samples in the innovation window (QRAUKF).
    """
    window = int(window)
    if window < 1:
        raise ValueError(f"window must be an integer >= 1, got {window!r}")
    state = np.zeros(N_STATE_FIXED + 6 * window)
    state[S.Q:S.Q + 4] = np.asarray(q0, dtype=np.float64).reshape(4)
    P = state[S.P:S.P + 36].reshape(6, 6)
    P[[0, 1, 2], [0, 1, 2]] = float(p0_att) ** 2
    P[[3, 4, 5], [3, 4, 5]] = float(p0_bias) ** 2
    istate = np.zeros(I.LEN, dtype=np.int64)
    istate[I.WINDOW] = window
    return state, istate


def new_work() -> np.ndarray:
    """Scratch array of one run (:data:`WORK_SIZE` values)."""
    return np.zeros(WORK_SIZE)


def ukf_chunk(gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray, coef: np.ndarray, robust: bool,
              state: np.ndarray, istate: np.ndarray, work: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Run the kernel over contiguous float64 (N, 3) arrays (N >= 0), continuing from ``state`` / ``istate``.

    ``state`` and ``istate`` (from :func:`new_state` or a previous call) are updated in place, so
    consecutive calls over consecutive pieces of a recording equal one call over all of it. The
    arrays are expected validated (:func:`objectives.attitude.filters.ukf.run_ukf` does it).
    Returns ``quat`` (N, 4) ENU, ``bias`` (N, 3), ``lam`` (N, 3), ``skipped`` and ``fallback`` (N,).
    """
    if state.dtype != np.float64 or istate.dtype != np.int64 or istate.shape != (I.LEN,):
        raise ValueError("state must be float64 and istate int64 (4,), as built by new_state")
    window = int(istate[I.WINDOW])
    if window < 1 or state.shape != (N_STATE_FIXED + 6 * window,):
        raise ValueError(f"state must have shape ({N_STATE_FIXED + 6 * window},) for a window of {window}, "
                         f"got {state.shape}")
    if work is None:
        work = new_work()
    elif work.dtype != np.float64 or work.shape != (WORK_SIZE,):
        raise ValueError(f"work must be a float64 ({WORK_SIZE},) array, got {work.dtype} {work.shape}")
    n = gyr.shape[0]
    out = {"quat": np.empty((n, 4)), "bias": np.empty((n, 3)), "lam": np.empty((n, 3)),
           "skipped": np.zeros(n, dtype=np.bool_), "fallback": np.zeros(n, dtype=np.bool_)}
    _ukf_run(gyr, acc, mag, coef, bool(robust), state, istate, work,
             out["quat"], out["bias"], out["lam"], out["skipped"], out["fallback"])
    return out
