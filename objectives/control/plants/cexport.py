"""The tuned controller of the generic loop as C99: ``tuner export RUN --format c-controller`` (``c-source``).

What leaves the tool is what the tuning scored: the controller's step of :mod:`.kernels` (``_control``: one
PID block, two cascaded blocks, or the state feedback) followed by the actuator the loop applied
(``_actuate``: saturation, rate limit, quantum), operation for operation in the same order, so the compiled C
closes the loop on the same trajectory (:func:`c_trace`, checked to 1e-9 in double by the tests and by
``tuner verify-c``). The measurement noise, the sensor quantum, the load and the input delay belong to the
plant and its sensor, not to the controller: they are not in the C.

- ``PFX_params`` is generated from the controller's declaration (:func:`objectives.csource.decl_fields`: every
  declared value, a choice an ``int`` with its enum), led by the period and followed by the actuator; a PID
  family's ``PFX_init`` makes each block's discrete coefficients from the declared values in C (the
  expressions of the class's ``C_BLOCKS``: ideal form and limits), so a gain changed in the struct is a
  controller retuned; the state feedback carries its designed gain ``K`` and pre-filter ``Nbar`` (the
  Riccati solution of the tuned ``Q``, ``R``, which are in the header's comment);
- the state (``PFX_controller``): each block's ``I``, ``D``, previous ``c r - y`` and start flag, and the last
  actuator command (rate limit); no heap, no global state.

The PID equations are Åström & Murray, Feedback Systems (2nd ed., section 11.5), as :mod:`.controllers`
discretises them.
"""

from __future__ import annotations

import ctypes
import math
import re
import shlex
import tempfile
import time
from importlib import resources
from typing import Any

import numpy as np

from objectives.control.kinds import KIND_CASCADE, KIND_PID, KIND_SF
from objectives.csource import CField, c_identifier, c_literal, choice_enum, decl_fields

__all__ = ["DOUBLE_TOL", "render_c_controller", "c_controller_names", "CController", "c_trace", "export_c_controller",
           "verify_c_controller"]

_PID_KINDS = (KIND_PID, KIND_CASCADE)
#: how far (relative to the largest |signal|, at least 1) the C's closed loop may leave the kernel's in double
DOUBLE_TOL = 1e-9
#: the design weights of a state feedback: in the comment, not in ``PFX_params`` (K and Nbar are)
_DESIGN = re.compile(r"[qr]\d+")


def c_controller_names() -> list[str]:
    """The registered controllers with a C port (the generic loop's PID family and state feedback)."""
    from objectives.control.controllers import controllers_of

    return sorted(n for n, c in controllers_of("siso").items() if c.kind in (*_PID_KINDS, KIND_SF))


def _check_port(ctrl: Any) -> None:
    if getattr(ctrl, "family", None) != "siso" or ctrl.kind not in (*_PID_KINDS, KIND_SF):
        raise ValueError(f"objective.controller: {ctrl.name!r} has no C port; the controllers with one: "
                         f"{', '.join(c_controller_names())}")


def _template(name: str) -> str:
    return resources.files(__package__).joinpath("ctemplates", name).read_text()


def _fields(ctrl: Any, values: dict[str, Any], plant: Any) -> tuple[list[CField], list[str]]:
    """The ``PFX_params`` members of the declaration (the state feedback's gain and pre-filter instead of its
    design weights) and the enums of its choices."""
    decl = ctrl.declaration_for(plant)
    skip = [p.name for p in decl.params if _DESIGN.fullmatch(p.name)] if ctrl.kind == KIND_SF else []
    fields = decl_fields(decl, values, skip)
    if ctrl.kind == KIND_SF:
        k, nbar = ctrl.gains(ctrl.coeffs(values, plant))
        m, n = k.shape
        fields = [CField("real", f"K[{m}][{n}]", k.tolist(), "state feedback gain u = -K x + Nbar r (dlqr of Q, R)"),
                  CField("real", f"Nbar[{m}]", nbar.tolist(), "reference pre-filter: the output's steady state is r"),
                  *fields]
    enums = []
    for p in decl.params:
        if p.choices and p.name not in skip:
            items = ", ".join(f"PFX_{n} = {i}" for n, i in choice_enum(p.name, p.choices))
            enums.append(f"enum {{ {items} }}; /* {p.name} */")
    return fields, enums


