"""A MuJoCo model as a plant: the file compiled, its actuators, outputs and state named, its loop run.

:func:`mujoco_from_spec` builds a :class:`MujocoPlant` from ``objective.plant`` (the keys in
:mod:`objectives.control.plants.mujoco`), checking everything before any tuning: the file exists and
compiles (MJCF, or URDF through MuJoCo's own compiler), every name exists (the message lists the model's
names), the controller period is a whole number of timesteps, and one period runs through the Python
bindings without a MuJoCo error or warning. The plant is the stepped variant of the ``Plant`` protocol
(:mod:`objectives.control.plants.base`): :meth:`MujocoPlant.run` runs the compiled loop
(:mod:`.kernel`) on an ``mjData`` of the caller's; ``design_model`` is the linearisation of
:mod:`.linearize`.

The plant's state is that of MuJoCo's transition derivatives (``mjd_transitionFD``) restricted to the
joints of ``state_joints``: the tangent-space position difference from the operating point of each of
their dofs (not for a joint given as ``{joint: name, position: false}``: a wheel whose angle nothing
depends on), the velocities of all their dofs, then every actuator activation. The operating point and the initial state
are a keyframe's (or the model's ``qpos0`` at rest, or the ``qpos``/``qvel``/``ctrl`` given); a
scenario moves the initial state from there (:mod:`.scenario`).

MuJoCo's automatic reset on a bad acceleration is disabled in the plant's copy of the model, so an
unstable simulation shows as a non-finite state (a failed evaluation) instead of a silent restart.
"""

from __future__ import annotations

import copy
import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from objectives.control.plants.mujoco.capi import capi, quiet_warnings, warnings_of
from objectives.control.plants.mujoco.kernel import (
    OPT_SIZE,
    SRC_PITCH,
    SRC_QPOS,
    SRC_QVEL,
    SRC_ROLL,
    SRC_SENSOR,
    SRC_YAW,
    STATUS_DIVERGED,
    _closed_loop,
)
from objectives.control.plants.mujoco.parameters import apply_parameters, named_parameters

__all__ = ["MujocoPlant", "mujoco_from_spec", "MJ_KEYS", "DIVERGENCE_LIMIT"]

#: every key of a MuJoCo plant mapping
MJ_KEYS = frozenset({"mujoco", "actuators", "motors", "outputs", "state_joints", "keyframe", "qpos", "qvel", "ctrl",
                     "timestep_s", "ctrlrange", "loops", "parameters"})
#: |qpos|, |qvel| or |output| beyond which the loop counts as diverged
DIVERGENCE_LIMIT = 1e9
_ANGLES = {"roll": SRC_ROLL, "pitch": SRC_PITCH, "yaw": SRC_YAW}


