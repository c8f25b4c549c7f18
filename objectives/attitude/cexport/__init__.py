"""C99 source of the attitude filters firmware runs, with a tuned configuration baked in.

``render_c_filter(flt, ...)`` turns a validated filter (Madgwick, Mahony, the EKF, the LCF, NCF and CCF,
``realtime``, the thesis's tilt KF and AKF of :mod:`objectives.attitude.filters`; robust blocks included) into a
header and a
source file. The C is a line-by-line port of the numba kernels (same operations in the same order, the same
start orientation, the robust blocks in the kernels' order), so that it computes what the tuning scored;
``tests/attitude/test_cexport*.py`` compile it and compare it with the kernels sample by sample.

Each filter is one struct and a streaming API without heap or global state::

    PREFIX_filter f;
    PREFIX_init(&f, &PREFIX_tuned);
    PREFIX_update(&f, gyr, acc, mag, dt_s);   /* per sample: rad/s, m/s^2, any unit (NULL: none), s */
    PREFIX_quaternion(&f, q);                 /* sensor-to-earth (w, x, y, z), ENU */

Only ``sqrt``, ``exp``, ``asin`` and ``atan2`` of libm are called (sine and cosine, for the EKF's exact
quaternion step and the complementary filters' Euler angles, are a series; the Huber angle uses ``asin``).
``precision="float"`` writes every literal and call in single precision for MCUs without a double FPU.

The templates (``templates/*.c``, ``*.h``) name public identifiers ``PFX_`` and use ``real``, ``SQRT``,
``EXP``, ``ASIN``, ``ATAN2``, ``fabs``; :func:`render_c_filter` replaces them. A source is the parts
``common.c``; ``robust.c`` (the filters with the robust blocks: their init and rate coefficients too);
``bias_prologue.c`` (Madgwick, Mahony) or ``trig.c``; ``angle.c`` (the filters that wrap angles); the filter's
own template; ``run.c``, in that order, so a piece two filters need is written once, in the first part both get.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np

__all__ = ["render_c_filter", "C_FILTERS", "CField", "c_identifier"]

#: filters with a C port: name -> the template of its update
C_FILTERS = {"madgwick": "madgwick.c", "mahony": "mahony.c", "ekf": "ekf.c", "lcf": "cf.c", "ncf": "cf.c",
             "ccf": "cf.c", "kf1d": "kf1d.c", "akf1d": "kf1d.c", "realtime": "realtime.c"}
_TILT = ("kf1d", "akf1d")
_ALPHA_MODES = {"per_sample": 0, "tau": 1, "static": 2}
_INIT = {"accmag": 0, "broad": 1, "given": 2}
_FLOAT_LIT = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+|\.\d+(?:[eE][-+]?\d+)?)(?![\w.])")
_BIAS_STATE = ("PFX_real q[4];   /* sensor-to-earth quaternion, working frame */\n"
               "PFX_real b[3];   /* gyro bias (Madgwick: omega_b; Mahony: the integral I = -b), rad/s */\n")
_ROBUST_STATE = ("PFX_real mc[11]; /* magnetic rejection: coefficients and state */\n"
                 "PFX_real ms[11];\n"
                 "PFX_real rc[7];  /* rest detection and rest bias: coefficients and state */\n"
                 "PFX_real rs[12];\n"
                 "PFX_real alp_k;  /* earth-frame acc low-pass: gain and state */\n"
                 "PFX_real as[4];\n"
                 "PFX_real dt_s;   /* sample time the coefficients were made for, s */\n"
                 "int started;     /* 0: start orientation from the next sample */\n"
                 "PFX_params p;\n")


@dataclass(frozen=True)
class CField:
    """One member of the ``PFX_params`` struct: C type (``real`` or ``int``), name, value, doc."""

    ctype: str
    name: str
    value: Any
    doc: str


def c_identifier(prefix: str) -> str:
    """``prefix`` as a C identifier prefix (letters, digits, underscores; not starting with a digit)."""
    p = re.sub(r"\W", "_", str(prefix))
    if not p or p[0].isdigit():
        raise ValueError(f"prefix must be a C identifier (letters, digits, _; no leading digit), got {prefix!r}")
    return p


def _robust_fields(v: dict, ekf: bool) -> list[CField]:
    out = [
        CField("int", "mag_rejection", bool(v["mag_rejection"]), "magnetic disturbance rejection (block a)"),
        CField("int", "rest_bias", bool(v["rest_bias"]), "gyro bias at detected rest (block b)"),
        CField("real", "acc_lp_tau_s", float(v["acc_lp_tau_s"]), "earth-frame acc low-pass time constant, s (0: off)"),
        CField("real", "mag_norm_th", float(v["mag_norm_th"]), "field norm threshold, fraction of the reference"),
        CField("real", "mag_dip_th_deg", float(v["mag_dip_th_deg"]), "field dip threshold, deg"),
        CField("real", "mag_max_rejection_s", float(v["mag_max_rejection_s"]), "longest full rejection, s"),
    ]
    if ekf:
        out.append(CField("real", "rest_bias_var", float(v["rest_bias_var"]),
                          "variance of the bias measurement at rest, (rad/s)^2"))
    else:
        out += [CField("int", "mag_ref_start", bool(v["mag_ref_start"]), "the first field is the first reference"),
                CField("real", "rest_bias_tau_s", float(v["rest_bias_tau_s"]), "rest bias time constant, s")]
    return out


def _fields(name: str, v: dict, dt: float, g: float, init: str, q0, up_sign: float = 1.0) -> list[CField]:
    """The params struct of filter ``name`` from its validated values ``v``."""
    q0 = [1.0, 0.0, 0.0, 0.0] if q0 is None else [float(x) for x in q0]
    head = [CField("real", "dt_s", float(dt), "nominal sample time, s (coefficients are remade when dt_s changes)")]
    start = [CField("int", "init", _INIT[init], "start orientation: 0 first acc/mag sample, 1 BROAD's quatFromAccMag, "
                                                "2 q0"),
             CField("real", "q0[4]", q0, "start quaternion for init 2 (working frame)")]
    if name == "madgwick":
        from objectives.attitude.filters.madgwick import VARIANTS

        body = [CField("real", "beta", float(v["beta"]), "gradient step gain, rad/s (report eq. 33)"),
                CField("real", "zeta", float(v["zeta"]), "gyro bias drift gain, 1/s (report eq. 48)"),
                CField("real", "field_k", VARIANTS[v["variant"]], f"field scale ({v['variant']!r}: 2 paper, 1 2010 C)"),
                CField("int", "use_mag", bool(v["use_mag"]), "MARG (1) or IMU (0)")]
        return head + body + start + _robust_fields(v, False)
    if name == "mahony":
        body = [CField("real", "Kp", float(v["Kp"]), "proportional gain, rad/s"),
                CField("real", "Ki", float(v["Ki"]), "integral gain, rad/s^2"),
                CField("int", "use_mag", bool(v["use_mag"]), "MARG (1) or IMU (0)")]
        return head + body + start + _robust_fields(v, False)
    if name == "ekf":
        body = [CField("real", "q_q", float(v["q_q"]), "quaternion process noise per sample (eq. 36)"),
                CField("real", "q_w", float(v["q_w"]), "gyro bias random walk per sample, (rad/s)^2 (eq. 36)"),
                CField("real", "rho", float(v["rho"]), "TRIAD measurement variance (eq. 36)"),
                CField("real", "p0_q", float(v["p0_q"]), "initial quaternion variance (eq. 18)"),
                CField("real", "p0_b", float(v["p0_b"]), "initial bias variance, (rad/s)^2 (eq. 18)"),
                CField("int", "use_mag", bool(v["use_mag"]), "TRIAD with the magnetometer (1) or north predicted (0)"),
                CField("int", "exact", v["integration"] == "exact", "quaternion step: 1 exact, 0 Euler (eq. 16)"),
                CField("real", "acc_gate", float(v["acc_gate"]), "skip TRIAD when | |acc| - g | > acc_gate g"),
                CField("real", "g", float(g), "gravity in the accelerometer's unit"),
                CField("real", "huber_rad", math.radians(float(v["huber_deg"])), "Huber innovation angle, rad"),
                CField("int", "gyro_current", v["gyro_sample"] == "current", "1: gyro sample k propagates k-1 -> k")]
        return head + body + start + _robust_fields(v, True)
    if name in ("lcf", "ncf", "ccf"):
        return head + _cf_fields(name, v, g) + start
    if name in _TILT:
        return head + [CField("real", "rho", float(v["rho"]), "accelerometer-angle variance per sample (eq. 3.17)"),
                       CField("real", "q00", float(v["q00"]), "angle process noise per sample (eq. 3.17)"),
                       CField("real", "q11", float(v["q11"]), "bias random walk per sample (eq. 3.17)"),
                       CField("real", "p0_theta", float(v["p0_theta"]), "initial angle variance, rad^2"),
                       CField("real", "p0_bias", float(v["p0_bias"]), "initial bias variance, (rad/s)^2"),
                       CField("real", "up_sign", up_sign, "+1: z-up earth frame (ENU), -1: NED"),
                       CField("int", "use_mag", True, "the start orientation uses the magnetometer when given")] + start
    if name == "realtime":
        return head + _realtime_fields(v) + start
    raise ValueError(f"c-filter: no C port of filter {name!r}; available: {sorted(C_FILTERS)}")


def _realtime_fields(v: dict) -> list[CField]:
    """Every value of the realtime filter in its declaration's units (the C derives the per-sample gains)."""
    from objectives.attitude.filters.realtime import DECL

    out = []
    for p in DECL.params:
        if p.name in ("start", "init"):
            continue
        ctype = "int" if isinstance(p.default, bool) else "real"
        val = bool(v[p.name]) if ctype == "int" else float(v[p.name])
        out.append(CField(ctype, p.name, val, f"{p.doc}{', ' + p.unit if p.unit and p.unit != '1' else ''}"))
    out.append(CField("int", "start_q0", v["start"] == "q0", "1: strapdown start at the start orientation (init), "
                                                             "0: identity start (VQF's)"))
    return out