def _control_code(ctrl: Any) -> tuple[str, str]:
    """``PFX_init``'s coefficient lines and ``PFX_update``'s controller lines (before the actuator)."""
    if ctrl.kind == KIND_SF:
        return "    (void)0; /* K and Nbar are the design's */", "\n".join([
            "    for (i = 0; i < PFX_N_U; ++i) {",
            "        PFX_real acc = p->Nbar[i] * r;",
            "        int j;",
            "        for (j = 0; j < PFX_N_MEAS; ++j)",
            "            acc -= p->K[i][j] * meas[j];",
            "        u[i] = clip(acc, p->u_min, p->u_max);",
            "    }"])
    init = [f"    pid_coeffs(&c->blk[{i}], {', '.join(b)}, p);" for i, b in enumerate(ctrl.C_BLOCKS)]
    if len(ctrl.C_BLOCKS) == 1:
        return "\n".join(init), "    u[0] = pid_step(&c->blk[0], &c->st[0], r, meas[PFX_OUTPUT]);"
    return "\n".join(init), "\n".join([  # the outer block's output is the inner block's reference
        "    {",
        "        PFX_real r_inner = pid_step(&c->blk[0], &c->st[0], r, meas[PFX_OUTPUT]);",
        "        u[0] = pid_step(&c->blk[1], &c->st[1], r_inner, meas[PFX_INNER_OUTPUT]);",
        "    }"])


def _usage(ctrl: Any, plant: Any, prefix: str, precision: str, period_s: float) -> str:
    meas = "states x" if ctrl.kind == KIND_SF else "outputs y"
    p = prefix
    return "\n".join([
        f"{ctrl.name} controller, C99, {precision} precision, generated by tuner from a tuning run.",
        "",
        f"Call {p}_update once per period ({period_s:g} s): the reference r and the plant's measured {meas}",
        f"(meas[{p}_N_MEAS]) in, the actuator commands u[{p}_N_U] out, after the actuator the loop was tuned",
        "with (saturation, rate limit, quantum: act_* in the params; set them to what your hardware does not do",
        "itself). No heap, no global state: one struct per controller. libm: sqrt, floor.",
        "",
        "    #include \"" + prefix.lower() + ".h\"",
        f"    {p}_controller c;",
        f"    {p}_init(&c, &{p}_tuned);        (or a {p}_params of your own)",
        "    for (;;) {                        (once per period)",
        f"        {p}_update(&c, r, meas, u);",
        "    }",
    ])


def render_c_controller(ctrl: Any, values: dict[str, Any], plant: Any, real: Any, *, precision: str = "double",
                        prefix: str = "CTL", comment: str = "") -> dict[str, str]:
    """``{"<prefix>.h": ..., "<prefix>.c": ...}`` of the controller class ``ctrl`` with ``values`` baked into
    ``PREFIX_tuned`` for ``plant`` (its period, sizes and output indices) and the actuator ``real``
    (:class:`~.scenario.Realism`). ValueError for a controller without a C port, a bad precision or prefix."""
    _check_port(ctrl)
    if precision not in ("double", "float"):
        raise ValueError(f"c-controller: precision must be 'double' or 'float', got {precision!r}")
    pfx = c_identifier(prefix)
    base = pfx.lower()
    fields, enums = _fields(ctrl, values, plant)
    period = float(plant.period_s)
    act = [CField("real", "act_u_min", real.u_min, ""), CField("real", "act_u_max", real.u_max, ""),
           CField("real", "act_rate_limit", real.rate_limit, ""), CField("real", "act_quantum", real.u_quantum, "")]
    n_meas = plant.n_states if ctrl.kind == KIND_SF else plant.n_outputs
    params = "\n".join(f"    {'PFX_real' if f.ctype == 'real' else 'int'} {f.name}; /* {f.doc} */" for f in fields)
    header = _template("controller.h")
    for key, val in (("@REAL@", precision), ("@N_MEAS@", str(n_meas)), ("@N_U@", str(plant.n_inputs)),
                     ("@OUTPUT@", str(plant.output)), ("@INNER@", str(max(plant.inner_output, 0))),
                     ("@N_BLOCKS@", str(len(ctrl.C_BLOCKS) if ctrl.kind != KIND_SF else 0)),
                     ("@MEAS_DOC@", "the plant's states x" if ctrl.kind == KIND_SF else "the plant's outputs y"),
                     ("@PARAMS@", params),
                     ("@ENUMS@\n", "".join(e + "\n" for e in enums))):
        header = header.replace(key, val)
    text = _usage(ctrl, plant, pfx, precision, period)
    text += "\n\nConfiguration (every value of the deployed controller):\n"
    text += "\n".join(f"  {k}: {v!r}" for k, v in values.items())
    text += (f"\nActuator: u in [{real.u_min!r}, {real.u_max!r}], rate limit {real.rate_limit!r} u/s, "
             f"quantum {real.u_quantum!r}")
    if comment:
        text += "\n\n" + comment
    text = text.replace("/*", "/ *").replace("*/", "* /")  # nothing in it may end the comment
    header = "/*\n" + "\n".join((" * " + line).rstrip() for line in text.splitlines()) + "\n */\n" + header
    tuned = [CField("real", "period_s", period, ""), *fields, *act]
    init_vals = ",\n".join(f"    .{f.name.split('[')[0]} = {c_literal(f.value, f.ctype)}" for f in tuned)
    init, control = _control_code(ctrl)
    api = _template("api.c").replace("@INIT@", init).replace("@CONTROL@", control)
    source = "\n".join([
        f"/* {ctrl.name} controller, {precision} precision; see {base}.h. Generated: edit the tuning, not this "
        "file. */",
        "#include <math.h>", f'#include "{base}.h"', "",
        f"const PFX_params PFX_tuned = {{\n{init_vals}\n}};",
        _template("sf.c" if ctrl.kind == KIND_SF else "pid.c") + api])
    return {f"{base}.h": header.replace("PFX", pfx), f"{base}.c": source.replace("PFX", pfx)}