@dataclass
class MujocoPlant:
    """A compiled MuJoCo model with its named inputs, outputs and state (module docstring).

    Attributes
    ----------
    mj : mujoco.MjModel
        The plant's own compiled model (timestep, ctrlrange, parameters applied; automatic reset off).
    period_s, n_sub : float, int
        Controller period (s) and the engine steps per period (``period_s / timestep``).
    input_names, inp_adr, ulim : list, (m,) int64, (m, 2)
        The controlled actuators, their indices in ``ctrl`` and ranges (``+-inf`` when unlimited).
    output_names, out_src : list, (p, 2) int64
        The outputs and where each is read (:mod:`.kernel`'s ``SRC_*`` and an address).
    state_names, pdofs, vdofs : list, (np,) int64, (nv,) int64
        The state's names (``<joint>`` per position, ``<joint>_vel`` per velocity, ``act_<actuator>``), the
        dofs whose positions and whose velocities it holds.
    qpos_op, qvel_op, act_op, ctrl_op : arrays
        The operating point (also the initial state before a scenario's offsets).
    loops : list of (output index, input index)
        The PID loops of ``joint_pid``.
    """

    linear: ClassVar[bool] = False
    mj: Any
    spec: dict[str, Any]
    path: str
    period_s: float
    n_sub: int
    input_names: list[str]
    inp_adr: np.ndarray
    ulim: np.ndarray
    output_names: list[str]
    out_src: np.ndarray
    out_state: np.ndarray
    state_names: list[str]
    pdofs: np.ndarray
    vdofs: np.ndarray
    qpos_op: np.ndarray
    qvel_op: np.ndarray
    act_op: np.ndarray
    ctrl_op: np.ndarray
    loops: list[tuple[int, int]]
    model: str = "mujoco"
    delay_n: int = 0
    output: int = 0
    inner_output: int = -1
    _data: Any = field(default=None, repr=False)
    _design: Any = field(default=None, repr=False)
    _y_op: Any = field(default=None, repr=False)

    # --- the Plant protocol -------------------------------------------------------------------
    @property
    def n_states(self) -> int:
        return self.pdofs.size + self.vdofs.size + int(self.mj.na)

    @property
    def n_inputs(self) -> int:
        return int(self.inp_adr.size)

    @property
    def n_outputs(self) -> int:
        return int(self.out_src.shape[0])

    @property
    def x0(self) -> np.ndarray:
        """The initial state in the plant's state coordinates: the operating point, zero deviation."""
        return np.zeros(self.n_states)

    @property
    def rk4(self) -> bool:
        import mujoco

        return int(self.mj.opt.integrator) == int(mujoco.mjtIntegrator.mjINT_RK4)

    @property
    def timestep_s(self) -> float:
        return float(self.mj.opt.timestep)

    def new_data(self) -> Any:
        """A fresh ``mjData`` of this model at the operating point."""
        import mujoco

        d = mujoco.MjData(self.mj)
        self.reset_data(d)
        return d

    def reset_data(self, d: Any, qpos_offset: np.ndarray | None = None, qvel_offset: np.ndarray | None = None) -> None:
        """``d`` back to the operating point (warnings, warm start and time cleared), moved by the offsets."""
        import mujoco

        mujoco.mj_resetData(self.mj, d)
        d.qpos[:] = self.qpos_op if qpos_offset is None else self.qpos_op + qpos_offset
        d.qvel[:] = self.qvel_op if qvel_offset is None else self.qvel_op + qvel_offset
        d.act[:] = self.act_op
        d.ctrl[:] = self.ctrl_op

    def reset(self) -> None:
        """The protocol's reset: the plant's own ``mjData`` back to the operating point."""
        if self._data is None:
            self._data = self.new_data()
        self.reset_data(self._data)

    def run(self, d: Any, sig: np.ndarray, cp: np.ndarray, opt: np.ndarray, ylim: np.ndarray, y: np.ndarray,
            u: np.ndarray, x: np.ndarray) -> tuple[int, int, str]:
        """The compiled loop (:func:`.kernel._closed_loop`) on ``d`` from its current state; returns
        ``(status, periods done, MuJoCo's warning or '')``. ``d`` must be an ``mjData`` of this model."""
        api = capi()
        layout = (self.out_src, self.inp_adr, self.pdofs, self.vdofs, self.qpos_op, self.qvel_op, self.act_op,
                  self.ulim, ylim)
        views = (d.qpos, d.qvel, d.act, d.sensordata, d.xquat, d.ctrl)
        ptrs = np.array([self.mj._address, d._address], dtype=np.int64)
        with quiet_warnings():
            status, done = _closed_loop((api.step1, api.step2, api.step), api.diffpos, ptrs, views, layout, sig, cp,
                                        opt, y, u, x)
        warned = warnings_of(d)
        if warned and status != STATUS_DIVERGED:
            status = STATUS_DIVERGED
        return int(status), int(done), warned

    def run_loop(self, sig, cp, opt, y, u, x):
        """The protocol's loop: :meth:`run` on the plant's own ``mjData`` from the operating point, with
        ``opt`` the kernel's options and no output limits."""
        self.reset()
        status, done, _ = self.run(self._data, sig, cp, opt, np.full(self.n_outputs, np.inf), y, u, x)
        return status, done

    def options(self, kind: int, delay_n: int = 0) -> np.ndarray:
        """The kernel's ``opt`` array for controller ``kind`` and a measurement delay of ``delay_n`` periods."""
        opt = np.zeros(OPT_SIZE)
        opt[:] = [kind, self.n_sub, 1.0 if self.rk4 else 0.0, delay_n, DIVERGENCE_LIMIT]
        return opt

    def design_model(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)`` of the linearisation at the operating point over one controller period, in the plant's
        state (:func:`.linearize.period_model`); computed once."""
        if self._design is None:
            from objectives.control.plants.mujoco.linearize import period_model

            self._design = period_model(self)
        return self._design[0], self._design[1]

    def tracked_row(self) -> np.ndarray:
        """The state row of output 0 (a joint position or velocity in the state); ``ValueError`` otherwise."""
        return self.state_row(0)

    def state_row(self, i: int) -> np.ndarray:
        """The state row equal to output ``i``'s deviation from its operating value (``ValueError`` when
        output ``i`` is not a position or velocity of a dof in the state)."""
        j = int(self.out_state[i])
        if j < 0:
            raise ValueError(f"output {self.output_names[i]!r} is not a joint position or velocity of the state "
                             f"(state: {self.state_names})")
        row = np.zeros(self.n_states)
        row[j] = 1.0
        return row

    def named_parameters(self) -> dict[str, float]:
        """The model's named physical parameters (:mod:`.parameters`)."""
        return named_parameters(self.mj)

    def with_parameters(self, values: Mapping[str, Any], key: str = "objective.plant.parameters") -> MujocoPlant:
        """This plant on a copy of its model with ``values`` set (equal to building the spec with them in
        ``parameters``; the operating point and names stay)."""
        m = copy.copy(self.mj)
        apply_parameters(m, values, key)
        spec = {**self.spec, "parameters": {**dict(self.spec.get("parameters") or {}), **dict(values)}}
        return replace(self, mj=m, spec=spec, _data=None, _design=None, _y_op=None)

    def operating_outputs(self) -> np.ndarray:
        """The outputs at the operating point (computed once)."""
        if self._y_op is None:
            self._y_op = self.output_values(self.new_data())
        return self._y_op

    def output_values(self, d: Any) -> np.ndarray:
        """The outputs of ``d``'s state (``mj_forward`` first): the kernel's reading, for the operating values."""
        import mujoco

        mujoco.mj_forward(self.mj, d)
        y = np.empty(self.n_outputs)
        for i, (kind, adr) in enumerate(self.out_src):
            if kind == SRC_QPOS:
                y[i] = d.qpos[adr]
            elif kind == SRC_QVEL:
                y[i] = d.qvel[adr]
            elif kind == SRC_SENSOR:
                y[i] = d.sensordata[adr]
            else:
                w, a, b, c = d.xquat[adr]
                y[i] = {SRC_ROLL: math.atan2(2 * (w * a + b * c), 1 - 2 * (a * a + b * b)),
                        SRC_PITCH: math.asin(min(max(2 * (w * b - c * a), -1.0), 1.0)),
                        SRC_YAW: math.atan2(2 * (w * c + a * b), 1 - 2 * (b * b + c * c))}[int(kind)]
        return y


