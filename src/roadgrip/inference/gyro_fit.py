r"""The yaw-rate gyro's scale and bias against the pose's heading, for ``roadgrip vehicle fit``.

A gyro reads ``r_meas = s r + b``: a scale ``s`` within a percent or two of 1 and a bias
``b`` of a few mrad/s. Both matter to every estimator that integrates ``a_y - v_x r``: a
bias of 5 mrad/s is a lateral-acceleration error of 0.06 m/s² at 12 m/s, which a
lateral-velocity filter turns into a ``v_y`` error of 0.1-0.2 m/s and the slip angles
into 0.01-0.02 rad (``random:117``: with the true yaw rate in place of its gyro, the
cascade's ``v_y`` error in steady cornering falls from -0.24 to -0.01 m/s).

The pose's heading is a reference with no scale error and a constant bias, which its
derivative drops: ``r_meas(t) = s dpsi/dt(t + d) + b``, ``d`` the pose's delay behind the gyro
(``delay_pose``). Both sides pass one filter: the heading and the gyro's integral are
differentiated by one Savitzky-Golay filter of :data:`WINDOW` (smoothing the gyro with the
same window instead would read the scale 2-3 % high: a quadratic fit's centre value passes more
of a slalom than its centre slope does); samples within
reach of a value either channel's logger held
(:func:`~roadgrip.inference.least_squares.held_samples`) are left out, standstill is kept (it
pins the bias). The heading's derivative is the noisier side (0.005 rad of heading noise against
the gyro's 0.005 rad/s), so it is regressed on the gyro and the line inverted; the other way
round reads the scale 0.6 % low on the random family. Standard errors from :func:`~roadgrip.inference.least_squares.lstsq`
(inflated for the residuals' correlation).
"""

from __future__ import annotations

import numpy as np

from roadgrip.drive import Drive
from roadgrip.inference.fit_signals import dilate, half_width, shifted, smooth
from roadgrip.inference.fitted_value import FittedValue, fitted, undetermined
from roadgrip.inference.least_squares import held_samples, lstsq

__all__ = ["MIN_RATE_STD", "WINDOW", "fit_gyro"]

WINDOW = 0.5
"""Savitzky-Golay window [s] of both sides (the heading's derivative needs the smoothing:
0.005 rad of heading noise at 100 Hz is 0.35 rad/s differentiated sample to sample)."""
MIN_RATE_STD = 0.05
"""Least standard deviation [rad/s] of the yaw rate over the samples used: below it the
scale is not separated from the bias."""
MIN_SAMPLES = 500
"""Fewest samples for the fit."""


def fit_gyro(drive: Drive, dt: float, pose_delay: FittedValue | None) -> dict[str, FittedValue]:
    """``yaw_rate_scale`` [-] and ``yaw_rate_bias`` [rad/s] of the drive's gyro (module docstring).

    Parameters
    ----------
    drive : Drive
        On a uniform clock of step ``dt`` [s], with ``yaw_rate``.
    dt : float
    pose_delay : FittedValue or None
        The pose's delay behind the gyro; without a fitted one both are undetermined.

    Returns
    -------
    dict of str to FittedValue
        Both values, fitted or undetermined with the reason (undetermined: scale 1, bias 0).
    """
    def none(why: str) -> dict[str, FittedValue]:
        return {"yaw_rate_scale": undetermined("yaw_rate_scale", "-", why, 1.0),
                "yaw_rate_bias": undetermined("yaw_rate_bias", "rad/s", why, 0.0)}

    if not drive.has("psi") or pose_delay is None or not pose_delay.fitted:
        return none("needs a pose (psi) with its delay fitted")
    t = drive.t
    psi = drive.col("psi")
    r = drive.col("yaw_rate")
    ok = np.isfinite(psi) & np.isfinite(r)
    if ok.sum() < MIN_SAMPLES:
        return none("too few samples with a pose")
    k = half_width(dt, WINDOW)
    bad = dilate(~ok | held_samples(np.where(ok, psi, 0.0)) | held_samples(np.where(ok, r, 0.0)), k)
    psi_u = np.unwrap(np.interp(t, t[ok], psi[ok]))
    r_f = np.interp(t, t[ok], r[ok])
    rate = shifted(t, smooth(psi_u, dt, WINDOW, deriv=1), pose_delay.value)
    bad = bad | (shifted(t, bad.astype(float), pose_delay.value) > 0.0)
    # the same filter on both sides: the gyro integrated, then differentiated as the heading
    # is (a quadratic fit's centre slope passes less than its centre value would)
    heading = np.concatenate(([0.0], np.cumsum(0.5 * (r_f[1:] + r_f[:-1]) * np.diff(t))))
    gyro = smooth(heading, dt, WINDOW, deriv=1)
    sel = ~bad
    sel[:k] = sel[-k:] = False
    if sel.sum() < MIN_SAMPLES or np.std(rate[sel]) < MIN_RATE_STD:
        return none("too little turning against the pose")
    # the heading's derivative is the noisier side: regress it on the gyro, dpsi/dt = (r - b)/s
    beta, cov, _ = lstsq(np.column_stack([gyro[sel], np.ones(sel.sum())]), rate[sel])
    scale = 1.0 / beta[0]
    bias = -beta[1] * scale
    # delta method: d(scale) = -scale² d(beta0); d(bias) = -scale d(beta1) + beta1 scale² d(beta0)
    jac = np.array([[-scale**2, 0.0], [beta[1] * scale**2, -scale]])
    c = jac @ cov @ jac.T
    note = "r = s dpsi/dt + b against the pose's heading"
    return {"yaw_rate_scale": fitted("yaw_rate_scale", scale, np.sqrt(c[0, 0]), "-", note),
            "yaw_rate_bias": fitted("yaw_rate_bias", bias, np.sqrt(c[1, 1]), "rad/s", note)}
