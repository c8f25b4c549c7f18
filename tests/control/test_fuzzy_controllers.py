"""Fuzzy WMP controllers (thesis 2.2.2, 2.3.1, eq. 2.32): kernel vs a literal reference, closed-loop
stability with Table 2.7's initial values, LUT vs direct inference, a short PSO run, the C header."""

import math
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

from objectives.control.controllers import get_controller
from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.wmp.controllers.fuzzy import THESIS_OPTIMISED, LUTFuzzy, ProtectiveFuzzy
from objectives.control.plants.wmp.controllers.fuzzy_steps import _protective_step, lut_nearest
from tests.reference import fuzzy_controller_reference as ref

CONFIG = pathlib.Path(__file__).parents[2] / "configs" / "wmp_fuzzy_protective.yaml"
TUNED = {k: v for k, v in THESIS_OPTIMISED.items() if k != "p13"}


@pytest.fixture(scope="module")
def objectives():
    return {name: ClosedLoopObjective(controller=name, duration_s=10.0) for name in ("flc", "protective_fuzzy", "lut")}


def test_fifteen_tuned_parameters_with_table_2_7_initial_values():
    space = ProtectiveFuzzy.default_space()
    free = [p.name for p in ProtectiveFuzzy.params if not p.is_fixed]
    assert len(free) == 15 and space.dim == 15
    d = ProtectiveFuzzy.defaults
    # Table 2.7, initial column
    assert (d["p11"], d["d11"], d["d12"], d["d13"], d["u11"], d["u12"], d["u13"]) == (0.35, 0.5, 0, 0.5, 3, 1, 1.5)
    assert (d["p21"], d["d21"], d["u2"], d["p31"], d["u3"]) == (15, 220, 0.6, 30, 1.5)
    for p in ProtectiveFuzzy.params:  # bounds hold both columns of Table 2.7
        if not p.is_fixed:
            assert p.low <= d[p.name] <= p.high and p.low <= TUNED[p.name] <= p.high, p.name
    assert get_controller("lut") is LUTFuzzy


@pytest.mark.parametrize("values", [None, TUNED])
@pytest.mark.slow
def test_protective_step_matches_literal_reference(values):
    ctrl = ProtectiveFuzzy()
    v = ctrl.resolve(values)
    p = ctrl.param_array(values)
    rng = np.random.default_rng(3)
    s = np.zeros(ctrl.state_size)
    st_ref = [0.0, 0.0]
    u = np.empty(2)
    for _ in range(300):
        r = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-2, 2)])
        meas = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-8, 8),
                         rng.uniform(-2, 2), rng.uniform(-1.2, 1.2)])  # fmt: skip
        if rng.random() < 0.1:  # exact set edges and zero errors
            meas[0] = r[0] - rng.choice([0.0, v["p11"], -v["p11"]])
        _protective_step(p, s, r, meas, u)
        u_ref = ref.protective_step(v, st_ref, r[0], r[1], meas, 0.01)
        np.testing.assert_allclose(u, u_ref, rtol=1e-12, atol=1e-12)


def test_protective_mechanism_lowers_the_action_as_the_current_grows():
    fis = ProtectiveFuzzy().fis()["flc1"]
    i = np.linspace(0.0, 0.8, 17)
    # at full speed error (P = 1, Z = 0) rules 2 and 5 fire: U_P = (u11 + u12 L) / (1 + L), with
    # L = Gamma(0, 0.5, inf): from u11 = 3 V at no current down to (u11 + u12) / 2 = 2 V (Fig. 2.14)
    lam = np.clip(i / 0.5, 0, 1)
    for e in (0.35, 0.5, -0.4):
        up = np.array([fis(np.array([e, c])) for c in i])
        np.testing.assert_allclose(up, np.sign(e) * (3.0 + 1.0 * lam) / (1.0 + lam), rtol=1e-12)
    # linear PI reading: with uniform triangles and no current, U_P = u11 e / p11 ... only where rule 4
    # (Z and S -> Z) does not fire, i.e. at a current beyond the S foot d11 = 0.5 A
    assert fis(np.array([0.2, 0.9])) == pytest.approx((0.2 / 0.35 * 3.0 + 0.2 / 0.35 * 1.0) / (1 + 0.2 / 0.35))