def _cf_fields(name: str, v: dict, g: float) -> list[CField]:
    """LCF, NCF and CCF share one kernel: the LCF has no PI gains, the NCF no blend, only the CCF robust options."""
    alpha = 1.0 if name == "ncf" else float(v["alpha"])
    kp, ki = (0.0, 0.0) if name == "lcf" else (float(v["Kp"]), float(v["Ki"]))
    mode = v.get("alpha_mode", "per_sample")
    rate = float(v.get("alpha_rate_hz", 0.0))
    if mode != "per_sample" and rate != 0.0:
        raise ValueError(f"c-filter: {name}: alpha_rate_hz={rate} applies to alpha_mode per_sample only")
    return [CField("real", "alpha", alpha, "gyro weight per sample, eq. (8) (1: no blend)"),
            CField("real", "Kp", kp, "proportional gain, 1/s (eq. (10))"),
            CField("real", "Ki", ki, "integral gain, 1/s^2 (eq. (10))"),
            CField("int", "use_mag", bool(v["use_mag"]), "yaw from the magnetometer (1) or the gyro only (0)"),
            CField("real", "acc_gate", float(v.get("acc_gate", math.inf)), "no correction when | |acc| - g | > "
                                                                             "acc_gate g"),
            CField("real", "g", float(g), "gravity in the accelerometer's unit"),
            CField("int", "alpha_mode", _ALPHA_MODES[mode], "0 per_sample, 1 tau (tau_s), 2 static (eq. (14))"),
            CField("real", "alpha_rate_hz", rate, "rate at which alpha is per sample (0: every rate)"),
            CField("real", "tau_s", float(v.get("tau_s", 0.1)), "blend time constant, s (alpha_mode 1)"),
            CField("real", "acc_lp_tau_s", float(v.get("acc_lp_tau_s", 0.0)), "earth-frame acc low-pass, s (0: off)"),
            CField("int", "mag_rejection", bool(v.get("mag_rejection", False)), "magnetic disturbance rejection"),
            CField("real", "mag_norm_th", float(v.get("mag_norm_th", 0.1)), "field norm threshold (fraction)"),
            CField("real", "mag_dip_th_deg", float(v.get("mag_dip_th_deg", 10.0)), "field dip threshold, deg"),
            CField("real", "mag_max_rejection_s", float(v.get("mag_max_rejection_s", 60.0)), "longest rejection, s"),
            CField("real", "mag_weight", float(v.get("mag_weight", 1.0)), "factor on the yaw correction")]


