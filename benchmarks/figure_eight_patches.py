"""What the GP-SSM can see of the multi-body figure-eight's snow patches (issue 31).

Run: ``.venv/bin/python benchmarks/figure_eight_patches.py [--vehicles ford-escort vw-vanagon] [--seed 0]``.

The figure-eight (``roadgrip simulate figure-eight --engine multibody``) drives laps of
dry asphalt (mu 1.0) with gravel (0.6) and snow (0.3) patches of 1.4-4.3 s. On the snow
patches the GP-SSM's unobserved peaks keep lower bounds learned on the dry laps
(0.41-0.63) where the truth is 0.30: the honesty matrix's open GP-SSM cells. This script
runs the filter as the matrix runs it (:mod:`roadgrip.evaluate.honesty_matrix`) and
prints, per vehicle and axle, the evidence a change detector would need:

- **truth**: the axle's ``|F_y / F_z|`` at true slip angles of 0.8-1.0 deg on dry
  asphalt and on snow (the snow tire saturates there: the patch is visible to anyone who
  knows the slip angle);
- **filter**: on the snow samples, the filter's own used friction ``mu_now`` over the
  median ``mu_now`` of the dry laps at the same *estimated* slip angle (1.0: the snow data
  lie on the curve learned on dry asphalt), and the estimated over the true slip angle
  on dry and on snow (without a measured lateral velocity the slip angles' scale is not
  identified: the curve learned on dry is stretched in slip, and the snow data fall on
  it);
- the median effective sample size on dry asphalt and on snow (the likelihood's view);
- the excess understeer ``delta - L r / v_x`` on snow over its dry-lap regression on
  ``a_y``, against that regression's residual scatter (the one measured signal left).

Then, for the lower bounds: the final rear lower bound the multi-body snow slaloms
would keep if lower bounds held only the friction used in the last second of driving
with ``|a_y| >= 0.05 g`` (the issue asks for at least 0.25; pass ``--slaloms``, 10 runs
of 200 s).

Not a test: it prints what ``docs/validation-honesty.md`` quotes.
"""

from __future__ import annotations

import argparse
from collections import deque

import numpy as np

from roadgrip.constants import GRAVITY


def recent_used(t, ay, used, window=1.0, min_ay=0.05):
    """Largest ``used`` over the last ``window`` seconds of samples with ``|ay| >= min_ay g``.

    Parameters
    ----------
    t, ay, used : ndarray, shape (n,)
        Time [s], lateral acceleration [m/s²], the axle's used friction [-].

    Returns
    -------
    ndarray, shape (n,)
        0 before the first such sample.
    """
    out = np.zeros(len(t))
    clock, last, dq = 0.0, None, deque()
    for i in range(len(t)):
        if abs(ay[i]) >= min_ay * GRAVITY:
            clock += 0.0 if last is None else t[i] - last
            while dq and dq[-1][1] <= used[i]:
                dq.pop()
            dq.append((clock, used[i]))
        last = t[i]
        while dq and dq[0][0] < clock - window:
            dq.popleft()
        out[i] = dq[0][1] if dq else 0.0
    return out


