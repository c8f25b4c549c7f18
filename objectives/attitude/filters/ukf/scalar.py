"""Scalar building blocks of the quaternion UKF kernels (:mod:`objectives.attitude.filters.ukf.kernel`).

Quaternion maps of Chiella et al. 2019 (eqs. 1-4), the algebraic quaternion of eqs. 22-24, small
fixed-size linear algebra and the sorted-window statistics of the Hampel identifier (eq. 36). Each
helper works on floats or on preallocated arrays, returns tuples and is compiled with
``inline="always"`` so the kernel is compiled as one function with its own flags.

The exponential and logarithm maps use their power series for small angles (eq. 2 below 0.5 rad,
eq. 1 below |n| = sin(th/2) = 0.1, with shorter series below 0.01), truncated where the next term
is below 1e-19 relative, and the trigonometric forms otherwise (atan2 for eq. 1, see
:mod:`objectives.attitude.filters.ukf`).
"""

from __future__ import annotations

import math

from numba import njit

from objectives.attitude.filters._scalar import qmul

_S2 = 1.0 / math.sqrt(2.0)
_SQRT2 = math.sqrt(2.0)


# power series coefficients (Horner, in the squared argument)
# cos(h) and sin(h)/(2h) with y = h^2 = th^2/4: eq. 2 for th < 0.5 rad (next term < 1e-21)
_C1, _C2, _C3, _C4, _C5, _C6 = -1 / 2, 1 / 24, -1 / 720, 1 / 40320, -1 / 3628800, 1 / 479001600
_S1, _S2C, _S3, _S4, _S5, _S6 = -1 / 6, 1 / 120, -1 / 5040, 1 / 362880, -1 / 39916800, 1 / 6227020800
_R2Q_SERIES_TH2 = 0.25
# asin(n)/n = sum c_k n^2k, c_k = (2k)! / (4^k (k!)^2 (2k+1)); eq. 1 for |n| = sin(th/2) < 0.1 (next < 1e-20)
_A = tuple(math.factorial(2 * k) / (4 ** k * math.factorial(k) ** 2 * (2 * k + 1)) for k in range(10))
_A1, _A2, _A3, _A4, _A5, _A6, _A7, _A8, _A9 = _A[1:]
_Q2R_SERIES_N2 = 0.01
_SHORT_TH2 = 1e-4  # shorter series below 0.01 rad (eq. 2) and |n| = 0.01 (eq. 1)
_SHORT_N2 = 1e-4

# ----------------------------------------------------------------------------------------------
# scalar quaternion helpers (tuples: no allocation)
@njit(cache=True, inline="always")
def _r2q(rx, ry, rz):
    """Exponential map, eq. 2: rotation vector (rad) -> unit quaternion."""
    th2 = rx * rx + ry * ry + rz * rz
    y = 0.25 * th2
    if th2 < _SHORT_TH2:  # th < 0.01 rad: the y^4 terms are below 1e-23
        c = 1.0 + y * (_C1 + y * (_C2 + y * _C3))
        s = 0.5 * (1.0 + y * (_S1 + y * (_S2C + y * _S3)))
        return c, s * rx, s * ry, s * rz
    if th2 < _R2Q_SERIES_TH2:
        c = 1.0 + y * (_C1 + y * (_C2 + y * (_C3 + y * (_C4 + y * (_C5 + y * _C6)))))
        s = 0.5 * (1.0 + y * (_S1 + y * (_S2C + y * (_S3 + y * (_S4 + y * (_S5 + y * _S6))))))
        return c, s * rx, s * ry, s * rz
    th = math.sqrt(th2)
    h = 0.5 * th
    s = math.sin(h) / th
    return math.cos(h), s * rx, s * ry, s * rz


@njit(cache=True, inline="always")
def _q2r(w, x, y, z):
    """Logarithm map, eq. 1 (antipodal sign handled): unit quaternion -> rotation vector (rad)."""
    n2 = x * x + y * y + z * z
    if n2 < _SHORT_N2:  # |n| < 0.01: the n^10 term is below 1e-21
        f = 2.0 * (1.0 + n2 * (_A1 + n2 * (_A2 + n2 * (_A3 + n2 * _A4))))
        if w < 0.0:
            f = -f
        return f * x, f * y, f * z
    if n2 < _Q2R_SERIES_N2:
        # 2 asin(|n|)/|n| for a unit quaternion (= 2 atan2(|n|, |w|)/|n| to rounding)
        f = 2.0 * (1.0 + n2 * (_A1 + n2 * (_A2 + n2 * (_A3 + n2 * (_A4 + n2 * (_A5 + n2 * (
            _A6 + n2 * (_A7 + n2 * (_A8 + n2 * _A9)))))))))
        if w < 0.0:
            f = -f
        return f * x, f * y, f * z
    nn = math.sqrt(n2)
    if w >= 0.0:
        f = 2.0 * math.atan2(nn, w) / nn
    else:
        f = -2.0 * math.atan2(nn, -w) / nn
    return f * x, f * y, f * z