def _akf_defines(flt: Any, rate_hz: float) -> list[str]:
    """The AKF1D's packet and fuzzy constants (static tables: its sets, 9 rules and singletons), else AKF 0."""
    if flt.name != "akf1d":
        return ["#define AKF 0"]
    v = flt.values
    fis = flt.fis()
    f = np.fft.rfftfreq(int(v["fft_length"]), 1.0 / rate_hz)
    n_bins = int(np.searchsorted(f, float(v["f_thr"]) * (1 + 1e-12), side="right"))

    def arr(a, ctype="real"):
        a = np.asarray(a)
        if a.ndim == 1:
            return "{" + ", ".join(_literal(x, ctype) for x in a.tolist()) + "}"
        return "{" + ", ".join(arr(x, ctype) for x in a) + "}"

    return ["#define AKF 1", f"#define AKF_WINDOW {int(v['window'])}", f"#define AKF_NFFT {int(v['fft_length'])}",
            f"#define AKF_NBINS {n_bins} /* bins up to f_thr = {v['f_thr']!r} Hz at {rate_hz:g} Hz */",
            f"#define AKF_DF {_literal(f[1] - f[0], 'real')}",
            f"#define AKF_OMEGA_THR {_literal(v['omega_thr'], 'real')}",
            f"#define AKF_NRULES {fis.rules.shape[0]}", f"#define AKF_MF_INIT {arr(fis.mf_params)}",
            f"#define AKF_KIND_INIT {arr(fis.mf_kind, 'int')}", f"#define AKF_RULES_INIT {arr(fis.rules, 'int')}",
            f"#define AKF_CONS_INIT {arr(fis.consequents)}", *_akf_twiddles(int(v["fft_length"]))]