# --------------------------------------------------------------------------------------------------
# building from the YAML spec
# --------------------------------------------------------------------------------------------------
def _names(m: Any, what: str) -> list[str]:
    import mujoco

    obj = {"actuator": mujoco.mjtObj.mjOBJ_ACTUATOR, "joint": mujoco.mjtObj.mjOBJ_JOINT,
           "sensor": mujoco.mjtObj.mjOBJ_SENSOR, "body": mujoco.mjtObj.mjOBJ_BODY, "key": mujoco.mjtObj.mjOBJ_KEY}[what]
    n = {"actuator": m.nu, "joint": m.njnt, "sensor": m.nsensor, "body": m.nbody, "key": m.nkey}[what]
    return [mujoco.mj_id2name(m, obj, i) or "" for i in range(n)]


def _find(m: Any, what: str, name: Any, key: str, label: str) -> int:
    names = _names(m, what)
    if not isinstance(name, str) or name not in names:
        have = [n for n in names if n]
        raise ValueError(f"{key}: no {label} named {name!r} in the model; its {label}s: {have or 'none (unnamed)'}")
    return names.index(name)


def _joint_dofs(m: Any, j: int) -> list[int]:
    import mujoco

    n = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}.get(int(m.jnt_type[j]), 1)
    return list(range(int(m.jnt_dofadr[j]), int(m.jnt_dofadr[j]) + n))