@njit(cache=True, inline="always")
def _qdiff(a0, a1, a2, a3, b0, b1, b2, b3):
    """Eq. 3: ``e_a (-) e_b = Q2R(e_a * e_b^*)`` (rad, earth-frame rotation vector)."""
    w, x, y, z = qmul(a0, a1, a2, a3, b0, -b1, -b2, -b3)
    return _q2r(w, x, y, z)


@njit(cache=True, inline="always")
def _acc_quat(ax, ay, az):
    """Eq. 23: the tilt quaternion ``e_acc`` of a unit accelerometer vector (two branches)."""
    if az >= 0.0:
        l1 = math.sqrt(0.5 * (az + 1.0))
        h = 0.5 / l1
        return l1, -ay * h, ax * h, 0.0
    l2 = math.sqrt(0.5 * (1.0 - az))
    h = 0.5 / l2
    return -ay * h, l2, 0.0, ax * h


@njit(cache=True, inline="always")
def _acc_frame(a0, a1, a2, a3):
    """Rows of ``R(e_acc)^T``: ``l = R^T b`` is the field in the tilt-compensated frame (eq. 24)."""
    return (1.0 - 2.0 * (a2 * a2 + a3 * a3), 2.0 * (a1 * a2 + a0 * a3), 2.0 * (a1 * a3 - a0 * a2),
            2.0 * (a1 * a2 - a0 * a3), 1.0 - 2.0 * (a1 * a1 + a3 * a3), 2.0 * (a2 * a3 + a0 * a1))


@njit(cache=True, inline="always")
def _aqua_finish(a0, a1, a2, a3, lx, ly, scale2):
    """Eq. 24 and the composition of eq. 22: ENU quaternion from ``e_acc`` and the field ``(lx, ly)``.

    ``(lx, ly)`` may carry any positive scale (the magnetic quaternion does not depend on it);
    ``scale2`` is its square, used only for the degeneracy test ``Gamma > 1e-12`` of unit vectors.
    Returns (ok, w, x, y, z).
    """
    gam = lx * lx + ly * ly
    if not gam > 1e-12 * scale2:  # field within 1e-6 rad of gravity
        return False, 1.0, 0.0, 0.0, 0.0
    sg = math.sqrt(gam)
    if lx >= 0.0:  # m0 = lam3 / sqrt(2 Gamma), m3 = l_y / (sqrt2 lam3), lam3^2 = Gamma + l_x sqrt(Gamma)
        t = gam + lx * sg
        h = 1.0 / (_SQRT2 * math.sqrt(t) * sg)
        m0, m3 = t * h, ly * sg * h
    else:  # m0 = l_y / (sqrt2 lam4), m3 = lam4 / sqrt(2 Gamma), lam4^2 = Gamma - l_x sqrt(Gamma)
        t = gam - lx * sg
        h = 1.0 / (_SQRT2 * math.sqrt(t) * sg)
        m0, m3 = ly * sg * h, t * h
    # c = e_acc * e_mag with e_mag = (m0, 0, 0, m3)
    c0 = a0 * m0 - a3 * m3
    c1 = a1 * m0 + a2 * m3
    c2 = a2 * m0 - a1 * m3
    c3 = a0 * m3 + a3 * m0
    # e_m = conj(c) in NWU; ENU = Q_ENU_FROM_NWU * e_m, Q = (S2, 0, 0, S2)
    return True, _S2 * (c0 + c3), _S2 * (c2 - c1), _S2 * (-c1 - c2), _S2 * (c0 - c3)


@njit(cache=True, inline="always")
def _aqua_enu(ax, ay, az, bx, by, bz):
    """Eqs. 22-24: sensor-to-earth quaternion (ENU) from unit acc and mag vectors.

    Returns (ok, w, x, y, z); ``ok`` is False where Gamma = 0 (field parallel to gravity).
    """
    a0, a1, a2, a3 = _acc_quat(ax, ay, az)
    r00, r01, r02, r10, r11, r12 = _acc_frame(a0, a1, a2, a3)
    return _aqua_finish(a0, a1, a2, a3, r00 * bx + r01 * by + r02 * bz, r10 * bx + r11 * by + r12 * bz, 1.0)


# ----------------------------------------------------------------------------------------------
# small linear algebra on preallocated arrays
@njit(cache=True, inline="always")
def _chol(A, L, n, rdiag):
    """Lower Cholesky factor of A[:n, :n] into L (upper part zeroed); False if A is not positive definite.

    ``rdiag`` (n,) receives the reciprocals of the diagonal of L: one division per column instead of
    one per entry below the diagonal.
    """
    for i in range(n):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if not s > 0.0:
                    return False
                d = math.sqrt(s)
                L[i, i] = d
                rdiag[i] = 1.0 / d
            else:
                L[i, j] = s * rdiag[j]
        for j in range(i + 1, n):
            L[i, j] = 0.0
    return True


