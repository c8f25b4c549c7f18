"""The commands package: a command imports its module only when it runs (``show``, ``list``, ``describe`` and
``--help`` stay light), and another package adds a command through the entry-point group ``tuner.commands``."""

import json
import subprocess
import sys
import textwrap

import pytest
import yaml

from tests.conftest import one_error_line, run_tuner
from tuner.commands import ENGINE, engine_command

HEAVY = ("pandas", "matplotlib", "numba", "scipy")


def _imported(args, cwd):
    """The exit status and the HEAVY modules a fresh interpreter holds after ``tuner.cli.main(args)``."""
    prog = textwrap.dedent(f"""
        import contextlib, io, json, sys
        from tuner.cli import main
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            try:
                code = main({list(args)!r})
            except SystemExit as exc:
                code = exc.code
        print(json.dumps([code, [m for m in {HEAVY!r} if m in sys.modules]]))
    """)
    out = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, cwd=cwd, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("cmd")
    cfg = {"name": "c", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "random", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    (d / "job.yaml").write_text(yaml.safe_dump(cfg))
    out = run_tuner("run", "job.yaml", "-q", "--no-report", "--run-dir", "run", cwd=d)
    assert out.returncode == 0, out.stderr
    return d / "run"


@pytest.mark.slow
@pytest.mark.parametrize("args, allowed", [
    (["--help"], ()), (["show", "run"], ()), (["show", "run", "--json"], ()), (["list", "optimizers"], ()),
    # these load the objective kinds for their catalogs and descriptions: the domain's kernels import numba
    (["list"], ("numba", "scipy")), (["describe", "pso"], ("numba", "scipy")),
    (["describe", "madgwick"], ("numba", "scipy"))])
def test_light_commands_import_no_pandas_nor_matplotlib(small_run, args, allowed):
    code, heavy = _imported(args, small_run.parent)
    assert code == 0 and set(heavy) <= set(allowed), (args, heavy, code)


def test_a_command_imports_its_module_only_when_it_runs():
    prog = textwrap.dedent("""
        import contextlib, io, sys
        from tuner.cli import main
        with contextlib.redirect_stdout(io.StringIO()):
            main(["list", "optimizers"])
        print(sorted(m for m in sys.modules if m.startswith("tuner.commands.")))
    """)
    out = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["['tuner.commands.common',", "'tuner.commands.listing']"], out


def test_every_engine_command_module_has_arguments_and_run():
    for name in ENGINE:
        mod = engine_command(name)
        assert callable(mod.add_arguments) and callable(mod.run), name


_TOY = '''
"""A command another package adds: `tuner toy`."""
import argparse

name = "toy"
help = "print a greeting (a command from outside the engine)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("who")
    parser.add_argument("--times", type=int, default=1)


def run(args: argparse.Namespace) -> int:
    if args.who == "nobody":
        from tuner.commands.common import UsageError
        raise UsageError("toy: nobody: expected a name")
    print(" ".join([f"hello {args.who}"] * args.times))
    return 3
'''


def _install(tmp_path, monkeypatch, entries, module_text=_TOY, module="toycmd"):
    """A distribution ``toy-commands`` on ``sys.path`` whose entry points add ``entries`` to ``tuner.commands``."""
    (tmp_path / f"{module}.py").write_text(module_text)
    info = tmp_path / "toy_commands-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-commands\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[tuner.commands]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()))
    monkeypatch.syspath_prepend(str(tmp_path))


def test_a_command_registered_through_the_entry_point_group_runs(tmp_path, monkeypatch):
    _install(tmp_path, monkeypatch, {"toy": "toycmd"})
    out = run_tuner("toy", "world", "--times", "2")
    assert (out.returncode, out.stdout) == (3, "hello world hello world\n"), out.stderr
    listed = run_tuner("--help").stdout  # named with its package, not imported (its import may be heavy)
    assert "toy" in listed and "a command of toy-commands: tuner toy --help" in listed
    assert "print a greeting" in run_tuner("toy", "--help").stdout
    assert "--times" in run_tuner("toy", "--help").stdout
    one_error_line(run_tuner("toy", "nobody"), "toy: nobody: expected a name")
    assert run_tuner("toy").returncode == 2  # argparse: the argument is missing


def test_an_added_command_never_replaces_an_engine_command(tmp_path, monkeypatch):
    _install(tmp_path, monkeypatch, {"show": "toycmd", "toy": "toycmd"})
    out = run_tuner("show", "world")
    assert out.returncode == 2 and "not a run or sweep directory" in out.stderr


@pytest.mark.parametrize("value, expected", [
    ("no_such_module_xyz", ["command 'toy'", "toy-commands (no_such_module_xyz)", "does not load",
                            "ModuleNotFoundError"]),
    ("toycmd:help", ["command 'toy'", "is not a command: no name, help, add_arguments, run"]),
])
def test_an_added_command_that_does_not_load_is_one_error_line(tmp_path, monkeypatch, value, expected):
    _install(tmp_path, monkeypatch, {"toy": value})
    one_error_line(run_tuner("toy", "world"), *expected)
    assert run_tuner("--help").returncode == 0  # --help names added commands without loading them
    assert run_tuner("show", "--help").returncode == 0  # an engine command never reads the group


def test_an_added_command_must_call_itself_by_its_entry_point_name(tmp_path, monkeypatch):
    _install(tmp_path, monkeypatch, {"greet": "toycmd"})
    one_error_line(run_tuner("greet", "world"), "command 'greet'", "calls itself 'toy'")


def test_the_export_format_of_the_tuned_system_is_named_without_a_domain_noun(small_run):
    help_text = run_tuner("export", "--help").stdout
    assert "c-source" in help_text and "c-filter" in help_text  # the old name stays accepted
    for fmt in ("c-source", "c-filter"):  # the sphere function has no C export: the same error under both names
        one_error_line(run_tuner("export", str(small_run), "--format", fmt, "--out", str(small_run / "c")),
                       "config.yaml", "objective", "this objective has no C export (hook export_c)")
    assert json.loads(run_tuner("export", str(small_run), "--format", "json").stdout)["params"]