@pytest.mark.parametrize("name", ["flc", "protective_fuzzy", "lut"])
@pytest.mark.slow
def test_initial_parameters_stabilise_the_plant(objectives, name, record_property):
    obj = objectives[name]
    ev = obj(obj.defaults)
    record_property("F_init", ev.fitness)
    print(f"{name}: F_init = {ev.fitness:.4f}, peak theta3 {ev.metrics['peak_theta3_deg']:.1f} deg, "
          f"peak current {ev.metrics['peak_current_A']:.3f} A")  # fmt: skip
    assert ev.status == "ok" and math.isfinite(ev.fitness) and 0 < ev.fitness < 10
    sim = obj.simulate(obj.defaults)
    y, t = sim["outputs"], sim["t"]
    last = t > 9.0  # reference is 0 m/s, 0 deg/s from 7.5 s on
    assert np.max(np.abs(np.degrees(y[last, 1]))) < 3.0  # IB settled
    assert np.max(np.abs(y[last, 0])) < 0.05  # robot (nearly) stopped
    seg = (t > 2.0) & (t < 2.5)  # end of the 0.4 m/s, 30 deg/s step: the initial PI loops are slow
    assert 0.25 < np.mean(y[seg, 0]) < 0.45  # (Table 2.4: fuzzy settling 1.8 s in simulation)
    assert np.degrees(np.mean(y[seg, 3])) == pytest.approx(30.0, abs=3.0)
    seg = (t > 7.0) & (t < 7.5)  # end of the -0.2 m/s, -70 deg/s step
    assert -0.25 < np.mean(y[seg, 0]) < -0.1
    assert np.degrees(np.mean(y[seg, 3])) == pytest.approx(-70.0, abs=5.0)


def test_thesis_optimised_values_beat_the_initial_ones(objectives):
    obj = objectives["protective_fuzzy"]
    f0, f1 = obj(obj.defaults), obj(TUNED)
    assert f1.fitness < 0.8 * f0.fitness  # thesis: 0.1049 -> 0.0558 (-46.8 %)
    assert f1.metrics["peak_current_A"] < 0.6 * f0.metrics["peak_current_A"]  # thesis: 0.5-0.6 -> 0.2-0.3 A


def test_lut_nearest_is_eq_2_32():
    rng = np.random.default_rng(0)
    t = rng.normal(size=(40, 40))
    xr, yr = np.array([-0.35, 0.35]), np.array([0.0, 0.5])
    for x, y in rng.uniform([-0.5, -0.1], [0.5, 0.7], size=(200, 2)):
        i = int(np.clip(np.round((x - xr[0]) / ((xr[1] - xr[0]) / 39)), 0, 39))
        j = int(np.clip(np.round((y - yr[0]) / ((yr[1] - yr[0]) / 39)), 0, 39))
        assert lut_nearest(t, xr, yr, x, y) == t[i, j]


@pytest.mark.parametrize("values", [None, TUNED])
def test_lut_reproduces_the_direct_controller_within_the_grid_resolution(values):
    ctrl = ProtectiveFuzzy()
    tabs, fis = ctrl.tables(values), ctrl.fis(values)
    rng = np.random.default_rng(1)
    checks = [("lut1_p", fis["flc1"], 2), ("lut2", fis["flc2"], 2)]
    for name, f, _ in checks:
        t = tabs[name]
        tab, (x0, x1), (y0, y1) = t["table"], t["x_range"], t["y_range"]
        assert tab.shape == (40, 40)
        gx, gy = np.linspace(x0, x1, 40), np.linspace(y0, y1, 40)
        for mode in (0, 1):  # nearest (eq. 2.32) and bilinear
            for x, y in rng.uniform([x0 - 0.2 * (x1 - x0), y0], [x1 + 0.2 * (x1 - x0), y1 * 1.2], (300, 2)):
                fn = lut_nearest if mode == 0 else __import__("objectives.fuzzy").fuzzy.lut_interp
                got = fn(tab, np.array([x0, x1]), np.array([y0, y1]), x, y)
                direct = f(np.array([x, y]))
                xc, yc = np.clip(x, x0, x1), np.clip(y, y0, y1)
                i = min(int((xc - x0) / (gx[1] - gx[0])), 38)
                j = min(int((yc - y0) / (gy[1] - gy[0])), 38)
                corners = [f(np.array([gx[a], gy[b]])) for a in (i, i + 1) for b in (j, j + 1)]
                # both lookups return a convex combination of the cell's corners; outside the
                # universes every output is constant, so clamping is exact there
                assert abs(got - direct) <= max(abs(c - direct) for c in corners) + 1e-12
        # exact at the grid nodes
        for a, b in rng.integers(0, 40, (20, 2)):
            assert tab[a, b] == pytest.approx(f(np.array([gx[a], gy[b]])), abs=1e-12)


