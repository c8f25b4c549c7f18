"""Fuzzing the command line: mutated configs, sweep files, run and sweep directories (with symbolic and hard links
to a victim file, FIFOs, deeply nested JSON, a removed history chain) and arguments are fed to every subcommand
for a fixed time budget. Each must exit 0, 1 or 2, never with a traceback, never write outside the sandbox's
run, sweep and output folders (a victim file beside it stays untouched), never block (a read-only command the
stop timer had to end failed), and leave no file in the temporary directory.

Seeded and reproducible: iteration ``i`` draws everything from ``random.Random(f"{SEED}-{i}")``, so a failure
names its iteration and ``TUNER_FUZZ_ONLY=i`` replays it alone. ``TUNER_FUZZ_SECONDS`` sets the budget of the
whole fuzzing (62 s by default; the suite's CI run counts on at least 60): half goes to this test, half to the
new surfaces of ``tests/tuner/test_fuzz_surfaces.py`` (plant grammar, FMU files, the C export, the Python API,
handed-over runs naming code), so pytest-xdist runs them side by side. Runs a config turns out valid are
stopped after ``RUN_SECONDS`` by the same path as a SIGTERM (exit 1, status interrupted), so none can run long.
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import os
import random
import shutil
import signal
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from tuner import signals as stop_signals
from tuner.cli import main

pytestmark = pytest.mark.slow

SEED = 20261201
BUDGET_S = float(os.environ.get("TUNER_FUZZ_SECONDS", "62")) / 2  # this test's half of the fuzzing budget
RUN_SECONDS = 2.0
#: how long a read-only command may take before the stop timer counts it as blocked (a report draws figures)
READ_SECONDS = 20.0
#: commands that only read (and write reports): the stop timer must never have to end one
READ_ONLY = ("show", "compare", "list", "export", "report", "dashboard", "describe")

BASE = {"name": "fz", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
        "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
        "output": "runs"}
KEYS = ["name", "seed", "description", "objective", "objective.kind", "objective.function", "objective.dim",
        "objective.sleep_s", "objective.fail_every", "objective.nan_every", "objective.timeout_s", "optimizer",
        "optimizer.method", "optimizer.population", "optimizer.generations", "optimizer.refine",
        "optimizer.refine.stages", "optimizer.refine.shrink", "optimizer.inertia", "optimizer.preset",
        "parameters", "parameters.x0", "parameters.x0.low", "parameters.x0.high", "parameters.x0.scale",
        "parameters.x1", "parallel", "parallel.backend", "parallel.n_jobs", "parallel.address", "validation",
        "validation.cv", "validation.folds", "validation.budget_fraction", "validation.select", "unknown_key"]
VALUES = [0, 1, -1, 2, 3, 7, 10**12, -(10**9), 0.5, -0.5, 1e308, float("nan"), float("inf"), "", "x", "../../up",
          "a/b", "\x00", "é\u202e", "pso", "cmaes", "de", "random", "auto", "trust_region", "log", "linear",
          "serial", "threads", "loky", "kfold", "logo", "none", "sphere", "rosenbrock", "python", "function",
          "tcp://", "tcp://127.0.0.1:1", None, True, False, [], [1, 2], {}, {"a": 1}, {"low": 1, "high": 0},
          {"low": 0.1, "high": 2.0, "scale": "log"}, {"fixed": 3}, {"stages": 2, "shrink": 0.3}, "1e-3", "x" * 3000]
TEXT_BOMBS = ["a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n" for p, c in zip("abcdefgh", "bcdefghi")),
    "name: " + "[" * 3000 + "]" * 3000 + "\n", "\x00\x01\x02\xff", ": : :\n  - [", "sweep: {base: nope.yaml}\n",
    "sweep: {name: '../x', base: {}}\n", "sweep: []\n", "---\n---\n", "!!python/object:os.system ls\n"]


class _Alarm:
    """Stops a run that a mutated config made valid, as a SIGTERM would, only while ``main`` runs; ``fired``
    says whether it had to (a read-only command it had to stop was blocked, e.g. on a FIFO)."""

    armed = False
    fired = False

    @classmethod
    def handler(cls, signum, frame):
        if cls.armed:
            cls.armed = False
            cls.fired = True
            stop_signals._handler(signum, frame)


def _set(doc: dict, dotted: str, value) -> None:
    parts = dotted.split(".")
    d = doc
    for p in parts[:-1]:
        if not isinstance(d.get(p), dict):
            d[p] = {}
        d = d[p]
    d[parts[-1]] = value


def _delete(doc: dict, dotted: str) -> None:
    parts = dotted.split(".")
    d = doc
    for p in parts[:-1]:
        d = d.get(p) if isinstance(d, dict) else None
        if not isinstance(d, dict):
            return
    d.pop(parts[-1], None)


def _config_text(rng: random.Random, base: dict | None = None) -> str:
    doc = json.loads(json.dumps(base or BASE))
    for _ in range(rng.randint(1, 3)):
        key = rng.choice(KEYS)
        if rng.random() < 0.2:
            _delete(doc, key)
        else:
            _set(doc, key, rng.choice(VALUES))
    if rng.random() < 0.08:
        return rng.choice(TEXT_BOMBS)
    text = yaml.safe_dump(doc, allow_unicode=True)
    if rng.random() < 0.1:  # cut or corrupt the text itself
        cut = rng.randrange(len(text))
        text = text[:cut] + (rng.choice(["\x00", "\t", ":", "&a", "*b", "]", "\ufffd"]) if rng.random() < 0.5 else "")
    return text


def _mutate_run_dir(rng: random.Random, d: Path, victim: Path) -> None:
    files = sorted(p for p in d.rglob("*") if p.is_file())
    for _ in range(rng.randint(1, 2)):
        target = rng.choice(files)
        op = rng.randrange(13)
        if not os.path.lexists(target) or target.is_symlink() or not target.is_file():  # changed by the one before
            continue
        if op == 9:  # a FIFO in its place: reading it without O_NONBLOCK blocked show, report, resume
            target.unlink()
            os.mkfifo(target)
            return
        if op == 10:  # a hard link to the victim: nothing may be written through it
            target.unlink()
            os.link(victim, target)
            return
        if op == 11 and target.suffix in (".json", ".chain", ".csv"):
            depth = rng.choice([70, 5000, 200_000])
            target.write_text("[" * depth + "]" * depth)
            continue
        if op == 12:
            (d / "history.chain").unlink(missing_ok=True)
            continue
        if op == 0:
            target.unlink()
            os.symlink(victim, target)
            return  # (the next mutation would write through it itself)
        elif op == 1:
            target.unlink()
        elif op == 2:
            data = target.read_bytes()
            target.write_bytes(data[:rng.randrange(len(data) + 1)])
        elif op == 3:
            target.write_bytes(bytes(rng.randrange(256) for _ in range(rng.randint(1, 200))))
        elif op == 4:
            target.write_text(rng.choice(TEXT_BOMBS))
        elif op == 5:
            target.write_text(json.dumps(rng.choice(VALUES)))
        elif op == 6 and target.suffix in (".csv", ".chain", ".yaml", ".json"):
            text = target.read_text(errors="replace")
            i = rng.randrange(len(text) + 1)
            target.write_text(text[:i] + str(rng.choice(VALUES)) + text[i + 1:])
        elif op == 7:
            text = target.read_text(errors="replace")
            target.write_text(text + "\n" + "y" * rng.choice([10, 200_000]) + "\n")
        elif op == 8 and (d / "figures").is_dir():
            shutil.rmtree(d / "figures")
            os.symlink(victim.parent, d / "figures")
            return


def _args(rng: random.Random, box: Path, run_dir: Path, sweep_dir: Path, cfg: Path, sweep: Path) -> list[str]:
    out = str(box / "out" / f"x{rng.randrange(10)}")
    choices = [
        ["run", str(cfg), "-q"], ["run", str(cfg), "--set", f"{rng.choice(KEYS)}={json.dumps(rng.choice(VALUES))}",
                                  "-q"],
        ["run", str(cfg), "--run-dir", str(box / "runs" / "given"), "-q"], ["run", str(cfg), "--seed", "-5", "-q"],
        ["run", str(cfg), "--n-jobs", str(rng.choice([0, -3, 1, 10**6]))],
        ["resume", str(run_dir), "-q"], ["show", str(run_dir)], ["show", str(run_dir), "--json"],
        ["show", str(sweep_dir)], ["report", str(run_dir)], ["report", str(sweep_dir)],
        ["dashboard", str(box / "work")],
        ["compare", str(run_dir), str(run_dir)], ["list", rng.choice(["runs", "all", "bogus", "metrics"]),
                                                   "--dir", str(box / "work")],
        ["export", str(run_dir), "--format", rng.choice(["yaml", "json", "python", "c"])],
        ["export", str(run_dir), "--format", "c", "--prefix", rng.choice(["EKF1", "1x", "a b", "K", "\u00e9"])],
        ["export", str(run_dir), "-o", out], ["evaluate", str(run_dir)], ["evaluate", str(cfg)],
        ["evaluate", str(run_dir), "--params", str(cfg)], ["evaluate", str(run_dir), "--data", str(cfg)],
        ["cv", str(cfg), "-q", "--dir", out], ["cv", str(run_dir), "-q"],
        ["cv", str(cfg), "--k", str(rng.choice([0, 1, 2, -1])), "-q", "--dir", out],
        ["cv", str(cfg), "--budget-fraction", str(rng.choice([0, 2, 0.5, "x"])), "-q", "--dir", out],
        ["sweep", str(sweep), "--dir", str(sweep_dir), "-q"],
        ["sweep", str(sweep), "--dir", str(box / "work" / "sw2"), "--jobs", str(rng.choice([0, -2, 1, 3])), "-q"],
        ["describe", rng.choice(["ekf", "pso", "nope", "", "\u202e"])], ["bogus"], [], ["--version"],
    ]
    return rng.choice(choices)


def _snapshot(root: Path, allowed: tuple[str, ...]) -> dict[str, float]:
    out = {}
    for p in root.rglob("*"):
        rel = p.relative_to(root).as_posix()
        if rel.split("/")[0] in allowed:
            continue
        try:
            out[rel] = p.lstat().st_mtime_ns
        except FileNotFoundError:
            pass
    return out


def _call(argv: list[str], seconds: float | None = None) -> tuple[int, str]:
    """``tuner ARGV`` in this process: (exit status, stderr); stopped as by SIGTERM after ``seconds`` (default
    :data:`RUN_SECONDS`, :data:`READ_SECONDS` for a read-only command)."""
    err, out = io.StringIO(), io.StringIO()
    _Alarm.armed, _Alarm.fired = True, False
    if seconds is None:
        seconds = READ_SECONDS if argv and argv[0] in READ_ONLY else RUN_SECONDS
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse: usage errors (2), --version (0)
                code = exc.code if isinstance(exc.code, int) else 2
    finally:
        _Alarm.armed = False
        signal.setitimer(signal.ITIMER_REAL, 0)
    return code, err.getvalue()


@contextlib.contextmanager
def stop_timer() -> Iterator[None]:
    """The stop timer's handler (:class:`_Alarm`) on SIGALRM for the block; after it, the previous handler and
    no timer left running."""
    old = signal.signal(signal.SIGALRM, _Alarm.handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGALRM, old)
        signal.setitimer(signal.ITIMER_REAL, 0)


def iterations(box: Path, monkeypatch, stream: str = "") -> Iterator[tuple[int, random.Random]]:
    """The fuzzing loop of both tests: ``(i, rng)`` for every iteration ``i`` within the test's half of the budget
    (:data:`BUDGET_S`), or for iteration ``TUNER_FUZZ_ONLY`` alone, ``rng`` drawn from ``SEED``, ``stream`` and
    ``i``; before each, ``box`` is a fresh sandbox (empty ``work`` and ``out`` folders) and the working
    directory. When the budget is spent the count is printed, and at least 8 iterations must have run (unless
    one was replayed)."""
    only = os.environ.get("TUNER_FUZZ_ONLY")
    t0, i = time.monotonic(), 0
    while (time.monotonic() - t0 < BUDGET_S) if only is None else i <= int(only):
        if only is None or i == int(only):
            shutil.rmtree(box, ignore_errors=True)
            (box / "work").mkdir(parents=True)
            (box / "out").mkdir()
            monkeypatch.chdir(box)
            yield i, random.Random(f"{SEED}-{stream}{i}")
        i += 1
    print(f"fuzz {SEED}-{stream}*: {i} iterations in {time.monotonic() - t0:.0f} s")
    assert only is not None or i >= 8, f"only {i} iterations in {BUDGET_S:g} s"  # (a loaded machine)


@pytest.fixture(scope="module")
def materials(tmp_path_factory):
    """A finished run, an interrupted run and a finished two-job sweep, built once and copied per iteration."""
    root = tmp_path_factory.mktemp("fuzzbase")
    (root / "job.yaml").write_text(yaml.safe_dump({**BASE, "output": str(root / "runs")}))
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", str(root / "job.yaml"), "--run-dir", str(root / "run"), "-q"]) == 0
        (root / "sw.yaml").write_text(yaml.safe_dump({"sweep": {"name": "s", "base": "job.yaml", "seeds": [1, 2]}}))
        assert main(["sweep", str(root / "sw.yaml"), "--dir", str(root / "sweep"), "-q"]) == 0
        # import every module the commands use now: a stop landing inside a first import would leave it
        # half-initialised for the rest of this process (a fresh `tuner` process has no such history)
        for argv in (["describe", "ekf"], ["list"], ["report", str(root / "run")], ["export", str(root / "run")],
                     ["evaluate", str(root / "run")], ["cv", str(root / "run"), "-q"], ["show", str(root / "sweep")]):
            try:
                main(argv)
            except SystemExit:
                pass
    return root


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """A temporary directory of the test's own (``tempfile`` and child processes use it): what is left in it
    after a command was left by that command."""
    d = tmp_path / "tmp"
    d.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(d))
    monkeypatch.setenv("TMPDIR", str(d))
    return d


def check_tmp_empty(tmp: Path, what: str) -> None:
    gc.collect()  # an objective dropped by the command removes its FMU extraction when collected
    left = sorted(p.name for p in tmp.iterdir())
    assert not left, f"{what} left files in the temporary directory: {left}"


def test_fuzz_every_subcommand(tmp_path, materials, monkeypatch, private_tmp):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    box = tmp_path / "box"
    seen = {0: 0, 1: 0, 2: 0}
    with stop_timer():
        for i, rng in iterations(box, monkeypatch):
            run_dir = box / "work" / "run"
            shutil.copytree(materials / "run", run_dir, symlinks=True)
            sweep_dir = box / "work" / "sweep"
            shutil.copytree(materials / "sweep", sweep_dir, symlinks=True)
            if rng.random() < 0.6:
                _mutate_run_dir(rng, run_dir if rng.random() < 0.7 else sweep_dir, victim)
            cfg = box / "job.yaml"
            cfg.write_text(_config_text(rng, {**BASE, "output": str(box / "runs")}))
            sweep = box / "sw.yaml"
            sweep.write_text(rng.choice([yaml.safe_dump({"sweep": {"name": "s", "base": "job.yaml",
                                                                   "seeds": [1, rng.choice(VALUES)]}}),
                                         _config_text(rng, {"sweep": {"name": "s", "base": "job.yaml"}}),
                                         rng.choice(TEXT_BOMBS)]))
            before = _snapshot(box, ("work", "runs", "out"))
            argv = _args(rng, box, run_dir, sweep_dir, cfg, sweep)
            try:
                code, err = _call(argv)
            except BaseException as exc:  # noqa: BLE001 - the point: nothing may escape main
                pytest.fail(f"iteration {i} (TUNER_FUZZ_ONLY={i}): tuner {argv} raised {type(exc).__name__}: {exc}")
            assert code in (0, 1, 2), f"iteration {i}: tuner {argv} exited {code}: {err[-2000:]}"
            assert not (_Alarm.fired and argv and argv[0] in READ_ONLY), \
                f"iteration {i}: tuner {argv} did not end within {READ_SECONDS} s (blocked?):\n{err[-2000:]}"
            assert "Traceback" not in err, f"iteration {i}: tuner {argv} printed a traceback:\n{err[-4000:]}"
            if code == 2 and argv:  # (no command at all prints the help and exits 2)
                last = err.rstrip().splitlines()[-1] if err.strip() else ""
                assert last.startswith("error: ") or (last.startswith("tuner") and ": error: " in last), \
                    f"iteration {i}: tuner {argv}: exit 2 without an error line:\n{err[-2000:]}"
            assert victim.read_text() == "keep me\n", f"iteration {i}: tuner {argv} wrote through a link"
            after = _snapshot(box, ("work", "runs", "out"))
            new = sorted(set(after) - set(before) - {"sw.yaml", "job.yaml"})
            assert not new, f"iteration {i}: tuner {argv} wrote outside its folders: {new}"
            assert sorted(p.name for p in tmp_path.iterdir()) == ["box", "tmp", "victim.txt"], \
                f"iteration {i}: tuner {argv} wrote beside the sandbox"
            check_tmp_empty(private_tmp, f"iteration {i}: tuner {argv}")
            seen[code] += 1
    print(f"fuzz: exits {seen}")
