"""An FMU file is untrusted data (objectives/control/plants/fmu_archive.py): a file that is not a zip, an XML
entity bomb, too many entries, a zip bomb, entries that leave the folder and a modelIdentifier that is not an
identifier are each one `error:` line; extraction folders are removed in every process, workers included, also
after Ctrl-C; and the FMU a handed-over run names is loaded by no read-only command and by no command from inside
the run directory. Skipped without fmpy or a C compiler (the real FMU is built from C, configs/examples/fmu/)."""

from __future__ import annotations

import gc
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import pytest
import yaml

from tests.conftest import run_tuner

pytest.importorskip("fmpy", reason="FMU plants need the optional extra fmpy (pip install -e '.[fmu]')")
if shutil.which("cc") is None and shutil.which("gcc") is None:
    pytest.skip("no C compiler to build the test FMU", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
EX = ROOT / "configs" / "examples" / "fmu"


def _mine() -> set[str]:
    """This process's extraction folders in the temporary directory."""
    return {p.name for p in Path(tempfile.gettempdir()).glob(f"tuner-fmu-{os.getpid()}-*")}


@pytest.fixture(scope="module")
def fmu(tmp_path_factory) -> Path:
    spec = importlib.util.spec_from_file_location("build_fmu", EX / "build_fmu.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.build(tmp_path_factory.mktemp("fmu"))


def _job(d: Path, fmu_name: str = "plant.fmu", **over) -> Path:
    raw = {"name": "f", "seed": 1, "objective": {
        "kind": "closed_loop", "plant": {"fmu": fmu_name, "inputs": ["u"], "outputs": ["y"],
                                         "parameters": {"K": 2.0, "T": 0.5}},
        "controller": "pid2dof", "period_s": 0.05, "fixed": {"Td_s": 0.0},
        "scenario": {"duration_s": 1.0, "reference": [{"t": 0.1, "value": 1.0}]}},
        "optimizer": {"method": "pso", "population": 2, "generations": 2}, "parallel": {"backend": "serial"},
        "output": str(d / "runs")}
    raw.update(over)
    p = d / "job.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


def one_error(out, *fragments):
    assert out.returncode == 2 and "Traceback" not in out.stderr, (out.returncode, out.stderr)
    lines = [ln for ln in out.stderr.strip().splitlines() if not ln.startswith("note:")]
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    for f in fragments:
        assert f in lines[0], (f, lines[0])


def _rezip(src: Path, dst: Path, edit) -> Path:
    """``src`` rewritten entry by entry through ``edit(name, data) -> [(name, data), ...]``."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            for name, data in edit(info.filename, zin.read(info)):
                zout.writestr(name, data)
    return dst


BOMB = (b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
        + b"".join(b'<!ENTITY lol%d "%s">' % (i, b"".join(b"&lol%s;" % (str(i - 1).encode() if i > 1 else b"")
                                                                for _ in range(10))) for i in range(1, 10))
        + b"]>\n<fmiModelDescription fmiVersion=\"2.0\" modelName=\"&lol9;\" guid=\"x\"/>\n")


@pytest.mark.parametrize("case, expected", [
    ("not_a_zip", "not an FMU: not a zip archive"),
    ("entity_bomb", "declares a document type or entities"),
    ("outside", "would be unpacked outside its folder"),
    ("symlink", "is a symbolic link"),
    ("identifier", "is not a C identifier"),
    ("no_description", "no modelDescription.xml"),
])
def test_a_hostile_fmu_file_is_one_error_line(fmu, tmp_path, case, expected):
    bad = tmp_path / "plant.fmu"
    if case == "not_a_zip":
        bad.write_bytes(b"MZ this is not a zip archive" * 100)
    elif case == "entity_bomb":
        _rezip(fmu, bad, lambda n, d: [(n, BOMB if n == "modelDescription.xml" else d)])
    elif case == "outside":
        _rezip(fmu, bad, lambda n, d: [(n, d)] + ([("../../evil.so", d)] if n.endswith(".so") else []))
    elif case == "symlink":
        shutil.copy(fmu, bad)
        with zipfile.ZipFile(bad, "a") as z:
            info = zipfile.ZipInfo("resources/link")
            info.external_attr = 0o120777 << 16
            z.writestr(info, "/etc/passwd")
    elif case == "identifier":
        _rezip(fmu, bad, lambda n, d: [(n, d.replace(b'modelIdentifier="first_order"',
                                                     b'modelIdentifier="../../../tmp/x"')
                                       if n == "modelDescription.xml" else d)])
    else:
        _rezip(fmu, bad, lambda n, d: [] if n == "modelDescription.xml" else [(n, d)])
    before = _mine()
    one_error(run_tuner("run", _job(tmp_path), "-q"), "objective.plant.fmu", expected)
    assert _mine() == before


def test_entry_count_and_unpacked_size_are_capped(fmu, tmp_path, monkeypatch):
    from objectives.control.plants import fmu_archive

    many = _rezip(fmu, tmp_path / "plant.fmu", lambda n, d: [(n, d)] + [(f"resources/{i}", b"") for i in range(40)]
                  if n == "modelDescription.xml" else [(n, d)])
    monkeypatch.setattr(fmu_archive, "MAX_ENTRIES", 30)
    one_error(run_tuner("run", _job(tmp_path), "-q"), "entries; at most 30 are unpacked")
    monkeypatch.undo()
    many.unlink()
    _rezip(fmu, many, lambda n, d: [(n, d)] + [("resources/zeros", bytes(3 * 2**20))] if n.endswith(".so")
           else [(n, d)])  # 3 MB of zeros packed to a few kB: a small zip bomb
    monkeypatch.setattr(fmu_archive, "MAX_UNPACKED_BYTES", 2**20)
    before = _mine()
    one_error(run_tuner("run", _job(tmp_path), "-q"), "unpacks to more than 1 MB")
    assert _mine() == before


@pytest.mark.slow
def test_extraction_folders_are_removed_with_the_plant_and_stale_ones_swept(fmu, tmp_path):
    from objectives.control.objective import ClosedLoopObjective

    shutil.copy(fmu, tmp_path / "plant.fmu")
    stale = Path(tempfile.mkdtemp(prefix="tuner-fmu-999999999-"))  # a killed process's (no such pid)
    section = yaml.safe_load(_job(tmp_path).read_text())["objective"]
    before = _mine()
    o = ClosedLoopObjective.from_config(section, tmp_path)
    assert len(_mine() - before) == 1 and not stale.exists()
    assert o({"K": 1.0, "Ti_s": 0.5}).status == "ok"
    del o
    gc.collect()
    assert _mine() == before


@pytest.mark.slow
def test_a_loky_run_leaves_no_extraction_folder_in_any_process(fmu, tmp_path):
    shutil.copy(fmu, tmp_path / "plant.fmu")
    job = _job(tmp_path, parallel={"backend": "loky", "n_jobs": 2})
    left = set(Path(tempfile.gettempdir()).glob("tuner-fmu-*"))
    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(job), "-q", "--no-report"], capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert set(Path(tempfile.gettempdir()).glob("tuner-fmu-*")) <= left  # the 9 folders of one loky run


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["serial", "loky"])
def test_ctrl_c_leaves_no_extraction_folder(fmu, tmp_path, backend):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) during a run, on its own process or with
    loky workers that each unpacked the FMU: no extraction folder is left in the temporary directory."""
    shutil.copy(fmu, tmp_path / "plant.fmu")
    job = _job(tmp_path, optimizer={"method": "pso", "population": 4, "generations": 10_000},
               parallel={"backend": backend, "n_jobs": 2})
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    p = subprocess.Popen([sys.executable, "-m", "tuner", "run", str(job), "--run-dir", str(tmp_path / "r"), "-q",
                          "--no-report"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "TMPDIR": str(tmp)}, start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:  # until the run is past its first generation (the FMU is extracted)
        try:
            if json.loads((tmp_path / "r" / "meta.json").read_text()).get("generations", 0) >= 1:
                break
        except (OSError, ValueError):
            pass
        time.sleep(0.2)
    time.sleep(1.0)  # the workers' first chunks unpacked their copies
    assert list(tmp.glob("tuner-fmu-*")), "no extraction folder while running"
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 1 and "Traceback" not in err, err
    time.sleep(0.5)
    assert not list(tmp.glob("tuner-fmu-*"))


def test_the_fmu_of_a_handed_over_run_is_loaded_by_no_read_only_command(fmu, tmp_path):
    shutil.copy(fmu, tmp_path / "plant.fmu")
    out = run_tuner("run", _job(tmp_path), "--run-dir", tmp_path / "run", "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    d = tmp_path / "handed"
    shutil.copytree(tmp_path / "run", d)
    shutil.copy(fmu, d / "plant.fmu")  # the FMU shipped inside the run, its config pointing there
    cfg = yaml.safe_load((d / "config.yaml").read_text())
    cfg["base_dir"] = str(d)
    (d / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    before = _mine()
    for cmd in (["show", d], ["report", d], ["compare", d, d], ["export", d], ["export", d, "--format", "c"],
                ["dashboard", tmp_path]):
        res = run_tuner(*cmd)
        assert res.returncode == 0 and "Traceback" not in res.stderr, (cmd, res.stderr)
        assert _mine() == before, f"`tuner {cmd[0]}` unpacked the run's FMU"
    assert "C_DEN" in run_tuner("export", d, "--format", "c").stdout  # the tables the run recorded
    one_error(run_tuner("evaluate", d), "objective.plant.fmu", "inside the run directory")
    assert _mine() == before

