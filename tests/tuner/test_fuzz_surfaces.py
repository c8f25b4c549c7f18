"""Fuzzing the surfaces beyond the command line's configs (the other half of the fuzzing budget of
``tests/tuner/test_fuzz_cli.py``, whose rules this follows): the plant grammar of closed-loop jobs (``tf``,
``zpk``, ``ss``, Python dynamics, FMUs, with their scenario, actuator, sensor, cost and requirements), FMU files
mutated byte by byte or built hostile, the C export and ``verify-c`` (prefixes, precisions, compilers, data),
the Python API (``tune``, ``load``, ``Result.build``, ``Result.report``) and handed-over runs whose plant module
lies inside them.

Each iteration must end as its surface allows: a command with exit 0, 1 or 2 and no traceback, an API call
returning or raising only what its docs say (``ConfigError``, ``RunError``, a refused file, ``ValueError`` from
``build``, the ``KeyboardInterrupt`` ``tune`` re-raises after the stop timer); write nothing outside the
sandbox's folders (a victim file stays untouched); never import a plant module shipped inside a run (a marker
file stays absent); and leave no file in the temporary directory (FMU extraction folders included).
``TUNER_FUZZ_ONLY=i`` replays iteration ``i``.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import random
import shutil
import signal
import sys
import zipfile
from pathlib import Path

import pytest
import yaml

from tests.tuner.test_fuzz_cli import (
    READ_SECONDS,
    RUN_SECONDS,
    TEXT_BOMBS,
    VALUES,
    _Alarm,
    _call,
    _mutate_run_dir,
    _set,
    _snapshot,
    check_tmp_empty,
    iterations,
    private_tmp,  # noqa: F401 - a fixture
    stop_timer,
)
from tuner.cli import main

pytestmark = pytest.mark.slow

HAVE_FMU = importlib.util.find_spec("fmpy") is not None and (shutil.which("cc") or shutil.which("gcc")) is not None
LOOP = {"name": "pl", "seed": 1, "objective": {
    "kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [0.5, 1.0]}}, "controller": "pid2dof",
    "period_s": 0.05, "scenario": {"duration_s": 1.0, "reference": [{"t": 0.1, "value": 1.0}]}},
    "optimizer": {"method": "pso", "population": 2, "generations": 2}, "parallel": {"backend": "serial"}}
#: Python dynamics numba does not compile (a Python list), so an iteration spends no time compiling; the module
#: writes the marker when imported (it never must be, from inside a handed-over run)
PLANT = """import pathlib
import numpy as np
if {inside}:
    pathlib.Path({marker!r}).write_text('imported')
_calls = []


def dynamics(x, u, t, params):
    _calls.append(0)
    return -x + u[0]
