"""AMIGO and SIMC tuning rules (objectives/control/plants/rules.py) against the literature's formulas
and examples, and the FOTD fit against an exact FOTD response."""

import numpy as np
import pytest

from objectives.control.plants.rules import FOTD, amigo_pid, fit_fotd, half_rule, series_to_ideal, simc_pid


def test_amigo_pid_formula():
    """Åström & Hägglund (2004), AMIGO PID: K Kp = 0.2 + 0.45 T/L, Ti = L (0.4 L + 0.8 T)/(L + 0.1 T),
    Td = 0.5 L T / (0.3 L + T); for Kp = 1, T = L = 1: 0.65, 1.2/1.1, 0.5/1.3."""
    K, Ti, Td = amigo_pid(FOTD(1.0, 1.0, 1.0))
    assert (K, Ti, Td) == pytest.approx((0.65, 1.2 / 1.1, 0.5 / 1.3))
    K2, Ti2, Td2 = amigo_pid(FOTD(2.0, 4.0, 0.5))  # K scales with 1/Kp; times scale with T and L
    assert K2 == pytest.approx((0.2 + 0.45 * 8) / 2) and Ti2 == pytest.approx(0.5 * (0.2 + 3.2) / (0.5 + 0.4))
    assert Td2 == pytest.approx(0.5 * 0.5 * 4 / (0.15 + 4))


def test_simc_half_rule_skogestad_example():
    """Skogestad (2003), the half rule on 1/((s+1)(0.2s+1)(0.04s+1)(0.008s+1)) to SOPDT: tau1 = 1,
    tau2 = 0.2 + 0.04/2 = 0.22, theta = 0.04/2 + 0.008 = 0.028; SIMC PID with tau_c = theta:
    Kc = tau1 / (k 2 theta) = 17.86, tauI = min(tau1, 8 theta) = 0.224, tauD = tau2 = 0.22."""
    k, t1, t2, th = half_rule(1.0, [1.0, 0.2, 0.04, 0.008], 0.0)
    assert (k, t1, t2, th) == pytest.approx((1.0, 1.0, 0.22, 0.028))
    kc, ti, td = simc_pid(k, t1, t2, th)
    assert (kc, ti, td) == pytest.approx((1 / 0.056, 0.224, 0.22))
    # an inverse-response time constant counts as delay
    assert half_rule(1.0, [1.0], 0.5, [0.3])[3] == pytest.approx(0.8)


def test_series_to_ideal_is_the_same_controller():
    kc, ti, td = 2.0, 1.5, 0.4
    K, Ti, Td = series_to_ideal(kc, ti, td)
    for s in (0.1j, 1.0j, 3.0 + 2.0j):
        assert kc * (1 + 1 / (ti * s)) * (1 + td * s) == pytest.approx(K * (1 + 1 / (Ti * s) + Td * s))


def test_fotd_fit_recovers_an_exact_fotd():
    t = np.linspace(0, 30, 3001)
    y = np.where(t > 0.7, 2.0 * (1 - np.exp(-(t - 0.7) / 3.0)), 0.0)
    m = fit_fotd(t, y)
    assert (m.K, m.T, m.L) == pytest.approx((2.0, 3.0, 0.7), rel=1e-3)


def test_area_method_is_exact_on_a_fotd_and_its_integrals_on_a_second_order_lag():
    """The method of areas recovers a FOTD exactly; on 1/(s+1)^2 its areas have the closed form
    Tar = 2, A1 = 4 e^-2, so T = 4 / e and L = 2 - 4 / e (the integrals checked with scipy's quad)."""
    from scipy.integrate import quad

    t = np.linspace(0, 80, 800001)
    y = np.where(t > 0.7, 2.0 * (1 - np.exp(-(t - 0.7) / 3.0)), 0.0)
    m = fit_fotd(t, y, "area")
    assert (m.K, m.T, m.L) == pytest.approx((2.0, 3.0, 0.7), rel=1e-5)
    step = lambda s: 1 - np.exp(-s) * (1 + s)  # noqa: E731
    a0 = quad(lambda s: 1 - step(s), 0, np.inf)[0]
    a1 = quad(step, 0, a0)[0]
    assert a0 == pytest.approx(2.0) and a1 == pytest.approx(4 * np.exp(-2.0))
    t = np.linspace(0, 40, 400001)
    m = fit_fotd(t, step(t), "area")
    assert (m.K, m.T, m.L) == pytest.approx((1.0, np.e * a1, a0 - np.e * a1), rel=1e-6)
    with pytest.raises(ValueError, match="allowed"):
        fit_fotd(t, step(t), "moments")


def _dense_ms(num, den, h, delay_n, K, Ti, Td, N=10.0):
    """Ms of the sampled PID loop by python-control's discretisation on 10^5 frequencies up to Nyquist."""
    import control

    P = control.sample_system(control.tf(num, den), h)
    w = np.logspace(np.log10(1e-4 * np.pi / h), np.log10(np.pi / h), 100_000)
    z = np.exp(1j * w * h)
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    C = K + ki / (z - 1) + bd * (z - 1) / (z - ad)
    Pz = np.polyval(np.ravel(P.num[0][0]), z) / np.polyval(np.ravel(P.den[0][0]), z) * z ** -delay_n
    return float(np.max(1 / np.abs(1 + C * Pz)))


