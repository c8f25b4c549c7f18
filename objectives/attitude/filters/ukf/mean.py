"""Sigma-point means of the quaternion UKF kernels (eqs. 5, 13-14 of Chiella et al. 2019).

The iterative intrinsic mean and covariance of equally weighted unit quaternions stored one per
column (:func:`_wmean_cov`): its deviation pass is a branch-free loop the compiler turns into vector
code, for the forecast's 18 sigma points by one power series of eq. 1 (``vector``), for the measurement
UT's 12 (padded to 16 columns) with the values of the scalar logarithm. Used by
:mod:`objectives.attitude.filters.ukf.kernel`, which documents the layouts and the profile.
"""

from __future__ import annotations

from numba import njit

from objectives.attitude.filters._scalar import qmul
from objectives.attitude.filters.ukf.scalar import (
    _A1,
    _A2,
    _A3,
    _A4,
    _A5,
    _A6,
    _A7,
    _A8,
    _A9,
    _C1,
    _C2,
    _C3,
    _C4,
    _C5,
    _C6,
    _Q2R_SERIES_N2,
    _S1,
    _S2C,
    _S3,
    _S4,
    _S5,
    _S6,
    _SHORT_N2,
    _qdiff,
    _r2q,
)

_TOL_MEAN = 1e-12
_MAX_MEAN_ITER = 6
_BCH_STEP2 = 1e-16  # (1e-8 rad)^2
_BCH_NEXT2 = 1e-26  # (1e-13 rad)^2


@njit(cache=True, error_model="numpy", inline="always")
def _add_outer(cxx, cxy, cxz, cyy, cyz, czz, dx, dy, dz):
    """The six second-moment sums (xx, xy, xz, yy, yz, zz) plus the outer product of ``(dx, dy, dz)``."""
    return cxx + dx * dx, cxy + dx * dy, cxz + dx * dz, cyy + dy * dy, cyz + dy * dz, czz + dz * dz


@njit(cache=True, error_model="numpy", inline="always")
def _r2q_series(rx, ry, rz):
    """Eq. 2 by its power series only (valid below ``|r|^2 = 0.25``, see ``scalar.py``): no branch, so a
    loop over sigma points vectorises. Returns the quaternion and ``|r|^2`` for the caller's range check."""
    th2 = rx * rx + ry * ry + rz * rz
    y = 0.25 * th2
    c = 1.0 + y * (_C1 + y * (_C2 + y * (_C3 + y * (_C4 + y * (_C5 + y * _C6)))))
    s = 0.5 * (1.0 + y * (_S1 + y * (_S2C + y * (_S3 + y * (_S4 + y * (_S5 + y * _S6))))))
    return c, s * rx, s * ry, s * rz, th2


@njit(cache=True, error_model="numpy", inline="always")
def _dev_column(Y, j, m, r0, r1, r2, r3, D):
    """Column j of :func:`_dev_pass` by the series of eq. 1 into ``D[:, j]`` (``Y`` (4 m,) and ``D`` (3 m,) flat, row
    after row); returns 1 when the column is beyond the series' range, else 0."""
    w, x, y, z = qmul(Y[j], Y[m + j], Y[2 * m + j], Y[3 * m + j], r0, -r1, -r2, -r3)
    n2 = x * x + y * y + z * z
    f = 2.0 * (1.0 + n2 * (_A1 + n2 * (_A2 + n2 * (_A3 + n2 * (_A4 + n2 * (_A5 + n2 * (
        _A6 + n2 * (_A7 + n2 * (_A8 + n2 * _A9)))))))))
    f = f if w >= 0.0 else -f
    D[j], D[m + j], D[2 * m + j] = f * x, f * y, f * z
    return n2 >= _Q2R_SERIES_N2


@njit(cache=True, error_model="numpy", inline="always")
def _dev_column_exact(Y, j, m, r0, r1, r2, r3, D):
    """Column j of :func:`_dev_pass` as the scalar logarithm (``_qdiff``, :func:`~.scalar._q2r`) computes it below
    ``|n|^2 = 0.01``, bit for bit: both of its series evaluated and one selected, without a branch (the choice
    between them is noise near ``|n|^2 = 1e-4``); returns 1 when the column is beyond that range, else 0."""
    w, x, y, z = qmul(Y[j], Y[m + j], Y[2 * m + j], Y[3 * m + j], r0, -r1, -r2, -r3)
    n2 = x * x + y * y + z * z
    fs = 2.0 * (1.0 + n2 * (_A1 + n2 * (_A2 + n2 * (_A3 + n2 * _A4))))
    fl = 2.0 * (1.0 + n2 * (_A1 + n2 * (_A2 + n2 * (_A3 + n2 * (_A4 + n2 * (_A5 + n2 * (
        _A6 + n2 * (_A7 + n2 * (_A8 + n2 * _A9)))))))))
    f = fs if n2 < _SHORT_N2 else fl
    f = -f if w < 0.0 else f
    D[j], D[m + j], D[2 * m + j] = f * x, f * y, f * z
    return not n2 < _Q2R_SERIES_N2  # NaN too: the scalar form decides


