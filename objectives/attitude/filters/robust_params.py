"""The robust blocks' parameters (:mod:`objectives.attitude.filters.robust`), declared once for every filter
that offers them (EKF, FAEKF, QRAUKF). All blocks are off by default: the filter is then the paper's, bit for bit.
"""

from __future__ import annotations

from objectives.params import POSITIVE, Interval, Param

__all__ = ["robust_decl", "ROBUST_SWITCHES"]

#: the options that switch a block on (a truthy value turns it on)
ROBUST_SWITCHES = ("acc_lp_tau_s", "mag_rejection", "rest_bias")


def robust_decl(acc_feeds: str, rejected: str) -> tuple[Param, ...]:
    """Declarations of the robust blocks' options.

    Parameters
    ----------
    acc_feeds : str
        What the low-passed accelerometer feeds in this filter (for the docs), e.g. ``"the TRIAD"``.
    rejected : str
        What happens to a rejected magnetic field in this filter (for the docs).
    """
    return (
        Param("acc_lp_tau_s", 0.0, unit="s", allowed=Interval(0.0),
              doc=f"time constant of the earth-frame accelerometer low-pass feeding {acc_feeds} (robust block c; "
                  "0: raw accelerometer, as the paper); 3-5 s keeps inclination through fast translation"),
        Param("mag_rejection", False, choices=(True, False),
              doc="magnetic disturbance rejection (robust block a): field norm and dip against a reference "
                  f"learned when undisturbed; {rejected}"),
        Param("mag_max_rejection_s", 60.0, unit="s", allowed=POSITIVE,
              doc="longest full rejection of a disturbed field before a new field is accepted (mag_rejection)"),
        Param("mag_norm_th", 0.1, unit="1", allowed=POSITIVE,
              doc="relative field-norm deviation beyond which the field is disturbed (mag_rejection)"),
        Param("mag_dip_th_deg", 10.0, unit="deg", allowed=POSITIVE,
              doc="dip-angle deviation beyond which the field is disturbed (mag_rejection)"),
        Param("rest_bias", False, choices=(True, False),
              doc="gyro bias estimation at rest (robust block b): at detected rest the low-passed gyro "
                  "measures the bias state"),
        Param("rest_bias_var", 3e-6, unit="(rad/s)^2", allowed=POSITIVE,
              doc="variance of the rest bias pseudo-measurement (rest_bias)"),
    )