def _load(spec: Mapping[str, Any], base_dir: pathlib.Path | None, key: str) -> tuple[Any, pathlib.Path]:
    """The compiled model of ``spec["mujoco"]`` (with ``motors`` added); ``ValueError`` naming the key."""
    try:
        import mujoco
    except ImportError:
        raise ValueError(f"{key}.mujoco: MuJoCo plants need the mujoco package (pip install -e '.[mujoco]')") from None
    src = spec["mujoco"]
    if not isinstance(src, str) or not src:
        raise ValueError(f"{key}.mujoco: expected the path of an MJCF (.xml) or URDF file, got {src!r}")
    path = pathlib.Path(src)
    if not path.is_absolute() and base_dir is not None:
        path = pathlib.Path(base_dir) / path
    if not path.is_file():
        raise ValueError(f"{key}.mujoco: no such file {str(path)!r}")
    motors = spec.get("motors") or []
    if not isinstance(motors, list) or not all(isinstance(j, str) for j in motors):
        raise ValueError(f"{key}.motors: expected a list of joint names (one motor actuator each), got {motors!r}")
    try:
        if motors:
            ms = mujoco.MjSpec.from_file(str(path))
            joints = [j.name for j in ms.joints]
            for j in motors:
                if j not in joints:
                    raise ValueError(f"{key}.motors: no joint named {j!r} in the model; its joints: {joints}")
                a = ms.add_actuator()
                a.name, a.target, a.trntype = j, j, mujoco.mjtTrn.mjTRN_JOINT
            m = ms.compile()
        else:
            m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        if str(exc).startswith(key):
            raise
        text = "; ".join(s.strip() for s in str(exc).strip().splitlines() if s.strip())
        raise ValueError(f"{key}.mujoco: {path.name} does not compile: {text}") from None
    return m, path


