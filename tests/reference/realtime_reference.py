"""Slow reference of the ``realtime`` filter: the ``vqf`` package's pure-Python implementation (``PyVQF``, the
published reference of Laidig & Seel 2023, one sample per call in NumPy), with the project's two additions
(``mag_first_at_rest``, ``mag_recover_tau_s``) written into a subclass's magnetometer step (PyVQF detects rest on
the accelerometer only with the rest bias on: the cases with ``mag_first_at_rest`` keep it on).

Used by tests/attitude/test_realtime.py to check the numba kernel sample by sample.
"""

from __future__ import annotations

import math

import numpy as np

#: the realtime filter's name -> PyVQF's parameter name (same units)
NAMES = {
    "tau_acc_s": "tauAcc", "tau_mag_s": "tauMag", "motion_bias": "motionBiasEstEnabled",
    "rest_bias": "restBiasEstEnabled", "mag_rejection": "magDistRejectionEnabled",
    "bias_sigma_init_dps": "biasSigmaInit", "bias_forgetting_s": "biasForgettingTime", "bias_clip_dps": "biasClip",
    "bias_sigma_motion_dps": "biasSigmaMotion", "bias_vertical_forgetting": "biasVerticalForgettingFactor",
    "bias_sigma_rest_dps": "biasSigmaRest", "rest_min_s": "restMinT", "rest_filter_tau_s": "restFilterTau",
    "rest_th_gyr_dps": "restThGyr", "rest_th_acc": "restThAcc", "mag_current_tau_s": "magCurrentTau",
    "mag_ref_tau_s": "magRefTau", "mag_norm_th": "magNormTh", "mag_dip_th_deg": "magDipTh",
    "mag_new_s": "magNewTime", "mag_new_first_s": "magNewFirstTime", "mag_new_min_gyr_dps": "magNewMinGyr",
    "mag_min_undisturbed_s": "magMinUndisturbedTime", "mag_max_rejection_s": "magMaxRejectionTime",
    "mag_rejection_factor": "magRejectionFactor",
}


def reference_run(values: dict, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray | None, dt: float) -> dict:
    """``{"quat": (N, 4) ENU, "bias": (N, 3), "rest": (N,), "mag_dist": (N,)}`` of the slow reference."""
    from vqf import PyVQF

    first_at_rest = bool(values.get("mag_first_at_rest", False))
    recover_tau = float(values.get("mag_recover_tau_s", 0.0))

    class _Ref(PyVQF):
        def updateMag(self, m):  # noqa: N802 - PyVQF's name
            if m[0] == 0.0 and m[1] == 0.0 and m[2] == 0.0:
                return
            st, p, ts = self._state, self._params, self._coeffs.magTs
            first_rest_ok = first_at_rest and st.magRefNorm == 0.0 and st.restDetected
            h = self.quatRotate(self.getQuat6D(), m)
            if p.magDistRejectionEnabled:
                nd = np.array([math.sqrt(h.dot(h)), -math.asin(h[2] / math.sqrt(h.dot(h)))])
                if p.magCurrentTau > 0:
                    nd = self.filterVec(nd, p.magCurrentTau, ts, self._coeffs.magNormDipLpB,
                                        self._coeffs.magNormDipLpA, st.magNormDipLpState)
                dip_th = p.magDipTh * np.pi / 180.0
                kref = self._coeffs.kMagRef
                if abs(nd[0] - st.magRefNorm) < p.magNormTh * st.magRefNorm and abs(nd[1] - st.magRefDip) < dip_th:
                    st.magUndisturbedT += ts
                    if st.magUndisturbedT >= p.magMinUndisturbedTime:
                        st.magDistDetected = False
                        st.magRefNorm += kref * (nd[0] - st.magRefNorm)
                        st.magRefDip += kref * (nd[1] - st.magRefDip)
                else:
                    st.magUndisturbedT = 0.0
                    st.magDistDetected = True
                if abs(nd[0] - st.magCandidateNorm) < p.magNormTh * st.magCandidateNorm and \
                        abs(nd[1] - st.magCandidateDip) < dip_th:
                    g = st.restLastGyrLp
                    if math.sqrt(g.dot(g)) >= p.magNewMinGyr * np.pi / 180.0 or first_rest_ok:
                        st.magCandidateT += ts
                    st.magCandidateNorm += kref * (nd[0] - st.magCandidateNorm)
                    st.magCandidateDip += kref * (nd[1] - st.magCandidateDip)
                    if st.magDistDetected and (st.magCandidateT >= p.magNewTime or (
                            st.magRefNorm == 0.0 and st.magCandidateT >= p.magNewFirstTime)):
                        st.magRefNorm, st.magRefDip = st.magCandidateNorm, st.magCandidateDip
                        st.magDistDetected = False
                        st.magUndisturbedT = p.magMinUndisturbedTime
                else:
                    st.magCandidateT = 0.0
                    st.magCandidateNorm, st.magCandidateDip = nd[0], nd[1]
            dis = math.atan2(h[0], h[1]) - st.delta
            if dis > np.pi:
                dis -= 2 * np.pi
            elif dis < -np.pi:
                dis += 2 * np.pi
            k = self._coeffs.kMag
            if p.magDistRejectionEnabled:
                if st.magDistDetected:
                    if st.magRejectT <= p.magMaxRejectionTime:
                        st.magRejectT += ts
                        k = 0
                    else:
                        k /= p.magRejectionFactor
                else:
                    k_rec = 1.0 - math.exp(-ts / recover_tau) if recover_tau > 0 else 0.0
                    if st.magRejectT > 0.0 and k_rec > k:
                        k = k_rec
                    st.magRejectT = max(st.magRejectT - p.magRejectionFactor * ts, 0.0)
            if st.kMagInit != 0.0:
                k = max(k, st.kMagInit)
                st.kMagInit = st.kMagInit / (st.kMagInit + 1)
                if st.kMagInit * p.tauMag < ts:
                    st.kMagInit = 0.0
            st.delta += k * dis
            if st.delta > np.pi:
                st.delta -= 2 * np.pi
            elif st.delta < -np.pi:
                st.delta += 2 * np.pi

    params = {NAMES[k]: v for k, v in values.items() if k in NAMES}
    f = _Ref(dt, **params)
    n = gyr.shape[0]
    out = {"quat": np.empty((n, 4)), "bias": np.empty((n, 3)), "rest": np.empty(n, bool), "mag_dist": np.empty(n, bool)}
    for i in range(n):
        f.update(np.array(gyr[i], float), np.array(acc[i], float), None if mag is None else np.array(mag[i], float))
        out["quat"][i] = f.getQuat9D() if mag is not None else f.getQuat6D()
        out["bias"][i] = f.getBiasEstimate()[0]
        out["rest"][i] = f.getRestDetected()
        out["mag_dist"][i] = f.getMagDistDetected()
    return out
