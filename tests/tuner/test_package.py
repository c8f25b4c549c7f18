"""The installable package: packaged example jobs, `tuner init`, `tuner demo`, and (slow) the wheel built,
installed into a fresh virtualenv and run from outside the clone."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tuner.cli import main as cli_main
from tuner.config import config_from_dict
from tuner.starter import packaged_config, packaged_configs, starter_names, starter_text, write_starter

ROOT = Path(__file__).resolve().parents[2]
PACKAGED = ROOT / "tuner" / "data" / "configs"


def test_packaged_jobs_are_the_repository_jobs_that_need_no_shared_data():
    repo = {p.name for p in (ROOT / "configs").glob("*.yaml")}
    shipped = set(packaged_configs())
    needs_data = {n for n in repo if "broad:" in (ROOT / "configs" / n).read_text()}
    assert needs_data and shipped == repo - needs_data, "run `make package-configs`"
    for name in shipped:  # copies, kept equal
        assert (PACKAGED / name).read_bytes() == (ROOT / "configs" / name).read_bytes(), \
            f"tuner/data/configs/{name} differs from configs/{name}: run `make package-configs`"
        assert "../shared" not in (PACKAGED / name).read_text()
    # a sweep's base files ship beside it
    for name in ("demo.yaml", "thesis_tilt_sweep.yaml", "wmp_compare.yaml"):
        sw = yaml.safe_load((PACKAGED / name).read_text())["sweep"]
        bases = [sw["base"]] + [v["base"] for v in sw["variants"].values() if "base" in v]
        assert all((PACKAGED / b).is_file() for b in bases)
    assert packaged_config("demo.yaml") == PACKAGED / "demo.yaml"


@pytest.mark.slow
def test_every_filter_and_controller_gets_a_starter_that_builds_and_preflights(tmp_path, monkeypatch):
    """Each starter job is valid YAML, a valid config, names only parameters its objective has, and its
    default parameters evaluate (the preflight that `tuner run` does before the first generation)."""
    from tuner.run import _build, new_optimizer

    names = starter_names()
    assert {"madgwick", "ekf", "kf1d", "vqf", "pid", "lqr", "protective_fuzzy"} <= set(names)
    monkeypatch.chdir(tmp_path)
    from objectives.control.controllers import controllers_of

    on_mujoco = set(controllers_of("mujoco"))
    for name in sorted(names):
        if name == "vqf":
            pytest.importorskip("vqf", reason="vqf is an optional extra")
        if name in on_mujoco:  # its starter names the repository's example model, copied beside the job
            pytest.importorskip("mujoco", reason="mujoco is an optional extra")
            if not (tmp_path / "mujoco").exists():
                shutil.copytree(Path(__file__).resolve().parents[2] / "configs" / "examples" / "mujoco",
                                tmp_path / "mujoco")
        text = starter_text(name)
        raw = yaml.safe_load(text)
        assert text.startswith("# Starter job") and raw["name"] == name
        assert raw["objective"].get("filter", raw["objective"].get("controller")) == name
        short = {"synthetic": {"generator": "tilt1d" if name.endswith("1d") else "bench6dof", "duration_s": 5.0,
                               "rate_hz": 100, "seed": 1}}  # the starter's data, shorter: the test stays fast
        if "data" in raw["objective"]:
            assert raw["objective"]["data"]["train"][0]["synthetic"]["generator"] == short["synthetic"]["generator"]
            raw["objective"]["data"] = {"train": [short], "test": [short]}
        cfg = config_from_dict(raw, source=f"{name}.yaml", base_dir=tmp_path)
        objective, space = _build(cfg)
        assert new_optimizer(cfg, 0, space, None).population >= 1  # `auto` accepts the budget
        declared = set(objective.parameter_names())
        assert set(space.names) <= declared and space.free_names, name
        commented = [ln.split(":")[0].strip("# ") for ln in text.splitlines() if ln.startswith("    # ")]
        assert set(commented) <= declared and not set(commented) & set(space.free_names), name


def test_init_writes_a_starter_and_refuses_unknown_names_and_overwriting(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli_main(["init", "madgwick"]) == 0
    text = (tmp_path / "madgwick.yaml").read_text()
    assert text == starter_text("madgwick") and "beta: {low: 0.001, high: 1.0, scale: log}" in text
    assert cli_main(["init", "madgwick"]) == 2
    err = capsys.readouterr().err
    assert "error: madgwick.yaml: exists; not overwritten" in err
    assert (tmp_path / "madgwick.yaml").read_text() == text
    assert cli_main(["init", "pid", "-o", "ctl.yaml"]) == 0 and (tmp_path / "ctl.yaml").is_file()
    assert cli_main(["init", "madgwik"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: init: unknown filter or controller 'madgwik'; did you mean 'madgwick'")
    assert not (tmp_path / "madgwik.yaml").exists()


@pytest.mark.parametrize("name", ["madgwick", "pid", "pid2dof"])
def test_uncommenting_a_fixed_value_in_a_starter_keeps_it_valid(tmp_path, name):
    """`fixed: {}` followed by indented commented values gave a YAML error once a line was uncommented."""
    from tuner.config import load_config

    path = write_starter(name, tmp_path / "job.yaml")
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("  fixed:"))
    first = start + 1  # the first value of the block, commented out
    lines[first] = lines[first].replace("# ", "", 1)
    key = lines[first].split(":")[0].strip()
    path.write_text("\n".join(lines) + "\n")
    raw = yaml.safe_load(path.read_text())
    assert key in raw["objective"]["fixed"]
    load_config(path)  # a valid job
    assert f"`tuner run {path}`" in lines[1] or f"`tuner run {path}`" in lines[2]  # the header names this file


def test_demo_lists_and_refuses_unknown_jobs(capsys):
    assert cli_main(["demo", "--list"]) == 0
    out = capsys.readouterr().out
    assert "demo" in out and "thesis_kf1d" in out and "broad" not in out
    assert cli_main(["demo", "nope"]) == 2
    assert "error: nope.yaml: not a packaged job" in capsys.readouterr().err


def test_installed_package_records_no_git_commit_of_a_surrounding_repository(tmp_path, monkeypatch):
    import tuner.run as run_mod

    monkeypatch.setattr(run_mod, "__file__", str(tmp_path / "site-packages" / "tuner" / "run.py"))
    assert run_mod._git_commit() == ""


#: python -m build without its second isolated environment: one environment builds the sdist from the clone,
#: then the wheel from the unpacked sdist (a file missing from the sdist is missing from the wheel)
_BUILD = """
import sys, tarfile, tempfile
from pathlib import Path
from build import ProjectBuilder
from build.env import DefaultIsolatedEnv

