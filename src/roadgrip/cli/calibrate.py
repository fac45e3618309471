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
from rich.table import Table

from roadgrip.cli._common import ChannelsOpt, FormatOpt, TopicsOpt, VehicleOpt, app, console

if TYPE_CHECKING:
    from roadgrip.estimators.classify import Calibration

__all__ = ["calibrate", "calibration_table", "parse_labelled", "read_calibration", "split_window",
           "write_calibration"]


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
    except UnicodeDecodeError as exc:
        raise ValueError(f"calibration file {p} is not text (byte {exc.start}: {exc.reason})") from None
    except yaml.YAMLError as exc:
        raise ValueError(f"calibration file {p} is not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(doc, dict) or "roadgrip_calibration" not in doc:
        raise ValueError(f"{p} is not a roadgrip calibration file (no 'roadgrip_calibration' key)")
    try:
        return Calibration.from_dict(doc, str(p))
    except (TypeError, KeyError, AttributeError, ValueError) as exc:  # a field of the wrong type or range
        msg = " ".join(str(exc).split())
        raise ValueError(msg if str(p) in msg else f"calibration file {p}: {msg or type(exc).__name__}") from None


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


def parse_labelled(args: Sequence[str], label: str | None = None,
                   ) -> tuple[list[tuple[str, str]], dict[str, float] | None]:
    """``DRIVE:LABEL`` / ``DRIVE:LABEL=MU`` arguments: (path, label) pairs and the friction references.

    The label is 'high' or 'low' (split at the last colon); ``MU`` is the known
    peak friction of that surface, the class's friction reference (given for
    every class of the drives or for none; several values of a class are
    averaged). A drive without ``:LABEL`` takes ``label`` (``--label``), and is an
    error without it. The path may end in a time window, ``DRIVE@T0-T1``
    (:func:`split_window`), to label one stretch of a drive. Drives of one class
    are a one-class calibration (the other class derived from the fitted car,
    :func:`roadgrip.estimators.classify.calibrate`).
    """
    if label is not None and label not in ("high", "low"):
        raise ValueError(f"--label must be 'high' or 'low', got {label!r}")
    if not args:
        raise ValueError("give at least one labelled drive, e.g. dry.parquet:high (with gravel.parquet:low "
                         "for two classes)")
    pairs = []
    given: dict[str, list[float]] = {}
    for arg in args:
        path, sep, lab = str(arg).rpartition(":")
        lab, eq, mu = lab.partition("=")
        if not sep or lab not in ("high", "low"):
            if label is None:
                raise ValueError(
                    f"expected DRIVE:LABEL or DRIVE:LABEL=MU with label 'high' or 'low', got {arg!r} "
                    "(or give --label for drives without one)"
                )
            path, lab, eq = str(arg), label, ""
        if eq:
            try:
                given.setdefault(lab, []).append(float(mu))
            except ValueError:
                raise ValueError(f"friction after '=' must be a number, got {mu!r} in {arg!r}") from None
        pairs.append((path, lab))
    if not given:
        return pairs, None
    present = {lab for _, lab in pairs}
    if set(given) != present:
        raise ValueError("give the friction (LABEL=MU) for every class of the drives or for none")
    return pairs, {k: float(np.mean(v)) for k, v in given.items()}


UNITS = {
    "c_long": "1/unit slip", "c_lat": "1/rad", "mu_high": "-", "mu_low": "-",
    "gain_x": "-", "gain_y": "-", "gain": "-", "model_error_x": "-", "model_error_y": "-",
    "model_error": "-", "relative_residual": "-", "stiffness_over_parameters": "-",
    "fraction_in_labelled_class": "-", "resistance_0": "m/s²", "resistance_2": "1/m",
    "road_load": "m/s², 1/m", "alpha_offset_f": "rad", "alpha_offset_r": "rad", "kappa_offset": "-",
    "offset": "-", "slope_per_mps2": "1/(m/s²)",
    "offset_deg": "deg", "slope_deg_per_mps2": "deg/(m/s²)", "D": "-",
}
"""Units of the calibration's entries by their last key, as the calibration file holds them
(``diagnostics.sensor_calibration``, the vehicle file's calibration the drives were read
with, in the vehicle file's units: :data:`roadgrip.io.calibration.CALIBRATION`)."""

GRIP_FITTED = ("c_long", "c_lat", "mu_high", "mu_low", "gain_x", "gain_y", "model_error_x",
               "model_error_y", "resistance_0", "resistance_2", "alpha_offset_f", "alpha_offset_r",
               "kappa_offset")
"""The saturation model's parameters that ``roadgrip calibrate`` fits or sets from the drives."""


def _unit(path: Sequence[str]) -> str:
    """The unit of the entry at ``path`` of the calibration file ('' where none is known)."""
    key, parent = path[-1], (path[-2] if len(path) > 1 else "")
    if key == "stiffness":  # diagnostics.grip_fit.{x, y}.stiffness
        return {"x": UNITS["c_long"], "y": UNITS["c_lat"]}.get(parent, "")
    if parent in ("friction", "friction_demonstrated"):
        return "-"
    if key.endswith("_s"):
        return "s"
    if key in UNITS:
        return UNITS[key]
    from roadgrip.io.calibration import CALIBRATION  # not at import: the command line starts light

    return CALIBRATION[key][0] if key in CALIBRATION else ""


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if v is None:
        return "unknown"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return ", ".join(_value(x) for x in v)
    return str(v)


def _leaves(value: Any, path: tuple[str, ...]) -> list[tuple[tuple[str, ...], Any]]:
    """(path, value) of every entry of a nested dictionary; a list of scalars is one entry,
    a list of dictionaries is entered by index."""
    if isinstance(value, dict):
        return [leaf for k, v in value.items() for leaf in _leaves(v, (*path, str(k)))]
    if isinstance(value, (list, tuple)) and any(isinstance(v, dict) for v in value):
        return [leaf for i, v in enumerate(value) for leaf in _leaves(v, (*path, str(i)))]
    return [(path, value)]


def calibration_table(cal: Calibration, title: str = "calibration") -> Table:
    """The calibration as a table of parameter, value and unit, parameters named by their
    place in the calibration file: the fitted model, each classifier's channels, then the
    fit's diagnostics."""
    from rich.text import Text

    doc = cal.to_dict()
    brls, slipmap = doc["brls"], doc["slipmap"]
    sections: list[list[tuple[tuple[str, ...], Any]]] = []
    if brls.get("grip"):
        sections.append([(("brls", "grip", k), brls["grip"][k]) for k in GRIP_FITTED])
    sections.append([(("brls", ch, k), brls[ch][k]) for ch in ("long", "lat")
                     for k in ("enabled", "ref_high", "ref_low", "threshold", "gamma")])
    config = slipmap.get("config")
    if config is not None:
        keys = ["longitudinal", "lateral"] if config.get("model") == "saturation" else []
        rows = [(("slipmap", "config", k), config[k]) for k in keys]
        rows += [(("slipmap", "config", c, "D"), config[c]["D"]) for c in ("long_curve", "lat_curve")
                 if config.get("model") != "saturation"]
        rows.append((("slipmap", "config", "lowpass_tau_s"), config["lowpass_tau_s"]))
        sections.append(rows)
    sections.append(_leaves(doc["diagnostics"], ("diagnostics",)) + _leaves(slipmap.get("fit") or {},
                                                                            ("slipmap", "fit")))
    table = Table(title=title)
    table.add_column("parameter", no_wrap=True)
    table.add_column("value", justify="right")
    table.add_column("unit")
    for rows in sections:
        for path, value in rows:
            if value == {}:  # an empty section of the file
                continue
            table.add_row(Text(".".join(path)), Text(_value(value)), Text(_unit(path)))
        table.add_section()
    return table


@app.command()
def calibrate(
    drives: Annotated[list[str], typer.Argument(metavar="DRIVE:LABEL...", help="Labelled drives (label high or low, optionally =MU; DRIVE@T0-T1 labels a time window). Drives of one class calibrate from that class alone.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="calibration.yaml")],
    label: Annotated[str | None, typer.Option("--label", help="Label (high or low) of the drives given without :LABEL, e.g. one dry baseline lap: --label high.")] = None,
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
) -> None:
    """Learn bRLS / slipmap references and thresholds from labelled drives (one class suffices)."""
    from roadgrip.cli.options import check_drive_args, check_output
    from roadgrip.estimators.classify import calibrate as learn
    from roadgrip.io import read_drive

    pairs, friction = parse_labelled(drives, label)
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
    try:
        cal = learn(labelled, friction=friction)
    except ValueError as exc:  # name the drives it was learned from
        names = ", ".join(sorted({Path(split_window(arg)[0]).name for arg, _ in pairs}))
        raise ValueError(f"{names}: {exc}") from None
    write_calibration(cal, output)
    console.print(calibration_table(cal, f"calibration of {cal.vehicle or 'the vehicle'} "
                                         f"({len(pairs)} labelled drive{'s' if len(pairs) != 1 else ''})"))
    console.print(f"wrote {output}")