def test_lut_closed_loop_follows_the_direct_one(objectives):
    f_dir = objectives["protective_fuzzy"](TUNED)
    f_lut = objectives["lut"](TUNED)
    assert f_lut.status == "ok"
    assert f_lut.fitness == pytest.approx(f_dir.fitness, rel=0.1)
    obj_bil = ClosedLoopObjective(controller="lut", duration_s=10.0, fixed={"lut_mode": 1})
    assert obj_bil(TUNED).fitness == pytest.approx(f_dir.fitness, rel=0.03)  # bilinear is closer


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    from tuner.config import load_config
    from tuner.run import run

    cfg = load_config(CONFIG, ["optimizer.population=8", "optimizer.generations=4"], n_jobs=1)
    # no report: the figures read below are the objective's (response, surfaces), written without it
    return run(cfg, tmp_path_factory.mktemp("fz") / "run", quiet=True, report=False)


@pytest.mark.slow
def test_short_pso_run_improves_the_initial_cost(short_run):
    import yaml

    section = yaml.safe_load(CONFIG.read_text())["objective"]  # the config's profile and requirements
    obj = ClosedLoopObjective.from_config(section, CONFIG.parent)
    f_init = obj(obj.defaults).fitness
    assert short_run.n_evals == 32
    assert short_run.best_fitness < f_init
    ev = short_run.extra
    assert ev["initial_fitness"] == pytest.approx(f_init)
    assert ev["improvement_pct"] == pytest.approx(100 * (f_init - short_run.best_fitness) / f_init)
    figs = sorted(p.name for p in (short_run.run_dir / "figures").glob("*.png"))
    assert {"response.png", "surface_flc1.png", "surface_flc2.png"} <= set(figs)


def test_c_header_with_tables_compiles_and_holds_the_python_values(short_run, tmp_path):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    from tuner.export import export

    header = export(short_run.run_dir, "c", prefix="TUNER")
    (tmp_path / "tuned.h").write_text(header)
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "tuned.h"\n'
        "int main(void) {\n"
        '  printf("%.17g %.17g %.17g %d %d\\n", TUNER_LUT2[7][31], TUNER_LUT1_P[20][3], TUNER_LUT2_X_MAX,\n'
        "         TUNER_LUT2_NX, TUNER_LUT3_NY);\n"
        '  printf("%.17g %.17g\\n", TUNER_LUT3[0][39], TUNER_U2);\n'
        "  (void)TUNER_LUT1_I;\n  return 0;\n}\n"
    )
    res = subprocess.run(
        [cc, "-std=c99", "-Wall", "-Werror", "-o", str(tmp_path / "m"),
         str(tmp_path / "main.c")], capture_output=True, text=True,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    out = subprocess.run([str(tmp_path / "m")], capture_output=True, text=True, check=True).stdout.split()
    best = short_run.best_params
    tabs = ProtectiveFuzzy().tables(best)  # (nx, ny), the header is rows-follow-y
    assert float(out[0]) == tabs["lut2"]["table"][31, 7]
    assert float(out[1]) == tabs["lut1_p"]["table"][3, 20]
    assert float(out[2]) == best["p21"]
    assert (int(out[3]), int(out[4])) == (40, 1)
    assert float(out[5]) == tabs["lut3"]["table"][39, 0]
    assert float(out[6]) == best["u2"]