"""
PLANTS = [
    {"tf": {"num": [1.0], "den": [0.5, 1.0]}}, {"tf": {"num": [2.0, 1.0], "den": [1.0, 3.0, 2.0]}, "delay_s": 0.1},
    {"zpk": {"z": [], "p": [-1.0, -2.0], "k": 2.0}}, {"ss": {"A": [[0.0, 1.0], [-2.0, -3.0]], "B": [[0.0], [1.0]],
                                                          "C": [[1.0, 0.0]]}},
    {"python": "fzplant:dynamics", "x0": [0.0], "n_sub": 2}, {"fmu": "plant.fmu", "inputs": ["u"], "outputs": ["y"],
                                                           "parameters": {"K": 2.0, "T": 0.5}},
]
PLANT_KEYS = ["objective.plant.tf.num", "objective.plant.tf.den", "objective.plant.zpk.p", "objective.plant.zpk.k",
              "objective.plant.ss.A", "objective.plant.ss.B", "objective.plant.dt", "objective.plant.delay_s",
              "objective.plant.method", "objective.plant.output", "objective.plant.inner_output", "objective.plant.x0",
              "objective.plant.python", "objective.plant.n_sub", "objective.plant.params", "objective.plant.fmu",
              "objective.plant.inputs", "objective.plant.parameters", "objective.controller", "objective.period_s",
              "objective.scenario.duration_s", "objective.scenario.reference", "objective.scenario.load",
              "objective.actuator.u_min", "objective.actuator.rate_limit", "objective.sensor.noise_std",
              "objective.cost", "objective.requirements", "objective.fixed", "objective.plant.linearize_at"]
PLANT_VALUES = [*VALUES, [1.0, 1.0], [[1.0]], [[0.0, 1.0], [-1.0, -1.0]], [-1.0] * 300, [1.0] * 2000, 1e-12, 1e9,
                100.0, 0.05, "../../x.fmu", "/dev/zero", "os:system", "fzplant:dynamics", "fzplant:nope", "zoh",
                "tustin", "lqr_sf", "pid_cascade", "open_loop", {"t": [0, 1], "value": [0, 1]},
                [{"t": 0.1, "value": 1.0, "ramp_s": 0.5}], {"iae": 1.0}, {"mae_product": {"e": 1.0}},
                {"max_ms": 1.2}, {"x": [0.0], "u": [0.0]}]


def _mutated(rng: random.Random, doc: dict, keys: list[str], values: list) -> dict:
    doc = json.loads(json.dumps(doc))
    for _ in range(rng.randint(1, 3)):
        _set(doc, rng.choice(keys), rng.choice(values))
    return doc


def _dump(doc) -> str:
    try:
        return yaml.safe_dump(doc, allow_unicode=True)
    except (yaml.YAMLError, ValueError):
        return "name: x\n"


@pytest.fixture(scope="module")
def surfaces(tmp_path_factory):
    """Built once: a closed-loop run on Python dynamics, a filter run with a C port, and the test FMU."""
    root = tmp_path_factory.mktemp("surfaces")
    (root / "fzplant.py").write_text(PLANT.format(inside=False, marker=""))
    quiet = contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO())
    with quiet[0], quiet[1]:
        plant = {**LOOP, "objective": {**LOOP["objective"], "plant": PLANTS[4]}, "output": str(root / "runs")}
        (root / "loop.yaml").write_text(yaml.safe_dump(plant))
        assert main(["run", str(root / "loop.yaml"), "--run-dir", str(root / "loop"), "-q", "--no-report"]) == 0
        flt = {"name": "flt", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick", "data": [
            {"synthetic": {"generator": "bench6dof", "duration_s": 3.0, "rate_hz": 100.0, "seed": 1}}]},
            "optimizer": {"method": "pso", "population": 2, "generations": 1}, "parallel": {"backend": "serial"}}
        (root / "flt.yaml").write_text(yaml.safe_dump(flt))
        assert main(["run", str(root / "flt.yaml"), "--run-dir", str(root / "flt"), "-q", "--no-report"]) == 0
        if HAVE_FMU:
            spec = importlib.util.spec_from_file_location("build_fmu", Path(__file__).resolve().parents[2]
                                                          / "configs" / "examples" / "fmu" / "build_fmu.py")
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            mod.build(root)
            (root / "first_order.fmu").rename(root / "plant.fmu")
        # every module the iterations use imported now: a stop landing in a first import leaves a module half
        # initialised for the rest of this process (a fresh `tuner` process has no such history)
        import control  # noqa: F401

        import tuner

        for plant in PLANTS[:4] + PLANTS[5:6] * HAVE_FMU:
            (root / "p.yaml").write_text(yaml.safe_dump({**LOOP, "objective": {**LOOP["objective"], "plant": plant}}))
            shutil.copy(root / "p.yaml", root / "q.yaml")
            main(["evaluate", str(root / "q.yaml")])
        for argv in (["export", str(root / "flt"), "--format", "c-source", "--out", str(root / "c")],
                     ["verify-c", str(root / "flt")], ["evaluate", str(root / "loop")], ["export", str(root / "loop")],
                     ["report", str(root / "loop")], ["dashboard", str(root)], ["show", str(root / "loop")]):
            main(argv)
        tuner.load(root / "loop").build()
    sys.modules.pop("fzplant", None)
    return root


def _mutate_fmu(rng: random.Random, src: Path, dst: Path) -> None:
    data = bytearray(src.read_bytes())
    op = rng.randrange(6)
    if op == 0:  # flip bytes
        for _ in range(rng.randint(1, 20)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        dst.write_bytes(bytes(data))
    elif op == 1:
        dst.write_bytes(bytes(data[:rng.randrange(len(data))]))
    elif op == 2:
        dst.write_bytes(rng.choice([b"", b"PK\x03\x04", b"\x00" * 100, TEXT_BOMBS[0].encode()]))
    else:
        with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
            for info in zin.infolist():
                body = zin.read(info)
                if op == 3 and info.filename == "modelDescription.xml":
                    body = rng.choice([b'<!DOCTYPE x [<!ENTITY a "aaaa">]>' + body, body[:rng.randrange(len(body))],
                                       body.replace(b"first_order", b"../x"), b"<a>" * 5000])
                zout.writestr(info.filename, body)
            if op == 4:
                zout.writestr(rng.choice(["../../up.so", "/abs.so", "a\\b", "resources/x"]), b"x")
            if op == 5:
                zout.writestr("resources/zeros", bytes(rng.choice([10, 2**20])))


def _api(rng: random.Random, box: Path, loop_dir: Path, flt_dir: Path, cfg_doc: dict) -> str:
    """One Python-API call; returns what was called. Raises only the documented exceptions."""
    import tuner
    from tuner.config import ConfigError
    from tuner.records import RunError
    from tuner.safe_io import UnsafeFile

    what = rng.choice(["tune", "tune", "load", "build", "report"])
    target = rng.choice([loop_dir, flt_dir])
    try:
        if what == "tune":
            kw = {"run_dir": box / "runs" / f"t{rng.randrange(3)}", "progress": False,
                  "report": rng.choice([True, False]),
                  "seed": rng.choice([None, 1, -2, 1.5, "x", True]), "overrides": rng.choice(
                      [None, [], ["optimizer.generations=1"], "optimizer.population=2", [3], ["bad"]])}
            tuner.tune(rng.choice([cfg_doc, str(box / "cfg.yaml"), {"objective": {}}]), **kw)
        else:
            res = tuner.load(target)
            if what == "build":
                with contextlib.suppress(ValueError):
                    res.build()
            elif what == "report":
                res.report()
    except (ConfigError, RunError, UnsafeFile, KeyboardInterrupt):
        pass
    return f"tuner.{what}({target.name})"


def test_fuzz_new_surfaces(tmp_path, surfaces, monkeypatch, private_tmp):  # noqa: F811 - the fixture
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    marker = tmp_path / "IMPORTED"
    box = tmp_path / "box"
    seen = {}
    kinds = ["plant", "plant", "handed", "api", "cexport", *(["fmu", "fmu"] if HAVE_FMU else [])]
    with stop_timer(), contextlib.ExitStack() as cleanup:
        cleanup.callback(sys.modules.pop, "fzplant", None)
        for i, rng in iterations(box, monkeypatch, "surfaces-"):
            shutil.copy(surfaces / "fzplant.py", box / "fzplant.py")
            if HAVE_FMU:
                shutil.copy(surfaces / "plant.fmu", box / "plant.fmu")
            loop_dir, flt_dir = box / "work" / "loop", box / "work" / "flt"
            shutil.copytree(surfaces / "loop", loop_dir)
            shutil.copytree(surfaces / "flt", flt_dir)
            kind = rng.choice(kinds)
            doc = {**LOOP, "objective": {**LOOP["objective"], "plant": rng.choice(PLANTS[:5 + HAVE_FMU])},
                   "output": str(box / "runs")}
            doc = _mutated(rng, doc, PLANT_KEYS, PLANT_VALUES) if rng.random() < 0.8 else doc
            cfg = box / "cfg.yaml"
            cfg.write_text(_dump(doc))
            before = _snapshot(box, ("work", "runs", "out"))
            label, code, err = "", 0, ""
            if kind == "plant":
                argv = rng.choice([["run", str(cfg), "-q"], ["run", str(cfg), "-q", "--no-report"],
                                   ["evaluate", str(cfg)],
                                   ["cv", str(cfg), "-q", "--k", "2", "--dir", str(box / "out")]])
            elif kind == "fmu":
                _mutate_fmu(rng, surfaces / "plant.fmu", box / "plant.fmu")
                doc["objective"]["plant"] = dict(PLANTS[5])
                cfg.write_text(_dump(doc))
                argv = rng.choice([["run", str(cfg), "-q", "--no-report"], ["evaluate", str(cfg)]])
            elif kind == "cexport":
                if rng.random() < 0.5:
                    _mutate_run_dir(rng, flt_dir, victim)
                (box / "data.yaml").write_text(rng.choice([
                    "data: []\n", "data: [{synthetic: {generator: bench6dof, duration_s: 2.0, rate_hz: 100.0}}]\n",
                    "data: [{synthetic: {generator: bench6dof, duration_s: 1.0e+9, rate_hz: 1000.0}}]\n",
                    rng.choice(TEXT_BOMBS)]))
                monkeypatch.setenv("CC", rng.choice(["", "/bin/false", "cc -DFUZZ=1", "no-such-cc", "cc '-O", "cc"]))
                argv = rng.choice([
                    ["export", str(flt_dir), "--format", "c-source", "--out", str(box / "out" / "c"),
                     "--precision", rng.choice(["double", "float"])],
                    ["export", str(flt_dir), "--format", rng.choice(["c-source", "c"]), "--prefix",
                     rng.choice(["EKF1", "1x", "a b", "K", "\u00e9", "x" * 300]), "--out", str(box / "out" / "c")],
                    ["verify-c", str(flt_dir)], ["verify-c", str(flt_dir), "--data", str(box / "data.yaml")],
                    ["verify-c", str(flt_dir), "--precision", "float", "--fast-math"]])
            elif kind == "handed":  # the plant module shipped inside the run, its config pointing there
                (loop_dir / "fzplant.py").write_text(PLANT.format(inside=True, marker=str(marker)))
                run_cfg = yaml.safe_load((loop_dir / "config.yaml").read_text())
                run_cfg["base_dir"] = rng.choice([str(loop_dir), str(loop_dir / "."), "."])
                if rng.random() < 0.3:
                    run_cfg.pop("base_dir")
                (loop_dir / "config.yaml").write_text(yaml.safe_dump(run_cfg))
                if rng.random() < 0.4:
                    _mutate_run_dir(rng, loop_dir, victim)
                argv = rng.choice([["show", str(loop_dir)], ["report", str(loop_dir)], ["export", str(loop_dir)],
                                   ["export", str(loop_dir), "--format", rng.choice(["json", "python", "c"])],
                                   ["compare", str(loop_dir), str(flt_dir)], ["evaluate", str(loop_dir)],
                                   ["resume", str(loop_dir), "-q"], ["cv", str(loop_dir), "-q", "--k", "2"],
                                   ["dashboard", str(box / "work")], ["list", "runs", "--dir", str(box / "work")]])
            else:
                argv = []
                if rng.random() < 0.4:
                    _mutate_run_dir(rng, rng.choice([loop_dir, flt_dir]), victim)
                _Alarm.armed, _Alarm.fired = True, False
                signal.setitimer(signal.ITIMER_REAL, RUN_SECONDS)
                try:
                    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                        label = _api(rng, box, loop_dir, flt_dir, doc)
                except Exception as exc:  # noqa: BLE001 - the point: nothing undocumented may escape
                    pytest.fail(f"iteration {i} (TUNER_FUZZ_ONLY={i}): the Python API raised "
                                f"{type(exc).__name__}: {exc}")
                finally:
                    _Alarm.armed = False
                    signal.setitimer(signal.ITIMER_REAL, 0)
            if argv:
                label = f"tuner {argv}"
                try:  # compiling and running the C takes seconds: verify-c and the C export get longer
                    code, err = _call(argv, READ_SECONDS if kind == "cexport" else None)
                except BaseException as exc:  # noqa: BLE001 - the point: nothing may escape main
                    pytest.fail(f"iteration {i} (TUNER_FUZZ_ONLY={i}): {label} raised {type(exc).__name__}: {exc}")
                assert code in (0, 1, 2), f"iteration {i}: {label} exited {code}: {err[-2000:]}"
                assert "Traceback" not in err, f"iteration {i}: {label} printed a traceback:\n{err[-4000:]}"
            monkeypatch.delenv("CC", raising=False)
            sys.modules.pop("fzplant", None)
            assert not marker.exists(), f"iteration {i}: {label} imported the plant module inside the run"
            assert victim.read_text() == "keep me\n", f"iteration {i}: {label} wrote through a link"
            new = sorted(set(_snapshot(box, ("work", "runs", "out"))) - set(before) - {"cfg.yaml", "data.yaml"})
            assert not [n for n in new if not n.startswith("__pycache__")], \
                f"iteration {i}: {label} wrote outside its folders: {new}"
            check_tmp_empty(private_tmp, f"iteration {i}: {label}")
            seen[kind] = seen.get(kind, 0) + 1
    print(f"fuzz surfaces: {seen}")
