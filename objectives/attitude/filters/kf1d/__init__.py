"""1-D tilt filters of the thesis (Odry 2020, section 3.1): KF, fuzzy-adaptive KF, Mahony and Madgwick.

All four estimate the tilt angle ``theta`` about the sensor **y** axis from the rate ``gyr[:, 1]`` and
the accelerometer's x and z components (the tilt bench of thesis 3.1.2, :func:`tilt1d` of
``objectives.attitude.data.synthetic``). The output quaternion is the rotation about y by the
estimate, ``(cos(theta/2), 0, sin(theta/2), 0)`` in the recording's frame; ``diagnostics["angle"]``
holds ``theta`` (N,) rad.

Angle convention
----------------
``theta`` is the rotation about the sensor y axis that takes the sensor frame to the recording's
earth frame (the truth ``rec.extra["angle"]`` of the tilt bench). The accelerometer realisation of
eq. 3.6 in our axes is ``theta_A = atan2(-s ax, s az)`` with ``s = +1`` in z-up frames (ENU) and
``s = -1`` in NED (the specific force points up). The initial angle comes from the common initial
quaternion (``q0``: first accelerometer sample by default, ``"truth"``, or explicit) through the
sensor's up vector, so it does not depend on heading.

KF1D (thesis eqs. 3.9-3.13, 3.17)
---------------------------------
State ``x = (theta, omega_0)`` (angle, gyro bias), input ``u = Omega = gyr[:, 1]``::

    x_k^- = Phi x_{k-1} + Gamma u_{k-1},  Phi = [[1, -Ts], [0, 1]],  Gamma = [Ts, 0]^T      (3.9, 3.11)
    P_k^- = Phi P_{k-1} Phi^T + Q,  Q = diag(q00, q11)                                        (3.11, 3.17)
    G_k = P_k^- H^T (H P_k^- H^T + R)^-1,  H = [1, 0],  R = rho                               (3.12, 3.17)
    x_k = x_k^- + G_k (theta_A,k - H x_k^-),  P_k = (I - G_k H) P_k^-                          (3.13)

Sample ``k`` is propagated with gyro sample ``k - 1`` (the rate held over ``[t_{k-1}, t_k]``) and
corrected with accelerometer sample ``k``; sample 0 is the initial state ``(theta_0, 0)``, ``P_0``
(thesis: ``0_2x2``). The residual is wrapped to ``(-pi, pi]``.

Units and rate: ``q00``, ``q11``, ``rho`` are per-sample variances as in the thesis (800 Hz; the
thesis states them in degree units). With ``P_0 = 0`` the gain depends only on the ratios of Q and R,
so the same numbers give the same estimate whether angles are in degrees or radians; with a nonzero
``P_0`` (options ``p0_theta``, ``p0_bias``), all five are in rad^2 (and (rad/s)^2) units.

AKF1D (thesis 3.1.4, eqs. 3.19-3.24, Table 3.2)
-----------------------------------------------
``R_k = K_k rho`` where ``K_k`` is a zero-order Sugeno system (min-AND, weighted average, eq. 3.24)
of the vibration frequency ``f_hat`` (Hz, eqs. 3.19-3.21 on ``gyr[:, 1]``) and the average external
acceleration ``alpha_hat`` (g, eq. 3.22), each covered by Z, S, B sets, with the 9 rules of Table 3.2
(``K_{1 + i_f + i_a}``). Both measures come from :mod:`objectives.attitude.disturbance` (packets of
``window`` samples, causal hold). Deviations / documented choices (Fig. 3.9 is missing from the text):

- the sets: "one triangular and two trapezoidal" per input over the ranges the thesis gives (f up to
  6.5 Hz, alpha up to 0.35 g): ``Z = trap(-inf, -inf, 0, r/2)``, ``S = tri(0, r/2, r)``,
  ``B = trap(r/2, r, inf, inf)`` with ``r = f_range_hz`` or ``acc_range_g`` (a uniform partition);
- the singletons ``K1..K5`` (not in the text, "chosen intuitively via iterative tuning"): default
  ``(1, 3, 10, 30, 100)``, half-decade steps so that the biggest disturbance makes the accelerometer
  100 times less trusted; all are options that can be searched;
- ``omega_thr`` default 10 deg/s = 0.1745 rad/s and ``f_thr`` 8 Hz (thesis values; the FAEKF paper
  uses 0.26 rad/s and the FAEKF config 10 Hz).

Mahony1D and Madgwick1D (thesis 3.1.5, Tables 3.4-3.5)
-------------------------------------------------------
The thesis runs Madgwick's sample code (MahonyAHRSupdateIMU, MadgwickAHRSupdateIMU) on the bench
data. On the tilt bench the attitude is a rotation about y only, so the quaternion stays
``(q0, 0, q2, 0)``; these classes run exactly that code restricted to ``(q0, q2)``, with ``ay`` and the
x/z rates dropped (they carry only noise on the bench) and the accelerometer normalised over
``(ax, az)``. Mahony: ``e = a x v`` (= ``sin(theta_A - theta)``), ``I += Ki e Ts`` (only when
``Ki > 0``, else ``I = 0``), ``omega = Omega + Kp e + I``. Madgwick: the normalised gradient step
``s = J^T f / |J^T f|``, ``q_dot = q (x) omega / 2 - beta s``. As in the sample code, call ``k`` uses
gyro and accelerometer sample ``k`` to go from ``t_k`` to ``t_{k+1}``; the output at sample ``k`` is the
state after call ``k - 1`` (sample 0 is the initial state).

Integration (option ``exact_step``): ``True`` (default) rotates ``(q0, q2)`` by the exact angle
``omega Ts`` (the rate is held constant over the sample, as the synthetic benches define it);
``False`` is the sample code's first-order step ``q += q_dot Ts`` then normalisation. They differ by
``(omega Ts)^3 / 12`` rad per sample (4e-7 rad at 800 deg/s and 800 Hz). Madgwick's normalised step
has magnitude ``beta`` whenever the gradient is not exactly zero, so even on perfect data its error
chatters at the level ``beta Ts``.

The unit: ``kf.py`` (KF1D, AKF1D and their C ports), ``sample_code.py`` (Mahony1D, Madgwick1D), ``tilt.py``
(the angle convention, inputs and stream they share), ``kernel.py`` (the numba kernels and their layouts),
``population.py`` (the tilt KF's population kernel), ``port.c`` (the C port of the KF and the AKF).
"""

from objectives.attitude.filters.kf1d.kernel import kf1d_kernel, madgwick1d_kernel, mahony1d_kernel
from objectives.attitude.filters.kf1d.kf import AKF1D, KF1D, akf1d_fis
from objectives.attitude.filters.kf1d.sample_code import Madgwick1D, Mahony1D
from objectives.attitude.filters.kf1d.tilt import quat_from_tilt, tilt_from_quat

__all__ = ["KF1D", "AKF1D", "Mahony1D", "Madgwick1D", "kf1d_kernel", "mahony1d_kernel",
           "madgwick1d_kernel", "tilt_from_quat", "quat_from_tilt", "akf1d_fis"]
