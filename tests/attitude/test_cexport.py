"""The C99 filters (objectives/attitude/cexport) against the numba kernels they port, on the synthetic bench.

Independent reference: the numba kernels of objectives/attitude/filters (the model the tuning scores). Double
precision must match them within 1e-9 rad at every sample, compiled with -O2 with and without -ffast-math; the
generated files must compile under -std=c99 -Wall -Wextra -Werror -pedantic; the objects must call no libm
function but sqrt, exp, asin and atan2 and hold no writable global state. BROAD trials: test_cexport_broad.py.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from objectives.attitude.cexport import render_c_filter
from objectives.attitude.cexport.build import STRICT_FLAGS, find_compiler
from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.filters.madgwick import Madgwick
from objectives.attitude.filters.mahony import Mahony
from objectives.attitude.quaternion import to_frame
from tests.attitude.cexport_cases import CONFIGS, angle, build, needs_cc, run_c
from tests.attitude.robust_cases import degenerate_arrays

pytestmark = needs_cc
TOL_RAD = 1e-9


@pytest.fixture(scope="module")
def bench():
    """20 s at 200 Hz of the FAEKF paper's bench (NED) with external accelerations and magnetic perturbations."""
    return bench6dof(20.0, 200.0, 5, ext_acc_max_g=0.5, mag_pert_range=(0.1, 0.5))


def _truth_start(flt):
    """The filter started from the first truth sample (a start consistent with the first measurement leaves
    Madgwick's first gradient to rounding noise, see test_madgwick_start_from_the_same_sample)."""
    return type(flt)(**{**flt.values, "init": "truth"})


@pytest.mark.parametrize("case", sorted(CONFIGS))
def test_double_matches_the_numba_kernel_at_every_sample(case, bench, tmp_path):
    flt = _truth_start(CONFIGS[case]())
    ref = flt.run(bench)
    q0 = bench.quat[0]
    for opt in (("-O2",), ("-O2", "-ffast-math")):
        c = build(flt, tmp_path, 1.0 / bench.dt, "double", opt, init="given")
        e = angle(ref, run_c(c, flt, bench, q0))
        assert e.max() < TOL_RAD, (case, opt, float(e.max()), int(np.argmax(e)))


@pytest.mark.parametrize("case", ["madgwick_c_zeta", "mahony_robust", "ekf_robust"])
def test_start_from_the_first_sample_as_the_model(case, bench, tmp_path):
    flt = CONFIGS[case]()  # init auto -> accmag: the C computes the start from its first sample
    c = build(flt, tmp_path, 1.0 / bench.dt)
    e = angle(flt.run(bench), run_c(c, flt, bench))
    assert e.max() < TOL_RAD, float(e.max())


def test_broad_start_as_the_model(bench, tmp_path):
    flt = Mahony(Kp=0.74, Ki=0.0012, init="broad")
    c = build(flt, tmp_path, 1.0 / bench.dt)
    assert angle(flt.run(bench), run_c(c, flt, bench)).max() < TOL_RAD


def test_madgwick_start_from_the_same_sample(bench, tmp_path):
    """With the start taken from sample 0 (accmag), the paper variant's error function is 0 at sample 0 up to
    rounding, and its normalised gradient (report eq. 42) is a rounding-noise direction of length 1: any two
    correct implementations step apart by up to 2 beta dt there (measured: 1.3e-4 to 4.7e-4 rad on BROAD at
    beta 0.034). The difference then decays with the filter's time constant; the metrics stay equal."""
    flt = Madgwick(beta=0.05)
    c = build(flt, tmp_path, 1.0 / bench.dt)
    e = angle(flt.run(bench), run_c(c, flt, bench))
    assert e.max() < 4.0 * flt.values["beta"] * bench.dt
    assert e[-200:].max() < 1e-3 * e.max() + TOL_RAD


