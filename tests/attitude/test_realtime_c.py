"""The C port of the ``realtime`` filter (objectives/attitude/filters/c/realtime.c) against the numba kernel:
compiled with strict warnings, run through ctypes, double within 1e-9 on the synthetic scenario (every option
set) and on a BROAD trial, a rate change mid-stream, and the per-sample API equal to the whole-recording one."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from objectives.attitude.filters._realtime_kernel import initial_state, realtime_kernel
from objectives.attitude.filters.realtime import Realtime
from tests.attitude.test_realtime import OPTION_SETS, scenario

SRC = Path(__file__).resolve().parents[2] / "objectives" / "attitude" / "filters" / "c"
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang)")

_INTS = {"use_mag", "motion_bias", "rest_bias", "mag_rejection", "mag_first_at_rest"}
#: the fields of rt_params in the header's order
FIELDS = ["tau_acc_s", "tau_mag_s", "use_mag", "motion_bias", "rest_bias", "mag_rejection", "bias_sigma_init_dps",
          "bias_forgetting_s", "bias_clip_dps", "bias_sigma_motion_dps", "bias_vertical_forgetting",
          "bias_sigma_rest_dps", "rest_min_s", "rest_filter_tau_s", "rest_th_gyr_dps", "rest_th_acc",
          "mag_current_tau_s", "mag_ref_tau_s", "mag_norm_th", "mag_dip_th_deg", "mag_new_s", "mag_new_first_s",
          "mag_new_min_gyr_dps", "mag_min_undisturbed_s", "mag_max_rejection_s", "mag_rejection_factor",
          "mag_first_at_rest", "mag_recover_tau_s"]


class Params(ctypes.Structure):
    _fields_ = [(n, ctypes.c_int if n in _INTS else ctypes.c_double) for n in FIELDS]


class Filt(ctypes.Structure):
    _fields_ = [("c", ctypes.c_double * 45), ("s", ctypes.c_double * 79), ("dt", ctypes.c_double)]


def test_header_fields_match_the_declaration():
    header = (SRC / "realtime.h").read_text()
    body = header[header.index("typedef struct {"):header.index("} rt_params;")]
    names = [w.strip(" ,;\n") for w in body.replace("double", ",").replace("int", ",").split(",")]
    assert [n for n in names if n and n != "typedef struct {"] == FIELDS
    assert set(FIELDS) == set(Realtime.defaults) - {"start", "init"}


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    out = tmp_path_factory.mktemp("rtc") / "librealtime.so"
    cmd = [CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-fPIC", "-shared", "-o", str(out),
           str(SRC / "realtime.c"), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr.strip(), res.stderr
    so = ctypes.CDLL(str(out))
    p = ctypes.POINTER(ctypes.c_double)
    so.rt_run.argtypes = [ctypes.POINTER(Params), ctypes.c_long, p, p, p, ctypes.c_double, p, p]
    so.rt_init.argtypes = [ctypes.POINTER(Filt), ctypes.POINTER(Params), ctypes.c_double, p]
    so.rt_update.argtypes = [ctypes.POINTER(Filt), ctypes.POINTER(Params), p, p, p, ctypes.c_double]
    so.rt_quaternion.argtypes = [ctypes.POINTER(Filt), p]
    return so


def _params(values):
    v = {**Realtime.defaults, **values}
    return Params(**{n: (int(bool(v[n])) if n in _INTS else float(v[n])) for n in FIELDS})


def _ptr(a):
    return None if a is None else a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def c_run(lib, values, gyr, acc, mag, dt, q0=None):
    gyr, acc = np.ascontiguousarray(gyr, float), np.ascontiguousarray(acc, float)
    mag = None if mag is None else np.ascontiguousarray(mag, float)
    out = np.empty((gyr.shape[0], 4))
    q0a = None if q0 is None else np.ascontiguousarray(q0, float)
    lib.rt_run(ctypes.byref(_params(values)), gyr.shape[0], _ptr(gyr), _ptr(acc), _ptr(mag), dt, _ptr(q0a), _ptr(out))
    return out


@pytest.mark.parametrize("use_mag", [True, False], ids=["9d", "6d"])
@pytest.mark.parametrize("opts", list(OPTION_SETS), ids=list(OPTION_SETS))
def test_c_equals_kernel_on_scenario(lib, opts, use_mag):
    rec = scenario(duration_s=30.0)
    values = {**OPTION_SETS[opts], "use_mag": use_mag}
    want = Realtime(**values).run_detailed(rec).quat
    got = c_run(lib, values, rec.gyr, rec.acc, rec.mag if use_mag else None, rec.dt)
    np.testing.assert_allclose(got, want, atol=1e-9, rtol=0)


def test_c_equals_kernel_on_broad(lib):
    from objectives.attitude.data.broad import default_broad_dir, load_broad

    path = default_broad_dir() / "28_disturbed_stationary_magnet_A.mat"
    if not path.exists():
        pytest.skip("needs ../shared/data/broad")
    rec = load_broad(path)
    values = {"mag_first_at_rest": True, "tau_mag_s": 22.46, "mag_recover_tau_s": 10.98}
    from objectives.attitude.quaternion import to_frame

    want = to_frame(Realtime(**values).run_detailed(rec).quat, rec.frame, "ENU")
    got = c_run(lib, values, rec.gyr, rec.acc, rec.mag, rec.dt)
    np.testing.assert_allclose(got, want, atol=1e-9, rtol=0)


def test_c_start_q0_and_rate_change_per_sample(lib):
    rec = scenario(duration_s=16.0)
    values = {"mag_first_at_rest": True, "mag_recover_tau_s": 4.0, "start": "q0"}
    q0 = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    f = Realtime(**values)
    n, cut, dt2 = rec.gyr.shape[0], 700, 0.5 * rec.dt
    # the kernel: the first part at dt, the rest at dt2, the state carried
    s = initial_state(f.coef(rec.dt, True), q0)
    want = np.empty((n, 4))
    for sl, dt in ((slice(0, cut), rec.dt), (slice(cut, n), dt2)):
        m = sl.stop - sl.start
        o = np.empty((m, 4))
        realtime_kernel(rec.gyr[sl].copy(), rec.acc[sl].copy(), rec.mag[sl].copy(), f.coef(dt, True), s, o,
                        np.empty((m, 3)), np.empty((m, 3)))
        want[sl] = o
    # C, one sample at a time with rt_update's dt argument
    filt, par = Filt(), _params(values)
    lib.rt_init(ctypes.byref(filt), ctypes.byref(par), rec.dt, _ptr(np.ascontiguousarray(q0)))
    got = np.empty((n, 4))
    q = np.empty(4)
    for k in range(n):
        g, a, m = (np.ascontiguousarray(x[k]) for x in (rec.gyr, rec.acc, rec.mag))
        lib.rt_update(ctypes.byref(filt), ctypes.byref(par), _ptr(g), _ptr(a), _ptr(m), rec.dt if k < cut else dt2)
        lib.rt_quaternion(ctypes.byref(filt), _ptr(q))
        got[k] = q
    np.testing.assert_allclose(got, want, atol=1e-9, rtol=0)