class CController:
    """A compiled controller (``lib``, from :func:`render_c_controller`'s files): ``update(r, meas) -> u``."""

    def __init__(self, lib: Any, prefix: str, precision: str = "double") -> None:
        self._lib = ctypes.CDLL(str(lib))
        self.dtype = np.float64 if precision == "double" else np.float32
        self._real = ctypes.c_double if precision == "double" else ctypes.c_float
        size = getattr(self._lib, f"{prefix}_controller_size")
        size.restype = ctypes.c_size_t
        self._state = ctypes.create_string_buffer(int(size()))
        self._init = getattr(self._lib, f"{prefix}_init")
        self._update = getattr(self._lib, f"{prefix}_update")
        self._init.restype = self._update.restype = None
        self._tuned = ctypes.c_void_p.in_dll(self._lib, f"{prefix}_tuned")
        self._ptr = ctypes.POINTER(self._real)

    def init(self) -> None:
        """``PREFIX_init`` with the tuned values (the state zeroed)."""
        self._init(self._state, ctypes.cast(ctypes.addressof(self._tuned), ctypes.c_void_p))

    def update(self, r: float, meas: np.ndarray, u: np.ndarray) -> None:
        """One period: ``u`` (the library's precision, contiguous) is written."""
        m = np.ascontiguousarray(meas, dtype=self.dtype)
        self._update(self._state, self._real(r), m.ctypes.data_as(self._ptr), u.ctypes.data_as(self._ptr))


def c_trace(plant: Any, sig: np.ndarray, opt: np.ndarray, ctl: CController) -> dict[str, Any]:
    """The closed loop of ``plant`` with the compiled controller ``ctl`` in place of the kernel's controller
    and actuator: the period of :func:`.kernels._loop_lti` / ``_loop_nl`` step by step (measure, C update,
    load, input delay, advance with the kernels' own functions); the record of :meth:`.batch.ItemRunner.trace`."""
    from objectives.control.plants.kernels import STATUS_DIVERGED, STATUS_OK, _affine, _diverged, _measure

    sig = np.ascontiguousarray(sig, dtype=float)
    n_steps, h = sig.shape[0], float(plant.period_s)
    n, m, p = plant.n_states, plant.n_inputs, plant.n_outputs
    sf, delay, div = int(opt[0]) == KIND_SF, int(opt[1]), float(opt[9])
    y_out, u_out, x_out = np.zeros((n_steps, p)), np.zeros((n_steps, m)), np.zeros((n_steps, n))
    x = np.array(plant.x0, dtype=float)
    y, meas = np.empty(p), np.empty(n if sf else p)
    u_c = np.zeros(m, dtype=ctl.dtype)
    line, u_applied = np.zeros((delay + 1, m)), np.zeros(m)
    linear = plant.linear
    if not linear:
        plant.reset()
        _, step = plant.stepper()
        outputs = np.asarray(plant.outputs)
    ctl.init()
    status, done = STATUS_OK, n_steps
    for k in range(n_steps):
        if linear:
            _affine(plant.Cd, x, plant.Dd, u_applied, y)
        else:
            y[:] = x[outputs]
        y_out[k], x_out[k] = y, x
        _measure(x if sf else y, sig[k, 2:], opt[8], meas)
        ctl.update(sig[k, 0], meas, u_c)
        u = u_c.astype(float)
        u_out[k] = u
        u[0] += sig[k, 1]
        line[k % (delay + 1)] = u
        u_applied = line[(k + 1) % (delay + 1)].copy() if delay > 0 else u
        if delay > 0 and k < delay:
            u_applied[:] = 0.0
        if linear:
            xn = np.empty(n)
            _affine(plant.Ad, x, plant.Bd, u_applied, xn)
        else:
            xn = np.asarray(step(plant.fn, x, u_applied.copy(), k * h, plant.params, h / plant.n_sub, plant.n_sub))
        if _diverged(xn, div):
            status, done = STATUS_DIVERGED, k + 1
            break
        x = xn
    return {"t": np.arange(n_steps) * h, "y": y_out, "u": u_out, "x": x_out, "status": int(status),
            "n_done": int(done)}