def patch_evidence(vehicle: str, seed: int) -> list[str]:
    """The lines of the module docstring for one figure-eight drive."""
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.honesty import score_result
    from roadgrip.evaluate.honesty_matrix import GPSSM_OPTIONS, DriveSpec, load_drive
    from roadgrip.io.presets import preset_options

    spec = DriveSpec(f"mb:{vehicle}:figure-eight:{seed}", "figure-eight", vehicle, seed)
    drive, _ = load_drive(spec)
    result = run_estimator("gpssm", drive, {**GPSSM_OPTIONS, **preset_options("gpssm", drive)}, seed=0)
    tb = result.table
    score = score_result(result, drive)
    c = drive.col
    mu = c("mu_true")
    dry, snow = mu == 1.0, mu == 0.3
    lines = [f"{spec.name}: axle bands wrong on {100 * score.wrong_axle:.1f} % of the samples"]
    for axle, k in (("front", "f"), ("rear", "r")):
        a_true = np.degrees(np.abs(c(f"alpha_{k}_true")))
        used_true = np.abs(c(f"Fy{k}_true") / c(f"Fz{k}_true"))
        band = (a_true > 0.8) & (a_true < 1.0)
        td = np.median(used_true[band & dry]) if (band & dry).sum() else np.nan
        ts = np.median(used_true[band & snow]) if (band & snow).sum() else np.nan
        a_est = np.degrees(np.abs(tb[f"alpha_{k}"].to_numpy()))
        used = np.abs(tb[f"mu_now_{axle}"].to_numpy())
        bins = np.arange(0.2, 3.0, 0.1)
        d_sel = dry & (a_est > 0.2)
        j_dry = np.digitize(a_est[d_sel], bins)
        curve = np.array([np.median(used[d_sel][j_dry == j]) if (j_dry == j).sum() > 20 else np.nan
                          for j in range(len(bins) + 1)])
        s_sel = snow & (a_est > 0.6)
        pred = curve[np.digitize(a_est[s_sel], bins)]
        ok = np.isfinite(pred)
        on_curve = np.median(used[s_sel][ok] / pred[ok])
        r_dry = np.median(a_est[dry & (a_true > 0.8)] / a_true[dry & (a_true > 0.8)])
        r_snow = np.median(a_est[snow & (a_true > 0.5)] / a_true[snow & (a_true > 0.5)])
        lines.append(f"  {axle}: truth |Fy/Fz| at 0.8-1.0 deg: dry {td:.3f}, snow {ts:.3f}; "
                     f"filter: snow mu_now / dry-lap curve at the same estimated slip {on_curve:.2f}; "
                     f"estimated / true slip: dry {r_dry:.2f}, snow {r_snow:.2f}")
    ess = tb["ess"].to_numpy()
    lines.append(f"  effective sample size (median of 200): dry {np.median(ess[dry]):.0f}, "
                 f"snow {np.median(ess[snow]):.0f}")
    veh = drive.vehicle
    under = np.degrees(c("steer") - (veh.lf + veh.lr) * c("yaw_rate") / np.maximum(c("vx"), 1.0))
    ay_g = c("ay") / GRAVITY
    sel = dry & (np.abs(ay_g) > 0.1) & (c("vx") > 5.0)
    coef = np.polyfit(ay_g[sel], under[sel], 1)
    resid = under[sel] - np.polyval(coef, ay_g[sel])
    s_sel = snow & (np.abs(ay_g) > 0.1) & (c("vx") > 5.0)
    excess = under[s_sel] - np.polyval(coef, ay_g[s_sel])
    lines.append(f"  understeer on snow over the dry laps' line: median {np.median(np.abs(excess)):.2f} deg, "
                 f"dry residual std {resid.std():.2f} deg")
    return lines


def slalom_lower_bounds() -> list[str]:
    """Final rear lower bounds of the multi-body snow slaloms: as reported, and held to
    the friction used in the last second of driving (:func:`recent_used`)."""
    from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
    from roadgrip.sim.scenarios import simulate_scenario

    lines = []
    for vehicle in ("ford-escort", "vw-vanagon"):
        for seed in range(5):
            d = simulate_scenario("snow-slalom", seed=seed, engine="multibody", vehicle=vehicle)
            tb, _ = run_filter(d, GPSSMConfig(particles=200), seed=seed)
            t = tb["t"].to_numpy()
            cap = recent_used(t, d.col("ay"), np.abs(tb["mu_now_rear"].to_numpy()))
            lo = float(tb["mu_rear_lower"].iloc[-1])
            lines.append(f"snow-slalom {vehicle} seed {seed}: final rear lower bound {lo:.3f}, "
                         f"held to the last second's used friction {min(lo, cap[-1]):.3f}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", nargs="+", default=["ford-escort", "vw-vanagon"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--slaloms", action="store_true")
    a = ap.parse_args()
    for v in a.vehicles:
        print("\n".join(patch_evidence(v, a.seed)), flush=True)
    if a.slaloms:
        print("\n".join(slalom_lower_bounds()))


if __name__ == "__main__":
    main()