@pytest.mark.parametrize("flt", [Madgwick(beta=0.1, rest_bias=True, zeta=0.01), Mahony(Kp=0.5, Ki=0.01)])
def test_degenerate_samples_as_the_model(flt, bench, tmp_path):
    """Zero and non-finite acc, mag and gyro samples: handled exactly as the kernels handle them (raw arrays,
    NWU working frame, a start quaternion given)."""
    from objectives.attitude.cexport.build import CFilter, compile_shared
    from objectives.attitude.filters.madgwick import madgwick_batch
    from objectives.attitude.filters.mahony import mahony_batch

    g, a, m = degenerate_arrays(bench)
    q0 = to_frame(bench.quat[0], bench.frame, "NWU")
    v = {k: x for k, x in flt.values.items() if k not in ("init", "use_mag")}
    if flt.name == "madgwick":
        ref = madgwick_batch(g, a, m, bench.dt, q0, **v)
    else:
        ref = mahony_batch(g, a, m, bench.dt, q0, kp=v.pop("Kp"), ki=v.pop("Ki"), **v)
    files = render_c_filter(flt, rate_hz=1.0 / bench.dt, init="given", prefix="DG", frame="NWU")
    got = CFilter(compile_shared(files, tmp_path), "DG").run(g, a, m, bench.dt, q0)
    assert np.isfinite(got).all()
    assert angle(ref, got).max() < TOL_RAD


def test_coefficients_follow_the_sample_time(bench, tmp_path):
    """Exported for 100 Hz and run at the bench's 200 Hz: the rate-dependent gains are remade from dt, so the
    C equals the model run at 200 Hz."""
    flt = _truth_start(CONFIGS["mahony_robust"]())
    c = build(flt, tmp_path, 100.0, init="given")
    assert angle(flt.run(bench), run_c(c, flt, bench, bench.quat[0])).max() < TOL_RAD


@pytest.mark.parametrize("case", ["madgwick_paper_robust", "ekf_robust"])
def test_float_close_to_double(case, bench, tmp_path):
    from objectives.attitude.metrics import broad_errors

    flt = _truth_start(CONFIGS[case]())
    out = {p: run_c(build(flt, tmp_path, 1.0 / bench.dt, p, init="given"), flt, bench, bench.quat[0])
           for p in ("double", "float")}
    rmse = {p: broad_errors(q, bench.quat).total_rmse_deg for p, q in out.items()}
    assert abs(rmse["float"] - rmse["double"]) < 0.01, rmse
    assert angle(out["float"], out["double"]).max() < 1e-3  # float rounding, not a different filter