def export_c_controller(loop: Any, values: dict[str, Any], precision: str, prefix: str,
                        comment: str) -> dict[str, str]:
    """The export hook's files for the loop's controller with ``values`` (every declared value)."""
    return render_c_controller(loop.ctrl, values, loop.plant, loop.realism, precision=precision, prefix=prefix,
                               comment=comment)


def verify_c_controller(loop: Any, values: dict[str, Any], precision: str = "double",
                        opt: tuple[str, ...] = ("-O2",)) -> dict[str, Any]:
    """The controller's C compiled, its loop closed on the nominal plant in every scenario, scored with the
    loop's own metrics next to the kernel's loop: ``{"python": Score, "c": Score, "precision", "flags",
    "compiler", "max_abs_diff": {scenario: largest |difference| of states, outputs and commands}, "agrees":
    whether each is within :data:`DOUBLE_TOL` of the scenario's largest |signal| (at least 1) in double (None
    in float), "seconds"}``; a :class:`~objectives.csource.CompileError` when the compiler is missing or fails."""
    from objectives.control.plants.metrics import _item_stats
    from objectives.control.plants.modelset import ModelSet
    from objectives.csource import CompileError, compile_shared, find_compiler
    from tuner.objective import Score

    cc = find_compiler()
    if cc is None:
        raise CompileError("no C compiler found (set CC, or install cc, gcc or clang)")
    files = render_c_controller(loop.ctrl, values, loop.plant, loop.realism, precision=precision, prefix="TVC")
    runner = loop.runner(ModelSet("nominal", [loop.plant], ["nominal"]))
    cp = loop.ctrl.coeffs(values, loop.plant)
    stats = {"python": np.zeros((1, len(loop.cases), runner.row)), "c": np.zeros((1, len(loop.cases), runner.row))}
    seconds, diff, scale = {"python": 0.0, "c": 0.0}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        ctl = CController(compile_shared(files, tmp, tuple(opt), cc), "TVC", precision)
        for s, case in enumerate(loop.cases):
            t0 = time.perf_counter()
            py = runner.trace(cp, 0, s)
            t1 = time.perf_counter()
            c = c_trace(loop.plant, runner.sigs[s], runner.opt[0], ctl)
            seconds["python"] += t1 - t0
            seconds["c"] += time.perf_counter() - t1
            diff[case.name] = max(float(np.max(np.abs(py[k] - c[k]), initial=0.0)) for k in ("x", "y", "u"))
            scale[case.name] = max(float(np.max(np.abs(py[k]), initial=0.0)) for k in ("x", "y", "u"))
            for side, tr in (("python", py), ("c", c)):
                _item_stats(tr["y"], tr["u"], tr["x"], runner.sigs[s][:, 0], runner.out_idx, runner.h, runner.win[s],
                            runner.sigs[s].shape[0], float(tr["status"]), float(tr["n_done"]), stats[side][0, s])
    models = ModelSet("nominal", [loop.plant], ["nominal"])
    out = {}
    for side in ("python", "c"):
        sc = loop.score(cp, stats[side], models)
        per = {} if sc.error else {case.name: {k: float(v) for k, v in sc.q[0][s].items()}
                                   for s, case in enumerate(loop.cases)}
        out[side] = Score(sc.fitness if not sc.error else math.nan, per, sc.error)
    agrees = None if precision != "double" else all(d <= DOUBLE_TOL * max(1.0, scale[k]) for k, d in diff.items())
    return {**out, "controller": loop.ctrl.name, "precision": precision, "flags": list(opt),
            "compiler": shlex.join(cc), "max_abs_diff": diff, "agrees": agrees, "tolerance": DOUBLE_TOL,
            "seconds": seconds}