@njit(cache=True, error_model="numpy", inline="always")
def _dev_pass(Y, m, mp, r0, r1, r2, r3, D, vector):
    """One pass of the mean: ``D[:, j] = Y[:, j] (-) r`` (eq. 3) for j < m, and the sums of the deviations
    and of their outer products (sx, sy, sz, cxx, cxy, cxz, cyy, cyz, czz).

    ``Y`` (4, mp) and ``D`` (3, mp) hold one sigma point per column (``mp >= m``: the columns from ``m`` on
    are padding, near the mean, so that the loop's count suits the vector width; they are computed and not
    summed), so the loop runs over contiguous
    rows without a branch and vectorises. With ``vector`` the logarithm is the power series of eq. 1 (valid
    for ``|n|^2 < 0.01``, i.e. deviations below 0.2 rad, relative error below 1e-20); without, the values of
    the scalar logarithm (``_qdiff``). A pass with any deviation beyond the series' range is redone with the
    scalar logarithm. The sums are taken afterwards, column after column: a floating-point sum in the column
    loop would keep it scalar (no reassociation without fast-math).
    """
    far = 0
    Yf = Y.reshape(4 * mp)  # flat views: with ``mp`` a compile-time constant the rows' offsets are known
    Df = D.reshape(3 * mp)
    if vector:
        for j in range(mp):
            far += _dev_column(Yf, j, mp, r0, r1, r2, r3, Df)
    else:
        for j in range(mp):
            far += _dev_column_exact(Yf, j, mp, r0, r1, r2, r3, Df)
    if far > 0:
        for j in range(mp):
            D[0, j], D[1, j], D[2, j] = _qdiff(Y[0, j], Y[1, j], Y[2, j], Y[3, j], r0, r1, r2, r3)
    sx = sy = sz = 0.0
    cxx = cxy = cxz = cyy = cyz = czz = 0.0
    for j in range(m):
        dx, dy, dz = D[0, j], D[1, j], D[2, j]
        sx += dx
        sy += dy
        sz += dz
        cxx, cxy, cxz, cyy, cyz, czz = _add_outer(cxx, cxy, cxz, cyy, cyz, czz, dx, dy, dz)
    return sx, sy, sz, cxx, cxy, cxz, cyy, cyz, czz


@njit(error_model="numpy")
def _wmean_cov(Y, m, mp, r0, r1, r2, r3, D, vector):
    """Eqs. 13-14 for equally weighted quaternions Y[:, :m] (one per column; ``Y`` (4, mp), the columns from ``m``
    on padding, see :func:`_dev_pass`): iterative mean from (r0..r3) and covariance.

    D[:, :m] receives the deviations ``Y_j (-) y_hat`` about the returned mean. Returns the mean
    (4 floats) and the covariance's 6 distinct entries (xx, xy, xz, yy, yz, zz).

    The iteration stops when a step is below 1e-12 rad, or when the step ``s`` just taken is below
    1e-8 rad and the next one is predicted below 1e-13 rad (the contraction per step is at most the
    trace of the covariance): the deviations then move to the new mean by the first-order
    Baker-Campbell-Hausdorff form ``D_j - s + s x D_j / 2`` (error O(|s|^2 |D|)) instead of one
    more pass of logarithms.
    """
    w = 1.0 / m
    cxx = cxy = cxz = cyy = cyz = czz = 0.0
    for _ in range(_MAX_MEAN_ITER):
        sx, sy, sz, cxx, cxy, cxz, cyy, cyz, czz = _dev_pass(Y, m, mp, r0, r1, r2, r3, D, vector)
        sx *= w
        sy *= w
        sz *= w
        s2 = sx * sx + sy * sy + sz * sz
        if s2 < _TOL_MEAN * _TOL_MEAN:
            break
        e0, e1, e2, e3 = _r2q(sx, sy, sz)
        r0, r1, r2, r3 = qmul(e0, e1, e2, e3, r0, r1, r2, r3)
        tr = (cxx + cyy + czz) * w
        if s2 < _BCH_STEP2 and s2 * tr * tr < _BCH_NEXT2:
            hx, hy, hz = 0.5 * sx, 0.5 * sy, 0.5 * sz
            cxx = cxy = cxz = cyy = cyz = czz = 0.0
            for j in range(m):
                dx, dy, dz = D[0, j], D[1, j], D[2, j]
                dx, dy, dz = dx - sx + (hy * dz - hz * dy), dy - sy + (hz * dx - hx * dz), dz - sz + (hx * dy - hy * dx)
                D[0, j], D[1, j], D[2, j] = dx, dy, dz
                cxx, cxy, cxz, cyy, cyz, czz = _add_outer(cxx, cxy, cxz, cyy, cyz, czz, dx, dy, dz)
            break
    return r0, r1, r2, r3, cxx * w, cxy * w, cxz * w, cyy * w, cyz * w, czz * w