src, out = sys.argv[1:]
with DefaultIsolatedEnv() as env:
    builder = ProjectBuilder.from_isolated_env(env, src)
    env.install(builder.build_system_requires)
    env.install(builder.get_requires_for_build("sdist"))
    sdist = Path(builder.build("sdist", out))
    with tempfile.TemporaryDirectory() as tmp:
        with tarfile.open(sdist) as tar:  # the extraction filter is in 3.11.4 and later
            tar.extractall(tmp, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
        builder = ProjectBuilder.from_isolated_env(env, Path(tmp) / sdist.name.removesuffix(".tar.gz"))
        env.install(builder.get_requires_for_build("wheel"))
        builder.build("wheel", out)
"""


def _dependency_view(wheel: Path, dest: Path) -> Path:
    """A folder of links to what installing ``wheel`` would download: its declared dependencies (and
    theirs, extras followed) and pip, taken from the running interpreter's site-packages.

    Nothing else is linked -- not this clone's own install (metadata, editable hook), not the dev tools --
    so the virtualenv sees what a fresh one would after ``pip install wheel``, and an import the wheel does
    not declare still fails there.
    """
    import sysconfig
    import zipfile
    from email.parser import Parser
    from importlib.metadata import distributions

    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    site = list(dict.fromkeys(sysconfig.get_paths()[k] for k in ("purelib", "platlib")))
    installed: dict = {}
    for dist in distributions(path=site):
        if dist.metadata["Name"]:
            installed.setdefault(canonicalize_name(dist.metadata["Name"]), dist)
    with zipfile.ZipFile(wheel) as zf:
        meta = next(n for n in zf.namelist() if n.endswith(".dist-info/METADATA"))
        todo = [Requirement(r) for r in Parser().parsestr(zf.read(meta).decode()).get_all("Requires-Dist") or []]
    todo = [r for r in todo if r.marker is None or r.marker.evaluate({"extra": ""})] + [Requirement("pip")]
    dest.mkdir()
    seen: set = set()
    while todo:
        req = todo.pop()
        name = canonicalize_name(req.name)
        if (name, *sorted(req.extras)) in seen or name not in installed:  # not here: pip downloads it
            continue
        seen.add((name, *sorted(req.extras)))
        dist = installed[name]
        for r in map(Requirement, dist.requires or []):
            if r.marker is None or any(r.marker.evaluate({"extra": e}) for e in ("", *req.extras)):
                todo.append(r)
        assert dist.files is not None, f"{name}: no RECORD, cannot tell its files"
        for top in {f.parts[0] for f in dist.files} - {"..", "__pycache__"}:
            if not top.endswith(".pth") and not (dest / top).exists():
                (dest / top).symlink_to(dist.locate_file(top))
    return dest


@pytest.mark.slow
def test_wheel_installs_and_runs_in_a_fresh_virtualenv(tmp_path):
    """sdist, then the wheel from it (as python -m build does); the wheel into a virtualenv without this
    clone on its path; then `tuner --version`, `tuner describe madgwick`, `tuner init` and a short synthetic
    run, all from a directory outside the clone.

    The virtualenv reads the wheel's dependencies from links to the test environment's copies
    (:func:`_dependency_view`, through a plain path line in a ``.pth`` file: the linked folder's own ``.pth``
    files are not processed) instead of downloading and installing them again; pip still resolves the
    wheel's declared dependencies against them, and ``pip check`` finds none missing or conflicting.
    """
    pytest.importorskip("build", reason="`build` is in the dev extra")
    dist = tmp_path / "dist"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    built = subprocess.run([sys.executable, "-c", _BUILD, str(ROOT), str(dist)], check=True, env=env,
                           capture_output=True, text=True, timeout=600)
    assert "Warning" not in built.stderr and "deprecated" not in built.stderr, built.stderr  # the metadata is current
    wheels, sdists = list(dist.glob("attitude_tuner-*.whl")), list(dist.glob("attitude_tuner-*.tar.gz"))
    assert len(wheels) == 1 and len(sdists) == 1
    import zipfile

    names = zipfile.ZipFile(wheels[0]).namelist()
    assert "tuner/data/configs/demo.yaml" in names and "objectives/starters.py" in names
    assert "tuner/static/tuner_report.js" in names  # the interactive report pages
    assert {"tuner/data/configs/examples/own_csv.yaml", "tuner/data/configs/examples/imu_columns.yaml",
            "tuner/data/configs/examples/imu.csv"} <= set(names)  # the README's own-CSV example, whole
    # the C export's shared parts and the filter units' ports
    assert {"objectives/attitude/cexport/templates/common.c", "objectives/attitude/filters/ekf/port.c"} <= set(names)
    assert {f"objectives/control/plants/ctemplates/{n}" for n in ("controller.h", "pid.c", "sf.c", "api.c")} <= \
        set(names)  # the controllers' C export
    assert not any(n.startswith(("tests/", "configs/", "benchmarks/")) for n in names)
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # the linked dependencies are read, never written
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=300)
    bin_dir = venv / "bin"
    site = subprocess.run([str(bin_dir / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          env=env, capture_output=True, text=True, check=True).stdout.strip()
    Path(site, "dependencies.pth").write_text(f"{_dependency_view(wheels[0], tmp_path / 'deps')}\n")
    for pip in (["install", "--quiet", str(wheels[0])], ["check"]):  # pip is among the links
        subprocess.run([str(bin_dir / "python"), "-m", "pip", *pip], check=True, env=env, timeout=900)
    work = tmp_path / "outside"
    work.mkdir()
    env = {**env, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PATH": f"{bin_dir}:{env.get('PATH', '')}"}

    def tuner_cmd(*args: str) -> str:
        out = subprocess.run([str(bin_dir / "tuner"), *args], cwd=work, env=env, capture_output=True, text=True,
                             timeout=600)
        assert out.returncode == 0, (args, out.stdout, out.stderr)
        return out.stdout

    where = subprocess.run([str(bin_dir / "python"), "-c", "import tuner, objectives; print(tuner.__file__); "
                            "print(objectives.__file__)"], cwd=work, env=env, capture_output=True, text=True,
                           check=True).stdout.split()
    assert all(Path(w).is_relative_to(venv) for w in where), where
    from tuner import __version__

    assert tuner_cmd("--version").strip() == f"tuner {__version__}"
    assert "beta" in tuner_cmd("describe", "madgwick")
    assert "thesis_kf1d" in tuner_cmd("demo", "--list")
    tuner_cmd("init", "madgwick")
    short = "[{synthetic: {generator: bench6dof, duration_s: 6, rate_hz: 100, seed: 1}}]"
    out = tuner_cmd("run", "madgwick.yaml", "-q", "--set", "optimizer.max_evals=8", "--set", "parallel.backend=serial",
                    "--set", f"objective.data.train={short}", "--set", f"objective.data.test={short}")
    assert "status: finished" in out
    run_dirs = list((work / "runs").iterdir())
    assert len(run_dirs) == 1 and (run_dirs[0] / "history.csv").is_file()
    meta = yaml.safe_load((run_dirs[0] / "meta.json").read_text())
    assert meta["git_commit"] == ""  # not the commit of a repository the venv happens to sit in
    shutil.rmtree(venv)


def test_the_license_is_an_spdx_expression():
    """`project.license` as a table made `make setup` print about 130 lines of setuptools deprecation warnings
    before anything else; PEP 639's SPDX string needs setuptools 77."""
    import tomllib

    doc = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert doc["project"]["license"] == "MIT"
    assert any(r.replace(" ", "").startswith("setuptools>=77") for r in doc["build-system"]["requires"])


def test_default_broad_dir_is_not_read_relative_to_an_installed_package(tmp_path, monkeypatch):
    import objectives.attitude.data.broad as broad

    assert broad.default_broad_dir() == ROOT.parent / "shared" / "data" / "broad"  # a clone: beside it
    site = tmp_path / "venv" / "lib" / "python3" / "site-packages"
    monkeypatch.setattr(broad, "__file__", str(site / "objectives" / "attitude" / "data" / "broad.py"))
    monkeypatch.chdir(tmp_path)
    assert broad.default_broad_dir() == tmp_path.parent / "shared" / "data" / "broad"


def test_demo_list_names_the_own_csv_example_and_it_builds(tmp_path):
    """The README's own-CSV example ships whole (job, column map, recording, copies of configs/examples/),
    ``tuner demo --list`` names it with its column map, and the packaged job builds and preflights."""
    from tests.conftest import run_tuner
    from tuner.config import load_config
    from tuner.setup import build

    for name in ("own_csv.yaml", "imu_columns.yaml", "imu.csv"):
        assert (PACKAGED / "examples" / name).read_bytes() == (ROOT / "configs" / "examples" / name).read_bytes(), \
            f"tuner/data/configs/examples/{name} differs from configs/examples/{name}: run `make package-configs`"
    out = run_tuner("demo", "--list")
    assert out.returncode == 0
    line = next(x for x in out.stdout.splitlines() if x.startswith("your own CSV: own_csv"))
    assert str(PACKAGED / "examples" / "imu_columns.yaml") in line
    assert packaged_config("own_csv.yaml") == PACKAGED / "examples" / "own_csv.yaml"
    objective, space = build(load_config(packaged_config("own_csv.yaml")))
    assert objective.preflight() is not None and "beta" in space


def test_init_without_a_name_lists_the_starters():
    from tests.conftest import run_tuner

    out = run_tuner("init")
    assert out.returncode == 0
    listed = {n.strip() for line in out.stdout.splitlines()[1:] for n in line.split(":", 1)[1].split(",")}
    assert listed == set(starter_names())