def _akf_twiddles(n_fft: int) -> list[str]:
    """sin(2 pi r / n_fft), r = 0 .. n_fft / 4: the DFT's twiddle factors by quarter-wave symmetry, so that
    the packet's DFT needs no sine or cosine per term (n_fft not a multiple of 4: computed per term)."""
    if n_fft % 4:
        return []
    tw = [math.sin(2.0 * math.pi * r / n_fft) for r in range(n_fft // 4 + 1)]
    return [f"#define AKF_TW_INIT {{{', '.join(_literal(x, 'real') for x in tw)}}}"]


def _literal(x: Any, ctype: str) -> str:
    if isinstance(x, list):
        return "{" + ", ".join(_literal(e, ctype) for e in x) + "}"
    if ctype == "int":
        return str(int(x))
    x = float(x)
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    s = repr(x)
    return s if ("." in s or "e" in s) else s + ".0"


def _quat_literal(q: np.ndarray) -> str:
    return "{" + ", ".join(_literal(float(c), "real") for c in q) + "}"


#: the streaming functions' definitions in the templates, made static (run.c defines the exported names)
_API_DEF = re.compile(r"^void PFX_(init|update|quaternion|set_quaternion)\(", re.MULTILINE)


def _template(name: str) -> str:
    return resources.files(__package__).joinpath("templates", name).read_text()


def render_c_filter(flt: Any, *, rate_hz: float, g: float = 9.80665, init: str = "accmag", q0=None,
                    precision: str = "double", prefix: str = "ATT", frame: str = "ENU",
                    comment: str = "") -> dict[str, str]:
    """Header and source of ``flt``'s C port with its values baked into ``PREFIX_tuned``.

    Parameters
    ----------
    flt : AttitudeFilter
        A validated Madgwick, Mahony or EKF (its ``values`` are the complete configuration).
    rate_hz : float
        Sample rate the values assume, Hz (``dt_s = 1 / rate_hz``; coefficients follow a changed ``dt``).
    g : float
        Gravity in the accelerometer's unit (the EKF's ``acc_gate`` and rest detection).
    init : {"accmag", "broad", "given"}
        Start orientation: first sample, BROAD's quatFromAccMag, or ``q0`` (working frame).
    precision : {"double", "float"}
    prefix : str
        Prefix of every public C identifier; the files are ``<prefix lower>.h`` and ``.c``.
    frame : {"ENU", "NED", "NWU"}
        Earth frame of ``PREFIX_quaternion`` (and of ``PREFIX_set_quaternion``).
    comment : str
        Text for the header's leading comment (units, rate, provenance).

    Returns
    -------
    dict
        ``{filename: text}`` for the header and the source.
    """
    from objectives.attitude.quaternion.conversions import frame_rotation, qconj_batch

    name = flt.name
    if name not in C_FILTERS:
        raise ValueError(f"c-filter: no C port of filter {name!r}; available: {sorted(C_FILTERS)}")
    if precision not in ("double", "float"):
        raise ValueError(f"c-filter: precision must be 'double' or 'float', got {precision!r}")
    if init not in _INIT:
        raise ValueError(f"c-filter: init must be one of {sorted(_INIT)}, got {init!r}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"c-filter: rate_hz must be a finite number > 0, got {rate_hz!r}")
    pfx = c_identifier(prefix)
    base = pfx.lower()
    fields = _fields(name, flt.values, 1.0 / rate_hz, g, init, q0, -1.0 if frame.upper() == "NED" else 1.0)
    work = flt.working_frame
    # the 1-D tilt filter's quaternion is a rotation about y in the frame it is defined in (``frame``)
    rot = np.array([1.0, 0.0, 0.0, 0.0]) if name in _TILT else frame_rotation(work, frame.upper())

    params = "\n".join(f"    {'PFX_real' if f.ctype == 'real' else 'int'} {f.name}; /* {f.doc} */" for f in fields)
    if name in _TILT:
        state = ("PFX_real th;       /* tilt angle about y, rad */\n"
                 "PFX_real b;        /* gyro bias, rad/s */\n"
                 "PFX_real p00;      /* covariance */\n"
                 "PFX_real p01;\n"
                 "PFX_real p11;\n"
                 "PFX_real prev_gyr; /* the previous gyro sample about y, rad/s */\n"
                 "PFX_real dt_s;\n"
                 "int started;\n"
                 "PFX_params p;\n")
        if name == "akf1d":
            state += (f"PFX_real buf[{int(flt.values['window'])}]; /* the gyro about y of the current packet */\n"
                      "PFX_real ext_sum;  /* its sum of external acceleration, g */\n"
                      "int nbuf;          /* samples in it */\n"
                      "PFX_real kscale;   /* the held fuzzy scale K of R (eq. 3.24) */\n"
                      "PFX_real vib_hz;   /* the last packet's vibration frequency, Hz */\n"
                      "PFX_real ext_g;    /* and external acceleration, g */\n")
    elif name in ("lcf", "ncf", "ccf"):
        state = ("PFX_real x[3];        /* roll, pitch, yaw (ZYX, NED), rad: the state */\n"
                 "PFX_real integ[3];    /* the PI integrals, rad/s */\n"
                 "PFX_real out[3];      /* the last output angles, rad */\n"
                 "PFX_real alpha;       /* per-sample gains at dt_s */\n"
                 "PFX_real kp;\n"
                 "PFX_real mag_gain;    /* the last factor on the yaw correction */\n") + _ROBUST_STATE
    elif name == "realtime":
        state = ("PFX_real c[45];  /* per-sample coefficients at dt_s (layout of _realtime_kernel.py) */\n"
                 "PFX_real s[79];  /* the state carried between samples (same layout) */\n"
                 "int lpf[6];      /* phase of each low-pass: 0 no sample, 1 averaging its first tau, 2 running */\n"
                 "PFX_real dt_s;\n"
                 "int started;     /* 0: start orientation from the next sample (start_q0) */\n"
                 "PFX_params p;\n")
    elif name == "ekf":
        state = ("PFX_real x[7];        /* state: quaternion (working frame NED) and gyro bias, rad/s */\n"
                 "PFX_real P[7][7];     /* its covariance */\n"
                 "PFX_real prev_gyr[3]; /* the previous gyro sample */\n"
                 "PFX_real mag_gain;    /* the last sample's magnetometer gain (1: used fully) */\n") + _ROBUST_STATE
    else:
        state = _BIAS_STATE + _ROBUST_STATE
    state = "\n".join("    " + line for line in state.splitlines())
    header = _template("header.h").replace("@PARAMS@", params).replace("@STATE@", state)
    header = header.replace("@REAL@", precision).replace("@FRAME@", frame.upper())
    comment = comment.replace("/*", "/ *").replace("*/", "* /")  # nothing in it may end the comment
    header = "/*\n" + "\n".join((" * " + line).rstrip() for line in comment.splitlines()) + "\n */\n" + header

    init_vals = ",\n".join(f"    {_literal(f.value, f.ctype)} /* {f.name.split('[')[0]} */" for f in fields)
    fl = precision == "float"
    pre = [f"/* {name} filter, {precision} precision; see {base}.h. Generated: edit the tuning, not this file. */",
           "#include <math.h>", f'#include "{base}.h"', "",
           "typedef PFX_real real;",
           f"#define SQRT {'sqrtf' if fl else 'sqrt'}",
           f"#define EXP {'expf' if fl else 'exp'}",
           f"#define ASIN {'asinf' if fl else 'asin'}",
           f"#define ATAN2 {'atan2f' if fl else 'atan2'}",
           "#define ISNAN_(x) isnan(x)",
           f"#define WORK_FRAME {({'ENU': 0, 'NED': 1}).get(work, 2)} /* {work} */",
           f"#define NWU_TO_WORK {_quat_literal(frame_rotation('NWU', work))}",
           f"#define WORK_TO_OUT {_quat_literal(rot)}",
           f"#define OUT_TO_WORK {_quat_literal(qconj_batch(rot))}", *_akf_defines(flt, rate_hz), ""]
    extra = ["bias_prologue.c"] if name in ("madgwick", "mahony") else ["trig.c"]
    if name in (*_TILT, "lcf", "ncf", "ccf"):
        extra.append("angle.c")  # floor_ for the angle wrapping (a static function no filter uses would warn)
    parts = ["common.c", *(["robust.c"] if name not in (*_TILT, "realtime") else []), *extra, C_FILTERS[name],
             "run.c"]
    body = _API_DEF.sub(r"static void PFX_\1_(", "\n".join(_template(p) for p in parts[:-1]))
    body += "\n" + _template(parts[-1])  # run.c: the exported names of the static functions and PFX_run
    if name == "madgwick":
        body = body.replace("BIAS_OUT", "int i;\n    for (i = 0; i < 3; i++)\n"
                                        "        b[i] = f->b[i] + (f->p.rest_bias ? f->rs[8 + i] : 0.0);")
    else:
        body = body.replace("BIAS_OUT", "int i;\n    for (i = 0; i < 3; i++)\n"
                                        "        b[i] = (f->p.rest_bias ? f->rs[8 + i] : 0.0) - f->b[i];")
    tuned = f"const PFX_params PFX_tuned = {{\n{init_vals}\n}};\n"
    source = "\n".join(pre) + "\n" + tuned + "\n" + body
    if fl:
        source = _FLOAT_LIT.sub(lambda m: m.group(1) + "f", source).replace("fabs(", "fabsf(")
    files = {f"{base}.h": header.replace("PFX_", pfx + "_"), f"{base}.c": source.replace("PFX_", pfx + "_")}
    return files
