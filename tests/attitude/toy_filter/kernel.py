"""The toy filter's numba kernel and its layouts: strapdown integration of the gyro with a proportional
correction towards the accelerometer (Mahony's filter without magnetometer and integral, ENU):

    v = R(q)^T (0, 0, 1)                 predicted up in the sensor frame
    w = gyr + gain (a x v)               a: the unit accelerometer
    q <- normalise(q + dt/2 q (x) (0, w))            (step "euler"; "half": two half steps)

Its numba functions are not cached: the package's cache locators (rule 3 of :mod:`objectives.jit`) key entries
on ``objectives/`` only, and a test's kernel compiles in a fraction of a second.
"""

from __future__ import annotations

import math

from numba import njit

from objectives.attitude.filters.layout import Layout

#: the coefficients and the state, declared once (the C port's enums and sizes come from them)
C = Layout("C", (("DT", 1, "sample time, s"), ("GAIN", 1, "correction gain, 1/s"),
                 ("HALF", 1, "1: two half steps per sample, 0: one Euler step")))
X = Layout("X", (("Q", 4, "sensor-to-earth quaternion, ENU"),))


@njit(inline="always")
def _step(q0, q1, q2, q3, wx, wy, wz, h):
    """``q + h q (x) (0, w)``, normalised."""
    n0 = q0 + h * (-q1 * wx - q2 * wy - q3 * wz)
    n1 = q1 + h * (q0 * wx + q2 * wz - q3 * wy)
    n2 = q2 + h * (q0 * wy - q1 * wz + q3 * wx)
    n3 = q3 + h * (q0 * wz + q1 * wy - q2 * wx)
    r = 1.0 / math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    return n0 * r, n1 * r, n2 * r, n3 * r


@njit
def toy_kernel(gyr, acc, coef, state, out):
    """The filter over whole arrays: gyr (N, 3) rad/s, acc (N, 3) any unit, coef (C.LEN,), state (X.LEN,) read and
    written, out (N, 4) the quaternion after each sample."""
    dt, gain, half = coef[C.DT], coef[C.GAIN], coef[C.HALF] != 0.0
    q0, q1, q2, q3 = state[X.Q], state[X.Q + 1], state[X.Q + 2], state[X.Q + 3]
    for i in range(gyr.shape[0]):
        wx, wy, wz = gyr[i, 0], gyr[i, 1], gyr[i, 2]
        ax, ay, az = acc[i, 0], acc[i, 1], acc[i, 2]
        an = math.sqrt(ax * ax + ay * ay + az * az)
        if an > 0.0:
            ax, ay, az = ax / an, ay / an, az / an
            vx = 2.0 * (q1 * q3 - q0 * q2)
            vy = 2.0 * (q0 * q1 + q2 * q3)
            vz = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
            wx += gain * (ay * vz - az * vy)
            wy += gain * (az * vx - ax * vz)
            wz += gain * (ax * vy - ay * vx)
        if half:
            q0, q1, q2, q3 = _step(q0, q1, q2, q3, wx, wy, wz, 0.25 * dt)
            q0, q1, q2, q3 = _step(q0, q1, q2, q3, wx, wy, wz, 0.25 * dt)
        else:
            q0, q1, q2, q3 = _step(q0, q1, q2, q3, wx, wy, wz, 0.5 * dt)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = q0, q1, q2, q3
    state[X.Q], state[X.Q + 1], state[X.Q + 2], state[X.Q + 3] = q0, q1, q2, q3
