"""Command ``roadgrip calibrate``: classifier references and thresholds from labelled drives.

Also the calibration file: :func:`write_calibration` writes a
:class:`~roadgrip.estimators.classify.Calibration` as YAML and
:func:`read_calibration` reads it back (``roadgrip estimate --calibration``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from roadgrip.cli._common import ChannelsOpt, FormatOpt, TopicsOpt, VehicleOpt, app, console

if TYPE_CHECKING:
    from roadgrip.estimators.classify import Calibration

__all__ = ["calibrate", "parse_labelled", "read_calibration", "split_window", "write_calibration"]


def write_calibration(cal: Calibration, path: str | Path) -> None:
    """Write ``cal`` as a YAML file (:meth:`Calibration.to_dict`)."""
    import yaml

    Path(path).write_text(yaml.safe_dump(cal.to_dict(), sort_keys=False))


def read_calibration(path: str | Path) -> Calibration:
    """Read a calibration YAML file written by :func:`write_calibration`.

    Raises
    ------
    ValueError
        When the file does not exist, is not YAML, or is not a valid roadgrip calibration.
    """
    import yaml

    from roadgrip.estimators.classify import Calibration

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"calibration file {p} does not exist")
    try:
        doc = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"calibration file {p} is not valid YAML: {exc}") from None
    if not isinstance(doc, dict) or "roadgrip_calibration" not in doc:
        raise ValueError(f"{p} is not a roadgrip calibration file (no 'roadgrip_calibration' key)")
    return Calibration.from_dict(doc, str(p))


def split_window(path: str) -> tuple[str, tuple[float, float] | None]:
    """``DRIVE@T0-T1`` -> (``DRIVE``, (t0, t1)) [s]; a path without ``@`` has no window.

    ``T1`` may be left out (to the end): ``dgd.parquet@120-``.

    Raises
    ------
    ValueError
        When the window is not two numbers with ``t0 < t1``.
    """
    base, at, window = path.rpartition("@")
    if not at:
        return path, None
    lo, dash, hi = window.partition("-")
    try:
        t0 = float(lo)
        t1 = float(hi) if hi.strip() else float("inf")
    except ValueError:
        raise ValueError(f"time window must be T0-T1 in seconds, got {window!r} in {path!r}") from None
    if not dash or not t0 < t1:
        raise ValueError(f"time window must be T0-T1 with T0 < T1, got {window!r} in {path!r}")
    return base, (t0, t1)


def parse_labelled(args: Sequence[str]) -> tuple[list[tuple[str, str]], dict[str, float] | None]:
    """``DRIVE:LABEL`` / ``DRIVE:LABEL=MU`` arguments: (path, label) pairs and the friction references.

    The label is 'high' or 'low' (split at the last colon); ``MU`` is the known
    peak friction of that surface, the class's friction reference (given for
    both classes or for neither; several values of a class are averaged). The
    path may end in a time window, ``DRIVE@T0-T1`` (:func:`split_window`), to
    label one stretch of a drive.
    """
    if not args:
        raise ValueError("give at least two labelled drives, e.g. dry.parquet:high gravel.parquet:low")
    pairs = []
    given: dict[str, list[float]] = {}
    for arg in args:
        path, sep, label = str(arg).rpartition(":")
        label, eq, mu = label.partition("=")
        if not sep or label not in ("high", "low"):
            raise ValueError(
                f"expected DRIVE:LABEL or DRIVE:LABEL=MU with label 'high' or 'low', got {arg!r}"
            )
        if eq:
            try:
                given.setdefault(label, []).append(float(mu))
            except ValueError:
                raise ValueError(f"friction after '=' must be a number, got {mu!r} in {arg!r}") from None
        pairs.append((path, label))
    if not given:
        return pairs, None
    if set(given) != {"high", "low"}:
        raise ValueError("give the friction (LABEL=MU) for both classes or for neither")
    return pairs, {k: float(np.mean(v)) for k, v in given.items()}


def _print_calibration(cal: Calibration, output: Path) -> None:
    b = cal.brls
    if b.grip is not None:
        g = b.grip
        console.print(
            f"saturation model: stiffness long {g.c_long:.3g}, lat {g.c_lat:.3g} /unit slip; gains "
            f"{g.gain_x:.3g}, {g.gain_y:.3g}; class friction high {g.mu_high:.3g}, low {g.mu_low:.3g}; "
            f"model error {g.model_error_x:.2g}, {g.model_error_y:.2g}"
        )
    for name, ch in (("longitudinal", b.long), ("lateral", b.lat)):
        state = "on" if ch.enabled else "off"
        console.print(
            f"bRLS {name}: {state}; reference high {ch.ref_high:.4g}, low {ch.ref_low:.4g}, "
            f"threshold {ch.threshold:.4g}, gamma {ch.gamma:.3g}"
        )
    if cal.slipmap is not None and cal.slipmap.model == "saturation":
        sm = cal.slipmap
        console.print(f"slipmap: saturation model; longitudinal map {'on' if sm.longitudinal else 'off'}, "
                      f"lateral map {'on' if sm.lateral else 'off'}; low-pass {sm.lowpass_tau_s:.3g} s")
    elif cal.slipmap is not None:
        sm = cal.slipmap
        console.print(
            f"slipmap: mid-friction peaks long {sm.long_curve.D:.3g}, "
            f"lat {sm.lat_curve.D:.3g}; low-pass {sm.lowpass_tau_s:.3g} s"
        )
    d: dict[str, Any] = cal.to_dict()
    console.print(f"fit: {d['diagnostics']} {d['slipmap'].get('fit', {})}")
    console.print(f"wrote {output}")


@app.command()
def calibrate(
    drives: Annotated[list[str], typer.Argument(metavar="DRIVE:LABEL...", help="Labelled drives (label high or low, optionally =MU; DRIVE@T0-T1 labels a time window).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="calibration.yaml")],
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
) -> None:
    """Learn bRLS / slipmap references and thresholds from labelled drives."""
    from roadgrip.cli.options import check_drive_args, check_output
    from roadgrip.estimators.classify import calibrate as learn
    from roadgrip.io import read_drive

    pairs, friction = parse_labelled(drives)
    for arg, _ in pairs:
        check_drive_args(split_window(arg)[0], fmt, vehicle, topics, channels)
    check_output(output, "--output", (".yaml", ".yml"))
    labelled = []
    for arg, label in pairs:
        path, window = split_window(arg)
        drive = read_drive(path, format=fmt, vehicle=vehicle, topics=topics, channels=channels)
        if window is not None:
            drive = drive.slice_time(*window)
            if drive.n < 2:
                raise ValueError(f"time window of {arg!r} holds fewer than two samples")
        labelled.append((drive, label))
    cal = learn(labelled, friction=friction)
    write_calibration(cal, output)
    _print_calibration(cal, output)