def _vector(key: str, v: Any, n: int) -> np.ndarray:
    try:
        a = np.array(v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a list of {n} numbers, got {v!r}") from None
    if a.size != n or not np.all(np.isfinite(a)):
        raise ValueError(f"{key}: expected {n} finite numbers, got {v!r}")
    return a


def _sensor_joint(m: Any, s: int) -> tuple[int, int]:
    """``(joint, 0 position / 1 velocity)`` of a jointpos/jointvel sensor on a hinge or slide, else (-1, -1)."""
    import mujoco

    kind = int(m.sensor_type[s])
    what = {int(mujoco.mjtSensor.mjSENS_JOINTPOS): 0, int(mujoco.mjtSensor.mjSENS_JOINTVEL): 1}.get(kind)
    j = int(m.sensor_objid[s])
    if what is None or len(_joint_dofs(m, j)) != 1:
        return -1, -1
    return j, what


def _outputs(m: Any, spec: Any, key: str) -> tuple[list[str], np.ndarray, list[tuple[int, int]]]:
    """Names, the (p, 2) source table and, per output, ``(joint id, 0 position / 1 velocity)`` or ``(-1, -1)``."""
    if spec is None:  # every 1-dof joint's position
        spec = [n for j, n in enumerate(_names(m, "joint")) if n and len(_joint_dofs(m, j)) == 1]
        if not spec:
            raise ValueError(f"{key}.outputs: the model has no named hinge or slide joint; list the outputs")
    if not isinstance(spec, list) or not spec:
        raise ValueError(f"{key}.outputs: expected a list of outputs (a joint or sensor name, or {{joint: ..}}, "
                         f"{{joint_velocity: ..}}, {{sensor: .., index: ..}}, {{body: .., angle: roll|pitch|yaw}}), "
                         f"got {spec!r}")
    names, src, joints = [], [], []
    for i, item in enumerate(spec):
        k = f"{key}.outputs[{i}]"
        if isinstance(item, str):
            if item in _names(m, "joint"):
                item = {"joint": item}
            elif item in _names(m, "sensor"):
                item = {"sensor": item}
            else:
                joints, sensors = [n for n in _names(m, "joint") if n], [n for n in _names(m, "sensor") if n]
                raise ValueError(f"{k}: {item!r} is neither a joint nor a sensor of the model; joints: {joints}, "
                                 f"sensors: {sensors}")
        if not isinstance(item, Mapping):
            raise ValueError(f"{k}: expected a name or a mapping, got {item!r}")
        kinds = [t for t in ("joint", "joint_velocity", "sensor", "body") if t in item]
        allowed = {"joint": {"joint", "name"}, "joint_velocity": {"joint_velocity", "name"},
                   "sensor": {"sensor", "index", "name"}, "body": {"body", "angle", "name"}}
        if len(kinds) != 1 or set(item) - allowed[kinds[0]]:
            raise ValueError(f"{k}: give one of joint, joint_velocity, sensor, body (with index for a sensor, "
                             f"angle for a body, and optionally name), got {dict(item)!r}")
        t = kinds[0]
        if t in ("joint", "joint_velocity"):
            j = _find(m, "joint", item[t], f"{k}.{t}", "joint")
            if len(_joint_dofs(m, j)) != 1:
                raise ValueError(f"{k}.{t}: {item[t]!r} is a free or ball joint; measure a body angle or a sensor")
            pos = t == "joint"
            src.append((SRC_QPOS, int(m.jnt_qposadr[j])) if pos else (SRC_QVEL, int(m.jnt_dofadr[j])))
            joints.append((j, 0 if pos else 1))
            default = item[t] if pos else f"{item[t]}_vel"
        elif t == "sensor":
            s = _find(m, "sensor", item["sensor"], f"{k}.sensor", "sensor")
            dim, idx = int(m.sensor_dim[s]), item.get("index", 0)
            if isinstance(idx, bool) or not isinstance(idx, int) or not 0 <= idx < dim:
                raise ValueError(f"{k}.index: sensor {item['sensor']!r} has {dim} values; an index in 0..{dim - 1}, "
                                 f"got {idx!r}")
            if dim > 1 and "index" not in item:
                raise ValueError(f"{k}.index: sensor {item['sensor']!r} has {dim} values; say which "
                                 f"(index: 0..{dim - 1})")
            src.append((SRC_SENSOR, int(m.sensor_adr[s]) + idx))
            joints.append(_sensor_joint(m, s))
            default = item["sensor"] if dim == 1 else f"{item['sensor']}[{idx}]"
        else:
            b = _find(m, "body", item["body"], f"{k}.body", "body")
            angle = item.get("angle")
            if angle not in _ANGLES:
                raise ValueError(f"{k}.angle: one of {sorted(_ANGLES)} (ZYX angles of the body's orientation), "
                                 f"got {angle!r}")
            src.append((_ANGLES[angle], b))
            joints.append((-1, -1))
            default = f"{item['body']}_{angle}"
        name = item.get("name", default)
        if not isinstance(name, str) or not name:
            raise ValueError(f"{k}.name: expected a non-empty string, got {name!r}")
        names.append(name)
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"{key}.outputs: names must differ, {dup} appear twice (give name: to one of them)")
    return names, np.array(src, dtype=np.int64).reshape(-1, 2), joints


