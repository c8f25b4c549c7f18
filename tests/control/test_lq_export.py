"""LQR/LQG export: the gain K and the tracking matrices Nx, Nu (eq. 2.15) that firmware runs, in the C
header (compiled with cc -std=c99 -Wall -Werror) and in YAML, JSON and Python, equal to lq_design's."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.wmp.controllers.lqr import lq_design, reduced_model
from tuner.export import export
from tuner.export_formats import json_load

MATRICES = {"K": (2, 4), "Nx": (4, 2), "Nu": (2, 2), "Fr": (2, 2)}


@pytest.fixture(scope="module", params=["lqr", "lqg"])
def lq_run(request, tmp_path_factory):
    from tuner.config import config_from_dict
    from tuner.run import run

    tmp = tmp_path_factory.mktemp(request.param)
    raw = {"name": f"{request.param}-export", "seed": 2,
           "objective": {"kind": "closed_loop", "controller": request.param, "profile": "thesis_2s",
                         "duration_s": 3.0, "requirements": None},
           "optimizer": {"method": "pso", "population": 4, "generations": 1}, "parallel": {"backend": "serial"}}
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "r", quiet=True, report=False).run_dir


def _reference(run_dir):
    """lq_design of the run's best weights, computed here from the plant and the controller period."""
    best = yaml.safe_load((run_dir / "best.yaml").read_text())["params"]
    obj = ClosedLoopObjective(controller="lqr", duration_s=3.0)
    q = [best["q_theta3"], best["q_nu"], best["q_omega3"], best["q_xi"]]
    plant = obj.loop.plant
    return lq_design(q, [best["r_u1"], best["r_u2"]], plant.sensors.Ts_s, plant.params, reduced_model(plant.params))


def test_yaml_json_python_carry_k_nx_nu(lq_run, tmp_path):
    des = _reference(lq_run)
    docs = {"yaml": yaml.safe_load(export(lq_run, "yaml")), "json": json_load(export(lq_run, "json"))}
    json.loads(export(lq_run, "json"))  # strict
    (tmp_path / "lq_tuned.py").write_text(export(lq_run, "python"))
    out = subprocess.run([sys.executable, "-c", "import json, lq_tuned as t; print(json.dumps(t.TABLES))"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    docs["python"] = {"tables": json.loads(out.stdout)}
    for fmt, doc in docs.items():
        for name, shape in MATRICES.items():
            got = np.asarray(doc["tables"][name]["table"], float)
            assert got.shape == shape, (fmt, name)
            np.testing.assert_array_equal(got, getattr(des, name), err_msg=f"{fmt} {name}")
    np.testing.assert_allclose(des.Fr, des.Nu + des.K @ des.Nx, rtol=1e-12)  # the exported feed-forward


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_holds_lq_design_values(lq_run, tmp_path):
    des = _reference(lq_run)
    (tmp_path / "lq.h").write_text(export(lq_run, "c", prefix="LQ"))
    loops = "".join(  # identifiers are upper case: LQ_K, LQ_NX, LQ_NU, LQ_FR
        f"for (int i = 0; i < LQ_{n}_NY; i++) for (int j = 0; j < LQ_{n}_NX; j++) "
        f'printf("%.17g\\n", LQ_{n}[i][j]);' for n in map(str.upper, MATRICES))
    (tmp_path / "main.c").write_text(f'#include <stdio.h>\n#include "lq.h"\nint main(void) {{ {loops} return 0; }}\n')
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", "main", "main.c"], capture_output=True,
                        text=True, cwd=tmp_path)
    assert cc.returncode == 0, cc.stderr
    vals = [float(x) for x in subprocess.run([str(tmp_path / "main")], capture_output=True, text=True).stdout.split()]
    want = np.concatenate([getattr(des, n).ravel() for n in MATRICES])
    np.testing.assert_array_equal(np.array(vals), want)   # %.17g round-trips doubles exactly
    header = (tmp_path / "lq.h").read_text()
    assert "matrix K (2 x 4, row-major)" in header and "eq. 2.15" in header