def test_detuning_meets_the_ms_limit_of_the_sampled_loop():
    """AMIGO (gain factor) and SIMC (tau_c) moved along their knobs to Ms = 1.4 on e^-s/(5s+1) at h = 0.05:
    the published rules exceed it, the detuned ones meet it to 1e-6 by python-control's own loop on a dense
    grid; a rule that already meets it is returned as published."""
    from objectives.control.plants.rules import FOTD, amigo_detuned, detune_to_ms, simc_detuned

    h, m = 0.05, FOTD(1.0, 5.0, 1.0)
    ms = lambda pid: _dense_ms([1.0], [5.0, 1.0], h, 20, *pid)  # noqa: E731
    assert ms(amigo_pid(m)) > 1.45
    d = detune_to_ms(lambda a: amigo_detuned(m, a), ms, 1.4, "down")
    assert d.detuned and 0.5 < d.knob < 1.0 and d.ms == pytest.approx(1.4, abs=1e-6) and d.ms <= 1.4
    assert d.pid[1:] == amigo_pid(m)[1:]  # only the gain moves
    sopdt = (1.0, 5.0, 0.0, 1.0)
    d = detune_to_ms(lambda lam: simc_detuned(sopdt, lam), ms, 1.4, "up")
    assert d.knob > 1.0 and d.ms == pytest.approx(1.4, abs=1e-6)
    assert d.pid == pytest.approx(series_to_ideal(*simc_pid(1.0, 5.0, 0.0, 1.0, d.knob * 1.0)))
    d = detune_to_ms(lambda a: amigo_detuned(m, a), ms, 2.0, "down")
    assert not d.detuned and d.knob == 1.0 and d.pid == amigo_pid(m)


def _fotd_job(**init):
    from objectives.control.objective import ClosedLoopObjective

    return ClosedLoopObjective.from_config({
        "kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [5.0, 1.0]}, "delay_s": 1.0},
        "controller": "pid2dof", "period_s": 0.05, "fixed": {"N": 10.0, "b": 1.0, "c": 0.0, "antiwindup": "none"},
        "scenario": {"duration_s": 20.0, "reference": [], "load": [{"t": 0.0, "value": 1.0}]},
        "requirements": {"max_ms": 1.4}, **({"init": init} if init else {})})


@pytest.mark.parametrize("fit", ["lsq", "area"])
def test_init_starts_from_the_rule_on_the_plants_step_response(fit):
    """``init: {rule: amigo, fit}`` on a FOTD plant: both fits of its sampled step response recover K = 1, T = 5,
    L = 1; the defaults are AMIGO detuned to the job's Ms limit (checked on python-control's loop), and the
    search starts there."""
    o = _fotd_job(rule="amigo", fit=fit)
    s = o.loop.start()
    assert (s.model.K, s.model.T, s.model.L) == pytest.approx((1.0, 5.0, 1.0), rel=2e-3)
    assert s.max_ms == 1.4 and s.knob < 1.0 and fit in s.fit
    pid = (o.defaults["K"], o.defaults["Ti_s"], o.defaults["Td_s"])
    assert pid[1:] == pytest.approx(amigo_pid(s.model)[1:])
    assert _dense_ms([1.0], [5.0, 1.0], 0.05, 20, *pid) == pytest.approx(1.4, abs=1e-6)
    assert o.start_params() == o.defaults and o(o.defaults).status == "ok"
    assert "AMIGO on the " in o.loop.notes()[-1]
    assert _fotd_job().start_params() is None and _fotd_job().defaults["K"] == 1.0


def test_init_errors_name_the_key():
    from objectives.control.objective import ClosedLoopObjective

    with pytest.raises(ValueError, match="objective.init.rule"):
        _fotd_job(rule="zn")
    with pytest.raises(ValueError, match="objective.init.fit"):
        _fotd_job(rule="simc", fit="moments")
    with pytest.raises(ValueError, match="objective.init: a rule gives one PID"):
        ClosedLoopObjective.from_config({"kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                                         "controller": "lqr_sf", "init": "amigo", "scenario": {"duration_s": 2.0}})
    integrator = ClosedLoopObjective.from_config({"kind": "closed_loop", "plant": {"tf": {"num": [1.0],
                                                  "den": [1.0, 1.0, 0.0]}}, "init": "simc",
                                                  "scenario": {"duration_s": 2.0}})
    with pytest.raises(ValueError, match="self-regulating"):
        _ = integrator.defaults


def test_a_run_with_init_starts_at_the_rule_and_config_errors_are_one_line(tmp_path):
    """``tuner run`` on a job with ``init:``: the first evaluation of the search (PSO's particle 0) is the rule's
    PID; the searched bounds clip it. A bad ``init`` is one ``error:`` line naming the key."""
    import csv

    import yaml

    from tests.conftest import one_error_line, run_tuner
    from tests.control.jobs import pi_job

    obj = _fotd_job(rule="simc", fit="lsq")
    start = obj.defaults
    path, job = pi_job(tmp_path, "init", {
        "kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [5.0, 1.0]}, "delay_s": 1.0},
        "controller": "pid2dof", "period_s": 0.05, "fixed": {"N": 10.0, "b": 1.0, "c": 0.0, "antiwindup": "none",
                                                             "Td_s": 0.0},
        "scenario": {"duration_s": 20.0, "reference": [], "load": [{"t": 0.0, "value": 1.0}]},
        "requirements": {"max_ms": 1.4}, "init": {"rule": "simc", "fit": "lsq"}},
        K=(0.05, 50.0), Ti_s=(0.1, 30.0), population=4, generations=1, seed=3)
    assert run_tuner("run", str(path), "--no-report").returncode == 0
    run = next((tmp_path / "runs").iterdir())
    with open(run / "history.csv") as fh:
        first = next(csv.DictReader(fh))
    assert float(first["K"]) == pytest.approx(start["K"], rel=1e-12)
    assert float(first["Ti_s"]) == pytest.approx(start["Ti_s"], rel=1e-12)
    job["objective"]["init"] = {"rule": "amigo", "fit": "moments"}
    path.write_text(yaml.safe_dump(job))
    one_error_line(run_tuner("run", str(path), "--no-report"), "objective.init.fit", "lsq")
