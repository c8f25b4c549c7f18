"""Pendulum on a cart (frictionless), for configs/examples/cartpole_lqr.yaml.

State x = (cart position p m, cart speed dp m/s, pendulum angle th rad from upright, dth rad/s),
input u = (force on the cart N,). Point mass m on a massless rod of length l, cart mass M:
    (M + m) ddp + m l (ddth cos th - dth^2 sin th) = u
    l ddth + ddp cos th - g sin th = 0
"""

import math

import numpy as np


def dynamics(x, u, t, params):
    dp, th, dth = x[1], x[2], x[3]  # x[0], the position, does not enter the dynamics
    s, c = math.sin(th), math.cos(th)
    m, big_m, l, g = params.m, params.M, params.l, params.g
    den = big_m + m * s * s
    ddp = (u[0] + m * s * (l * dth * dth - g * c)) / den
    ddth = (-u[0] * c - m * l * dth * dth * s * c + (big_m + m) * g * s) / (l * den)
    out = np.empty(4)
    out[0] = dp
    out[1] = ddp
    out[2] = dth
    out[3] = ddth
    return out
