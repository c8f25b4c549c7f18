"""The project's one quaternion library: numba kernels, batch helpers and earth-frame conversions.

Convention: ``q = (w, x, y, z)``, Hamilton product, ``q`` rotates sensor-frame vectors into the
earth frame: ``v_e = q * v_s * conj(q)`` (FAEKF paper section 2, eqs. 1-3, with its sensor-to-earth
reading).

Scalar kernels (``qmul``, ``qconj``, ``qrot``, ...) take and return small arrays and are meant to be
called from other ``@njit`` code; the ``*_batch`` helpers work on ``(N, 4)`` arrays.

Modules
-------
- :mod:`~objectives.attitude.quaternion.algebra`: product, conjugate, rotation of vectors,
  exponential and logarithm maps, sign continuity.
- :mod:`~objectives.attitude.quaternion.conversions`: earth frames (ENU, NED, NWU), rotation
  matrices (eq. 3), ZYX Euler angles (eq. 6) and TRIAD (eqs. 11-14).

Everything is importable from this package; the underscore kernels re-exported here
(``_euler_into``, ``_euler_error_kernel``, ``_triad_into``) are for other ``@njit`` code of the
project.
"""

from objectives.attitude.quaternion.algebra import (
    make_continuous,
    normalize_batch,
    qconj,
    qconj_batch,
    qexp,
    qexp_batch,
    qlog,
    qlog_batch,
    qmul,
    qmul_batch,
    qnormalize,
    qrot,
    qrot_batch,
)
from objectives.attitude.quaternion.conversions import (
    FRAME_CODES,
    Q_ENU_FROM_NWU,
    Q_NED_FROM_ENU,
    _euler_error_kernel,
    _euler_into,
    _triad_into,
    euler_zyx,
    frame_rotation,
    qeuler_zyx,
    quat_from_euler_zyx,
    rotmat,
    rotmat_batch,
    to_frame,
    triad,
    triad_batch,
    triad_code,
)

__all__ = [
    "qmul", "qconj", "qnormalize", "qrot", "qmul_batch", "qconj_batch", "normalize_batch", "qrot_batch",
    "make_continuous", "Q_ENU_FROM_NWU", "Q_NED_FROM_ENU", "frame_rotation", "to_frame",
    "FRAME_CODES", "rotmat", "rotmat_batch", "qexp", "qlog", "qexp_batch", "qlog_batch",
    "qeuler_zyx", "euler_zyx", "quat_from_euler_zyx", "triad", "triad_code", "triad_batch",
    "_euler_into", "_euler_error_kernel", "_triad_into",
]