def _state(m: Any, spec: Any, key: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The position dofs, the velocity dofs and the state's names of ``state_joints``."""
    names = _names(m, "joint")
    if spec is None:
        items = [(j, True) for j in range(m.njnt)]
    else:
        if not isinstance(spec, list) or not spec:
            raise ValueError(f"{key}.state_joints: expected a list of joint names (or {{joint: name, position: "
                             f"false}}), got {spec!r}")
        items = []
        for i, it in enumerate(spec):
            k = f"{key}.state_joints[{i}]"
            if isinstance(it, Mapping):
                pos = it.get("position", True)
                if set(it) - {"joint", "position"} or "joint" not in it or not isinstance(pos, bool):
                    raise ValueError(f"{k}: expected a joint name or {{joint: name, position: true|false}}, got "
                                     f"{dict(it)!r}")
                items.append((_find(m, "joint", it["joint"], f"{k}.joint", "joint"), pos))
            else:
                items.append((_find(m, "joint", it, k, "joint"), True))
    pdofs, vdofs, plabels, vlabels = [], [], [], []
    for j, pos in items:
        d = _joint_dofs(m, j)
        for i, dof in enumerate(d):
            base = names[j] or f"joint{j}"
            label = base if len(d) == 1 else f"{base}[{i}]"
            if pos:
                pdofs.append(dof)
                plabels.append(label)
            vdofs.append(dof)
            vlabels.append(f"{label}_vel")
    acts = [f"act_{a or i}" for i, a in enumerate(_names(m, "actuator")) if m.actuator_actadr[i] >= 0]
    return np.array(pdofs, dtype=np.int64), np.array(vdofs, dtype=np.int64), plabels + vlabels + acts


def mujoco_from_spec(spec: Mapping[str, Any], period_s: float, base_dir: pathlib.Path | None,
                     key: str = "objective.plant") -> MujocoPlant:
    """The plant of ``spec`` (its keys among :data:`MJ_KEYS`, checked by the registry) at ``period_s``;
    ``ValueError`` naming the key for every bad input (module docstring)."""
    import mujoco

    m, path = _load(spec, base_dir, key)
    ts = spec.get("timestep_s")
    if ts is not None:
        if isinstance(ts, bool) or not isinstance(ts, (int, float)) or not (math.isfinite(ts) and ts > 0):
            raise ValueError(f"{key}.timestep_s: the engine's timestep must be a number > 0 s, got {ts!r}")
        m.opt.timestep = float(ts)
    ts = float(m.opt.timestep)
    ratio = period_s / ts
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
        lo, hi = max(1, math.floor(ratio)) * ts, max(1, math.ceil(ratio)) * ts
        raise ValueError(f"objective.period_s: {period_s:g} s is not a whole number of the model's timestep "
                         f"{ts:g} s ({path.name}); use a multiple, e.g. {lo:g} or {hi:g}")
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    params = spec.get("parameters") or {}
    if not isinstance(params, Mapping):
        raise ValueError(f"{key}.parameters: expected a mapping of named parameters to values, got {params!r}")
    apply_parameters(m, params, f"{key}.parameters")
    acts = spec.get("actuators")
    all_acts = _names(m, "actuator")
    if m.nu == 0:
        raise ValueError(f"{key}.mujoco: {path.name} has no actuator; add one to the model or name joints in motors")
    if acts is None:
        inp = list(range(m.nu))
    elif isinstance(acts, list) and acts:
        inp = [_find(m, "actuator", a, f"{key}.actuators", "actuator") for a in acts]
    else:
        raise ValueError(f"{key}.actuators: expected a list of actuator names, got {acts!r}")
    input_names = [all_acts[i] or f"actuator{i}" for i in inp]
    ranges = _ctrlrange(m, spec.get("ctrlrange"), inp, input_names, key)
    out_names, out_src, out_joint = _outputs(m, spec.get("outputs"), key)
    pdofs, vdofs, state_names = _state(m, spec.get("state_joints"), key)
    qpos, qvel, act, ctrl = _operating_point(m, spec, key)
    out_state = np.full(len(out_names), -1, dtype=np.int64)
    for i, (j, what) in enumerate(out_joint):
        dofs, base = (pdofs, 0) if what == 0 else (vdofs, pdofs.size)
        if j >= 0 and int(m.jnt_dofadr[j]) in dofs:
            out_state[i] = base + int(np.flatnonzero(dofs == int(m.jnt_dofadr[j]))[0])
    loops = _loops(spec.get("loops"), out_names, input_names, key)
    plant = MujocoPlant(m, dict(spec), str(path), float(period_s), int(round(ratio)), input_names,
                        np.array(inp, dtype=np.int64), ranges, out_names, out_src, out_state, state_names, pdofs, vdofs,
                        qpos, qvel, act, ctrl, loops)
    _check_runs(plant, path.name, key)
    return plant


def _ctrlrange(m: Any, over: Any, inp: list[int], names: list[str], key: str) -> np.ndarray:
    """(m, 2) limits of the controlled inputs: the model's ``ctrlrange`` where limited, else +-inf, with
    ``over`` (``{actuator: [lo, hi]}``) applied (also in the model, so MuJoCo clamps alike)."""
    over = over or {}
    if not isinstance(over, Mapping):
        raise ValueError(f"{key}.ctrlrange: expected a mapping {{actuator: [low, high]}}, got {over!r}")
    out = np.empty((len(inp), 2))
    for k, i in enumerate(inp):
        limited = bool(m.actuator_ctrllimited[i])
        out[k] = m.actuator_ctrlrange[i] if limited else (-np.inf, np.inf)
    for name, rng in over.items():
        if name not in names:
            raise ValueError(f"{key}.ctrlrange.{name}: not a controlled actuator; they are {names}")
        lo_hi = _vector(f"{key}.ctrlrange.{name}", rng, 2)
        if not lo_hi[0] < lo_hi[1]:
            raise ValueError(f"{key}.ctrlrange.{name}: low {lo_hi[0]:g} must be below high {lo_hi[1]:g}")
        k = names.index(name)
        out[k] = lo_hi
        m.actuator_ctrlrange[inp[k]] = lo_hi
        m.actuator_ctrllimited[inp[k]] = 1
    return np.ascontiguousarray(out)


def _operating_point(m: Any, spec: Mapping[str, Any], key: str) -> tuple[np.ndarray, ...]:
    """``(qpos, qvel, act, ctrl)``: a keyframe's, or the model's ``qpos0`` at rest, with the given ones."""
    kf = spec.get("keyframe")
    if kf is not None:
        k = _find(m, "key", kf, f"{key}.keyframe", "keyframe")
        qpos, qvel = np.array(m.key_qpos[k]), np.array(m.key_qvel[k])
        act, ctrl = np.array(m.key_act[k]), np.array(m.key_ctrl[k])
    else:
        qpos, qvel, act, ctrl = np.array(m.qpos0), np.zeros(m.nv), np.zeros(m.na), np.zeros(m.nu)
    given = {name: _vector(f"{key}.{name}", spec[name], n) for name, n in (("qpos", m.nq), ("qvel", m.nv),
                                                                          ("ctrl", m.nu)) if spec.get(name) is not None}
    qpos, qvel, ctrl = given.get("qpos", qpos), given.get("qvel", qvel), given.get("ctrl", ctrl)
    return (np.ascontiguousarray(qpos), np.ascontiguousarray(qvel), np.ascontiguousarray(act),
            np.ascontiguousarray(ctrl))


def _loops(spec: Any, outputs: list[str], inputs: list[str], key: str) -> list[tuple[int, int]]:
    """``joint_pid``'s loops: ``[[output, actuator], ...]``; by default output i drives actuator i."""
    if spec is None:
        return [(i, i) for i in range(min(len(outputs), len(inputs)))]
    if not isinstance(spec, list) or not spec:
        raise ValueError(f"{key}.loops: expected a list of [output, actuator] pairs, got {spec!r}")
    out = []
    for i, pair in enumerate(spec):
        if not (isinstance(pair, list) and len(pair) == 2):
            raise ValueError(f"{key}.loops[{i}]: expected [output, actuator], got {pair!r}")
        if pair[0] not in outputs:
            raise ValueError(f"{key}.loops[{i}]: {pair[0]!r} is not an output; outputs: {outputs}")
        if pair[1] not in inputs:
            raise ValueError(f"{key}.loops[{i}]: {pair[1]!r} is not a controlled actuator; actuators: {inputs}")
        out.append((outputs.index(pair[0]), inputs.index(pair[1])))
    return out


def _check_runs(plant: MujocoPlant, name: str, key: str) -> None:
    """One period at the operating point through the Python bindings: a MuJoCo error or warning is an error."""
    import mujoco

    d = plant.new_data()
    try:
        with quiet_warnings():
            mujoco.mj_step(plant.mj, d, plant.n_sub)
    except Exception as exc:  # noqa: BLE001 - MuJoCo's errors have several classes: any is a config error
        raise ValueError(f"{key}.mujoco: {name} does not run: {type(exc).__name__}: {exc}") from None
    warned = warnings_of(d)
    if warned or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
        raise ValueError(f"{key}.mujoco: {name} is unstable at its operating point within one period "
                         f"(MuJoCo: {warned or 'non-finite state'}); lower timestep_s or check the model")
    plant._data = d
