"""A toy filter unit, defined in the test suite only: a class with its declaration, a kernel with its layouts, a
tiny C port and a population kernel, in one package like the units of ``objectives/attitude/filters/``.
Registering it (``register_filter("toy", "tests.attitude.toy_filter:Toy")``) is all it takes for the objective,
the C export and its check against the kernel, and the population batch to run it
(``tests/attitude/test_filter_units.py``)."""

from __future__ import annotations

import numpy as np

from objectives.attitude.cexport.port import CMember, CPort
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.params import POSITIVE, Param, ParamSet
from tests.attitude.toy_filter.kernel import C, X, toy_kernel
from tests.attitude.toy_filter.population import POPULATION

DECL = ParamSet("toy", (
    Param("gain", 1.0, (0.01, 10.0), "log", "1/s", "correction gain towards the accelerometer", "", POSITIVE),
    Param("step", "euler", choices=("euler", "half"), doc="one Euler step per sample or two half steps"),
))


class Toy(AttitudeFilter):
    """The toy filter (:mod:`tests.attitude.toy_filter.kernel`), ENU, without magnetometer."""

    name = "toy"
    working_frame = "ENU"
    decl = DECL
    population = POPULATION
    c_port = CPort((__package__, "port.c"), (), (
        CMember("real", "q", (X.LEN,), "sensor-to-earth quaternion, ENU"),
        CMember("int", "started"),
        CMember("params", "p")), layouts=(X,))

    def kernel_setup(self, dt, use_mag, q0, frame, g_ref=G_SI) -> KernelSetup:
        v = self.values
        return KernelSetup(C.pack(DT=dt, GAIN=v["gain"], HALF=1.0 if v["step"] == "half" else 0.0), X.pack(Q=q0))

    def _run(self, rec, q0) -> FilterResult:
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        out = np.empty((rec.n, 4))
        toy_kernel(np.ascontiguousarray(rec.gyr, dtype=float), np.ascontiguousarray(rec.acc, dtype=float),
                   setup.coef, setup.state, out)
        return FilterResult(out, self.working_frame)