@njit(cache=True, inline="always")
def _inv3_spd(A, Ainv):
    """Inverse of a 3x3 symmetric positive definite matrix through its Cholesky factor; False if not SPD."""
    d0 = A[0, 0]
    if not d0 > 0.0:
        return False
    l00 = math.sqrt(d0)
    l10 = A[1, 0] / l00
    l20 = A[2, 0] / l00
    d1 = A[1, 1] - l10 * l10
    if not d1 > 0.0:
        return False
    l11 = math.sqrt(d1)
    l21 = (A[2, 1] - l20 * l10) / l11
    d2 = A[2, 2] - l20 * l20 - l21 * l21
    if not d2 > 0.0:
        return False
    l22 = math.sqrt(d2)
    i00 = 1.0 / l00
    i11 = 1.0 / l11
    i22 = 1.0 / l22
    i10 = -l10 * i00 * i11
    i21 = -l21 * i11 * i22
    i20 = -(l20 * i00 + l21 * i10) * i22
    # A^-1 = Linv^T Linv
    Ainv[0, 0] = i00 * i00 + i10 * i10 + i20 * i20
    Ainv[0, 1] = Ainv[1, 0] = i10 * i11 + i20 * i21
    Ainv[0, 2] = Ainv[2, 0] = i20 * i22
    Ainv[1, 1] = i11 * i11 + i21 * i21
    Ainv[1, 2] = Ainv[2, 1] = i21 * i22
    Ainv[2, 2] = i22 * i22
    return True


@njit(cache=True, inline="always")
def _is_pd3(A):
    """True if the symmetric 3x3 ``A`` has a Cholesky factor (all pivots positive)."""
    d0 = A[0, 0]
    if not d0 > 0.0:
        return False
    l10 = A[1, 0] / math.sqrt(d0)
    l20 = A[2, 0] / math.sqrt(d0)
    d1 = A[1, 1] - l10 * l10
    if not d1 > 0.0:
        return False
    l21 = (A[2, 1] - l20 * l10) / math.sqrt(d1)
    return A[2, 2] - l20 * l20 - l21 * l21 > 0.0


@njit(cache=True, inline="always")
def _count_below(S, n, x, inclusive):
    """Number of ``S[:n]`` below ``x`` (``<=`` with ``inclusive``); a branch-free scan (no data-dependent jumps)."""
    c = 0
    if inclusive:
        for i in range(n):
            c += S[i] <= x
    else:
        for i in range(n):
            c += S[i] < x
    return c


@njit(cache=True, inline="always")
def _sorted_update(S, n, full, old, new):
    """Keep ``S[:n]`` sorted: remove one ``old`` (when ``full``), insert ``new``; returns the new length.

    The removal index (the first ``old``) and the insertion index (after every value ``<= new``) are
    counted by branch-free scans, then only the entries between them move by one place. The result is
    the same array as a removal by bisection followed by an insertion scan, without their data-dependent
    branches (innovations are noise: their order is unpredictable, each mispredicted jump costs more
    than the whole scan).
    """
    p = _count_below(S, n, new, True)
    if full:
        r = _count_below(S, n, old, False)
        if old <= new:
            p -= 1  # ``old`` was counted and leaves
        if p >= r:
            for i in range(r, p):
                S[i] = S[i + 1]
        else:
            for i in range(r, p, -1):
                S[i] = S[i - 1]
        S[p] = new
        return n
    for i in range(n, p, -1):
        S[i] = S[i - 1]
    S[p] = new
    return n + 1


@njit(cache=True, inline="always")
def _median_sorted(S, n):
    """Median of the sorted ``S[:n]`` (mean of the two middle values for even ``n``)."""
    h = n // 2
    if n % 2 == 1:
        return S[h]
    return 0.5 * (S[h - 1] + S[h])


@njit(cache=True, inline="always")
def _mad_sorted(S, n, med):
    """Median of ``|S[:n] - med|`` for sorted ``S`` by merging the two monotone halves (no sort).

    The merge takes ``n // 2 + 1`` steps with selects instead of branches (an exhausted side reads as
    ``inf``); the values are exactly those of ``abs(S - med)``.
    """
    lo = _count_below(S, n, med, False)  # first index with S >= med
    i, j = lo - 1, lo  # left walks down, right walks up
    h = n // 2
    prev = cur = 0.0
    for _ in range(h + 1):
        prev = cur
        dl = med - S[max(i, 0)] if i >= 0 else math.inf
        dr = S[min(j, n - 1)] - med if j < n else math.inf
        left = dl <= dr
        cur = dl if left else dr
        i -= 1 if left else 0
        j += 0 if left else 1
    if n % 2 == 1:
        return cur
    return 0.5 * (prev + cur)


@njit(cache=True, inline="always")
def _store_sym3(M, cxx, cxy, cxz, cyy, cyz, czz):
    """Write a symmetric 3x3 block, given by its upper triangle, into ``M[:3, :3]``."""
    M[0, 0], M[1, 1], M[2, 2] = cxx, cyy, czz
    M[0, 1] = M[1, 0] = cxy
    M[0, 2] = M[2, 0] = cxz
    M[1, 2] = M[2, 1] = cyz