@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("case", sorted(CONFIGS) + ["kf1d", "akf1d"])
def test_objects_use_only_sqrt_exp_asin_atan2_and_no_writable_globals(case, precision, tmp_path):
    from objectives.attitude.filters.kf1d import AKF1D, KF1D

    flt = {"kf1d": KF1D, "akf1d": AKF1D}[case]() if case.endswith("kf1d") else CONFIGS[case]()
    files = render_c_filter(flt, rate_hz=200.0, precision=precision, prefix="NM")
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    obj = tmp_path / "nm.o"
    # float: no arithmetic silently promoted to double (an MCU without a double FPU would emulate it)
    res = subprocess.run([*find_compiler(), *STRICT_FLAGS, "-Wdouble-promotion", "-Wconversion", "-O2", "-c",
                          str(tmp_path / "nm.c"), "-o", str(obj)], capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr, res.stderr
    syms = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout.split("\n")
    undefined = {s.split()[-1] for s in syms if s.strip().startswith("U ")}
    allowed = {"sqrt", "exp", "asin", "atan2"} | {"sqrtf", "expf", "asinf", "atan2f"}
    assert undefined <= allowed, undefined - allowed
    writable = [s for s in syms if len(s.split()) == 3 and s.split()[1] in "BbDdCc"]
    assert not writable, writable
    assert "NM_tuned" in "\n".join(syms)
    assert (" float " if precision == "float" else " double ") in files["nm.h"]


def test_frames_and_quaternion_output(bench, tmp_path):
    """The output frame is a render option: NED output equals ENU output rotated."""
    flt = _truth_start(CONFIGS["madgwick_c_zeta"]())
    files = render_c_filter(flt, rate_hz=200.0, init="given", prefix="FR", frame="NED")
    from objectives.attitude.cexport.build import CFilter, compile_shared

    ned = CFilter(compile_shared(files, tmp_path / "ned"), "FR").run(bench.gyr, bench.acc, bench.mag, bench.dt,
                                                                         bench.quat[0])
    assert angle(ned, flt.run(bench)).max() < TOL_RAD  # bench is NED
    enu = run_c(build(flt, tmp_path, 200.0, init="given"), flt, bench, bench.quat[0])
    assert angle(to_frame(ned, "NED", "NED"), enu).max() < TOL_RAD


@pytest.mark.parametrize("frame", ["NED", "ENU"])
@pytest.mark.parametrize("name", ["kf1d", "akf1d", "akf1d_fft450"])
def test_tilt_kf_as_the_model(name, frame, tmp_path):
    """The thesis's tilt KF (eqs. 3.9-3.13, nonzero P0) and its fuzzy-adaptive form (R_k = K_k rho, eq. 3.24,
    from the packet measures of eqs. 3.19-3.22 and the static tables of Table 3.2) on the tilt bench (thesis
    3.1.2): the bench's vibration and external acceleration move K over 1-18 (checked). The DFT's twiddles
    come from the quarter-wave table (FFT length 512) or, for a length not a multiple of 4, per term."""
    from objectives.attitude.cexport.build import CFilter, compile_shared
    from objectives.attitude.data.tilt1d import tilt1d
    from objectives.attitude.filters.kf1d import AKF1D, KF1D

    rec = tilt1d(30.0, 800.0, 3, frame=frame)
    if name == "kf1d":
        flt = KF1D(rho=0.35, q00=6.4e-8, q11=3.1e-12, p0_theta=1e-3, p0_bias=1e-6)
    else:
        flt = AKF1D(rho=0.32, q00=5.9e-7, q11=6.4e-12, K3=12.0, fft_length=450 if name.endswith("450") else 512)
    res = flt.run_detailed(rec)
    if name.startswith("akf1d"):
        assert res.diagnostics["K"].max() > 5.0 * res.diagnostics["K"].min()
    for precision in ("double", "float"):
        files = render_c_filter(flt, rate_hz=800.0, precision=precision, prefix="KF", frame=frame)
        c = CFilter(compile_shared(files, tmp_path / precision), "KF", precision)
        q = c.run(rec.gyr, rec.acc, rec.mag, rec.dt)
        theta = 2.0 * np.arctan2(q[:, 2], q[:, 0])
        tol = TOL_RAD if precision == "double" else 1e-4
        assert np.abs(theta - res.diagnostics["angle"]).max() < tol
        assert angle(q, res.quat).max() < tol


def test_each_helper_is_defined_in_one_template():
    """A helper two filters need lives in one shared part (common.c, robust.c, trig.c, angle.c, ...), not in a
    copy per filter template; only the streaming API and each filter's own set_rate have one per filter."""
    import re
    from importlib import resources

    where: dict[str, set[str]] = {}
    for f in resources.files("objectives.attitude.cexport").joinpath("templates").iterdir():
        if f.name.endswith(".c"):
            for fn in re.findall(r"^(?:static )?(?:inline )?\w+ \**(\w+)\(", f.read_text(), re.MULTILINE):
                where.setdefault(fn, set()).add(f.name)
    assert {"robust_init", "robust_rate", "floor_", "sincos_", "qmul"} <= set(where)
    twice = {fn: sorted(files) for fn, files in where.items()
             if len(files) > 1 and not fn.startswith("PFX_") and fn != "set_rate"}
    assert not twice, twice


def test_render_refuses_what_it_cannot_port():
    from objectives.attitude.filters.ekf import FAEKF

    with pytest.raises(ValueError, match="no C port of filter 'faekf'"):
        render_c_filter(FAEKF(), rate_hz=100.0)
    with pytest.raises(ValueError, match="precision must be"):
        render_c_filter(Mahony(), rate_hz=100.0, precision="half")
    with pytest.raises(ValueError, match="C identifier"):
        render_c_filter(Mahony(), rate_hz=100.0, prefix="1x")


def test_sine_and_cosine_without_libm(tmp_path):
    """The series that replaces libm's sin/cos agrees with it to 1 ulp over the angles filters see."""
    import ctypes
    import math

    from objectives.attitude.filters.ekf import EKF

    src = render_c_filter(EKF(), rate_hz=100.0, prefix="T")["t.c"]
    a = src.index("static void sincos_", src.index("#else", src.index("#ifdef T_LIBM_TRIG")))  # the series
    b = src.index("\n}\n", a) + 3
    (tmp_path / "s.c").write_text("#include <math.h>\ntypedef double real;\n" + src[a:b]
                                  + "\nvoid sc(double a, double *s, double *c);\n"
                                  + "void sc(double a, double *s, double *c) { sincos_(a, s, c); }\n")
    subprocess.run([*find_compiler(), *STRICT_FLAGS, "-O2", "-shared", "-fPIC", "-o", str(tmp_path / "s.so"),
                    str(tmp_path / "s.c"), "-lm"], check=True)
    lib = ctypes.CDLL(str(tmp_path / "s.so"))
    s, c = ctypes.c_double(), ctypes.c_double()
    xs = np.concatenate([np.linspace(-20.0, 20.0, 40001), np.geomspace(1e-12, 1.0, 200), [math.pi, -math.pi]])
    for x in xs:
        lib.sc(ctypes.c_double(x), ctypes.byref(s), ctypes.byref(c))
        assert abs(s.value - math.sin(x)) <= 4e-16 * max(abs(math.sin(x)), 1e-3), x
        assert abs(c.value - math.cos(x)) <= 4e-16, x
    lib.sc(ctypes.c_double(math.inf), ctypes.byref(s), ctypes.byref(c))
    assert math.isnan(s.value) and math.isnan(c.value)


def test_a_fast_math_build_leaves_this_process_with_subnormal_numbers(bench, tmp_path):
    """Linking with -ffast-math would add crtfastmath.o, which sets flush-to-zero in the loading process: every
    later test in this Python would then see subnormals as 0 (numpy's hypothesis-driven tests fail on that)."""
    flt = _truth_start(CONFIGS["madgwick_c_zeta"]())
    tiny = np.float64(2.2250738585072014e-308) / 4  # a subnormal
    assert tiny / 2 > 0
    c = build(flt, tmp_path, 1.0 / bench.dt, "double", ("-O2", "-ffast-math"), init="given")
    run_c(c, flt, bench, bench.quat[0])
    assert tiny / 2 > 0 and tiny * 0.5 == np.float64(2.2250738585072014e-308) / 8


@pytest.mark.parametrize("case", ["lcf_tau", "ccf_robust", "realtime_vqf", "realtime_tuned"])
def test_with_libm_trig_the_port_runs_the_kernels_operations(case, bench, tmp_path):
    """``-DPREFIX_LIBM_TRIG`` swaps the series for libm's sin and cos, the kernel's own: then the port computes
    the kernel's numbers, bit for bit where the output needs no frame change (realtime works in ENU) and to the
    rounding of the output's frame change otherwise; the series differs from libm by up to 1 ulp per call."""
    flt = type(CONFIGS[case]())(**{**CONFIGS[case]().values, "init": "truth"})
    ref = flt.run(bench)
    err = {}
    for opt in (("-O2",), ("-O2", "-DT1_LIBM_TRIG")):
        c = build(flt, tmp_path, 1.0 / bench.dt, "double", opt, init="given")
        err[opt[-1]] = np.abs(ref - run_c(c, flt, bench, bench.quat[0])).max()
    if case.startswith("realtime"):
        assert err["-DT1_LIBM_TRIG"] == 0.0 and err["-O2"] > 0.0, err
    else:
        assert err["-DT1_LIBM_TRIG"] < 1e-15 and err["-DT1_LIBM_TRIG"] <= err["-O2"], err
    files = render_c_filter(flt, rate_hz=200.0, precision="float", prefix="T2")  # float: sinf and cosf
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    res = subprocess.run([*find_compiler(), *STRICT_FLAGS, "-Wdouble-promotion", "-DT2_LIBM_TRIG", "-O2", "-c",
                          str(tmp_path / "t2.c"), "-o", str(tmp_path / "t2.o")], capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr, res.stderr
