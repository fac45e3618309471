"""Why the cascade is excited so rarely on the race car (issue 29), measured per excitation test.

Run: ``.venv/bin/python benchmarks/race_car_cascade.py [--out DIR]`` (about 1 min).

The race car (``../shared/data/revs``) is split at its middle as ``benchmarks/race_car.py``
splits it: ``vehicle fit`` on the first half, the cascade on the second half read with
the fitted file (and with the shipped ``race_car.yaml`` for comparison). Printed:

1. the share of excited samples (either axle, front, rear) and the honesty rule's verdict
   (:func:`roadgrip.evaluate.honesty.score_result` with the INS ``v_y``) with the
   default settings and with one excitation test switched off at a time: the slip-angle
   bias test (``max_slip_bias_effect``), the slip-noise test (``slip_noise_z``), both, the
   sliding-range test (``max_slip_ratio``) and the information threshold
   (``excitation_std``); and with other cornering stiffnesses (the fallback 1e5 N/rad is
   what the file gives the cascade);
2. the slip angles' error against the INS (``-atan((v_y,ref - l_r r) / v_x)`` for the rear
   axle) by lateral acceleration, beside the slip-angle standard deviation the cascade
   states and the slip angle itself, and the linear-range stiffness the INS's slip angles
   give (``F_y / (F_z tan alpha)`` at 0.1-0.4 g);
3. per variant, two judgements of the excited observations that the honesty rule cannot
   make here: the share more than 2 stated standard deviations off the brush inversion at
   the INS's slip angle (same stiffness), and the share whose 95 % upper end lies below the
   grip the car sustained at that speed (the largest 1 s mean ``|a_y|/g`` within ±5 m/s);
4. the reach: the cascade given the INS's own lateral velocity as a pose velocity (an
   oracle, for this measurement only: the reference is never an estimator input).

The switched-off variants are measurements, not candidates: a test switched off is judged
by the slip-angle errors in 2, not by the honesty rule alone, which on this recording has
no friction truth (only the grip the car used).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import time
from pathlib import Path

import numpy as np

from race_car import fit_first_half  # the split and the fit of benchmarks/race_car.py (same folder)

BANDS_G = ((0.0, 0.3), (0.3, 0.6), (0.6, 0.9), (0.9, 3.0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="directory for the fitted vehicle file")
    args = ap.parse_args()

    from roadgrip.constants import GRAVITY, Z95
    from roadgrip.drive import Drive
    from roadgrip.estimators import run_estimator
    from roadgrip.estimators.cascade import brush_mu_inverse
    from roadgrip.evaluate.honesty import score_result
    from roadgrip.evaluate.honesty_matrix import reference_vy
    from roadgrip.io import read_drive

    path, shipped, mid, fit, car = fit_first_half(Path(args.out) if args.out else Path("report") / "race_car")
    halves = {"fitted": read_drive(path, format="canonical", vehicle=str(car)).slice_time(mid, np.inf),
              "shipped": shipped.slice_time(mid, np.inf)}

    def stiff(drive: Drive, cf: float, cr: float) -> Drive:
        v = dataclasses.replace(drive.vehicle, cornering_stiffness_front=cf, cornering_stiffness_rear=cr)
        return Drive(drive.data, dataclasses.replace(drive.meta, vehicle=v))

    def ins_slip(tab, drive: Drive, vy_ref: np.ndarray) -> dict[str, np.ndarray]:
        """Slip angles with the INS's lateral velocity [rad] (front: the file's steering)."""
        vx = tab["vx"].to_numpy()
        r = tab["yaw_rate_est"].to_numpy()
        v = drive.vehicle
        return {"front": drive.col("steer") - np.arctan((vy_ref + v.lf * r) / vx),
                "rear": -np.arctan((vy_ref - v.lr * r) / vx)}

    def off_ins(tab, drive: Drive, vy_ref: np.ndarray) -> float:
        """Share of the excited observations more than 2 stated standard deviations (with the
        systematic part) from the brush inversion at the INS's slip angle (same force, load,
        stiffness and longitudinal force): the slip angle's error beyond what is stated."""
        ins = ins_slip(tab, drive, vy_ref)
        v = drive.vehicle
        bad = n = 0
        for axle, a in (("front", "f"), ("rear", "r")):
            ex = tab[f"excited_{axle}"].to_numpy(bool)
            if not ex.any():
                continue
            fz = tab[f"Fz{a}"].to_numpy()[ex]
            k = getattr(v, f"cornering_stiffness_{axle}") / (v.fz_front if axle == "front" else v.fz_rear)
            cap, _, _ = brush_mu_inverse(tab[f"Fy{a}"].to_numpy()[ex], ins[axle][ex], fz, k)
            mu_ins = np.sqrt(cap**2 + (tab[f"Fx_{axle}"].to_numpy()[ex] / fz) ** 2)
            sd = np.hypot(tab[f"mu_{axle}_obs_std"].to_numpy()[ex], tab[f"mu_{axle}_obs_sys"].to_numpy()[ex])
            bad += int(np.sum(~(np.abs(tab[f"mu_{axle}_obs"].to_numpy()[ex] - mu_ins) <= 2.0 * sd)))
            n += int(ex.sum())
        return bad / n if n else float("nan")

    def speed_floor(drive: Drive) -> np.ndarray:
        """Per sample, the largest 1 s mean |a_y| / g the car sustained in the half within
        ±5 m/s of its speed [-]: the friction an axle demonstrably has there (steady cornering
        puts F_y / F_z,static = a_y / g on both axles; the track is dry throughout)."""
        n = max(round(drive.meta.sample_rate), 1)
        ay = np.abs(drive.col("ay"))
        mean_1s = np.convolve(ay, np.ones(n) / n, mode="same") / GRAVITY
        vx = drive.col("vx")
        return np.array([mean_1s[np.abs(vx - v) < 5.0].max() for v in vx])

    def below_floor(tab, floor: np.ndarray) -> float:
        """Share of the excited observations whose 95 % upper end (standard deviation and
        systematic part) lies below the grip the car sustained at that speed."""
        bad = n = 0
        for axle in ("front", "rear"):
            ex = tab[f"excited_{axle}"].to_numpy(bool)
            sd = np.hypot(tab[f"mu_{axle}_obs_std"].to_numpy()[ex], tab[f"mu_{axle}_obs_sys"].to_numpy()[ex])
            bad += int(np.sum(tab[f"mu_{axle}_obs"].to_numpy()[ex] + Z95 * sd < floor[ex]))
            n += int(ex.sum())
        return bad / n if n else float("nan")

    def with_ins_pose(drive: Drive, vy_ref: np.ndarray) -> Drive:
        df = drive.data.copy()
        df["vx_pose"] = df["vx"]
        df["vy_pose"] = vy_ref
        return drive.with_data(df)

    scale = fit.values["steer_scale"].value if "steer_scale" in fit.values else float("nan")
    print(f"{'file':8s} {'variant':44s} {'excited':>8s} {'front':>6s} {'rear':>6s}  honest (wrong)  off the INS  below the grip used")
    for name, half in halves.items():
        vy_ref = reference_vy(str(path), half.t)
        floor = speed_floor(half)
        # the fit's centre where it calls the stiffness undetermined is in its note ("fit 1.4e+05 ± ...")
        c_fit = {a: float(re.search(r"fit ([0-9.e+]+)", fit.values[f"cornering_stiffness_{a}"].note).group(1))
                 if not fit.values[f"cornering_stiffness_{a}"].fitted else fit.values[f"cornering_stiffness_{a}"].value
                 for a in ("front", "rear")}
        # the linear-range stiffness the INS's slip angles give (0.1-0.4 g): reference, measurement only
        base = run_estimator("cascade", half, {}).table
        ins = ins_slip(base, half, vy_ref)
        v = half.vehicle
        g_use = np.abs(base["Fyf"].to_numpy() + base["Fyr"].to_numpy()) / (v.mass * GRAVITY)
        lin = (g_use > 0.1) & (g_use < 0.4)
        c_ins = {axle: float(np.median(base[f"Fy{a}"].to_numpy()[lin] / base[f"Fz{a}"].to_numpy()[lin]
                                       / np.tan(ins[axle][lin]))) * (v.fz_front if axle == "front" else v.fz_rear)
                 for axle, a in (("front", "f"), ("rear", "r"))}
        unscaled = half.with_data(half.data.assign(steer=half.col("steer") / scale))
        variants = [
            ("default", half, {}),
            ("slip-bias test off (max_slip_bias_effect 10)", half, {"max_slip_bias_effect": 10.0}),
            ("slip-noise test off (slip_noise_z 0)", half, {"slip_noise_z": 0.0}),
            ("both off", half, {"max_slip_bias_effect": 10.0, "slip_noise_z": 0.0}),
            ("sliding-range test off (max_slip_ratio 100)", half, {"max_slip_ratio": 100.0}),
            ("information test off (excitation_std 100)", half, {"excitation_std": 100.0}),
            (f"C the fit's centre {c_fit['front']:.2g}/{c_fit['rear']:.2g} N/rad",
             stiff(half, c_fit["front"], c_fit["rear"]), {}),
            (f"C the INS's linear range {c_ins['front']:.2g}/{c_ins['rear']:.2g} N/rad",
             stiff(half, c_ins["front"], c_ins["rear"]), {}),
            ("INS vy as pose (std 0.1 m/s)", with_ins_pose(half, vy_ref), {}),
            ("INS vy as pose (std 0.03 m/s)", with_ins_pose(half, vy_ref), {"pose_velocity_std": 0.03}),
        ]
        if name == "fitted":
            variants.insert(7, (f"steering scale {scale:.3f} undone", unscaled, {}))
        for label, drive, cfg in variants:
            t0 = time.perf_counter()
            res = run_estimator("cascade", drive, cfg)
            tab = res.table
            s = score_result(res, drive, vy_ref=vy_ref)
            print(f"{name:8s} {label:44s} {100 * tab['excited'].mean():7.1f}% {100 * tab['excited_front'].mean():5.1f}%"
                  f" {100 * tab['excited_rear'].mean():5.1f}%  {s.honest} ({100 * s.wrong:.2f} %)"
                  f" {100 * off_ins(tab, drive, vy_ref):9.1f} % {100 * below_floor(tab, floor):11.1f} %"
                  f"  [{time.perf_counter() - t0:.1f} s]")
        # the slip angles against the INS's: both axles carry the same v_y part, -(v_y - v_y,INS) / v_x
        err = base["alpha_r"].to_numpy() - ins["rear"]
        print(f"\n{name}: the slip angles' v_y part against the INS's (both axles), by |F_y| / (m g)")
        for lo, hi in BANDS_G:
            m = (g_use >= lo) & (g_use < hi) & np.isfinite(err)
            print(f"  {lo:.1f}-{hi:.1f} g: n {m.sum():5d}  error mean {np.mean(err[m]):+.4f} rms "
                  f"{np.sqrt(np.mean(err[m] ** 2)):.4f} rad; stated std (median) front "
                  f"{np.median(base['alpha_f_std'].to_numpy()[m]):.4f}, rear {np.median(base['alpha_r_std'].to_numpy()[m]):.4f};"
                  f" |alpha_INS| median front {np.median(np.abs(ins['front'][m])):.4f}, rear "
                  f"{np.median(np.abs(ins['rear'][m])):.4f}")
        # what the brush model reads at the INS's slip angles, with the file's stiffness and with
        # the INS's linear-range one: the friction and how far into the sliding range (u / 3)
        print(f"{name}: the brush inversion at the INS's slip angles, median friction (u / 3 = the share of the"
              " sliding range's slip angle)")
        for axle, a in (("front", "f"), ("rear", "r")):
            fz = base[f"Fz{a}"].to_numpy()
            fz0 = v.fz_front if axle == "front" else v.fz_rear
            for label, c in (("file", getattr(v, f"cornering_stiffness_{axle}")), ("INS", c_ins[axle])):
                cap, _, _ = brush_mu_inverse(base[f"Fy{a}"].to_numpy(), ins[axle], fz, c / fz0)
                line = f"  {axle:5s} C {label:4s} {c:.3g} N/rad:"
                for lo, hi in BANDS_G[2:]:
                    m = (g_use >= lo) & (g_use < hi) & np.isfinite(cap)
                    u3 = c / fz0 * np.abs(np.tan(ins[axle][m])) / cap[m] / 3.0
                    line += f"  {lo:.1f}-{hi:.1f} g: mu {np.median(cap[m]):.2f} (u / 3 {np.median(u3):.2f})"
                print(line)
        print()


if __name__ == "__main__":
    main()
