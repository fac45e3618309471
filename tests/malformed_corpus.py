"""A generated corpus of malformed input files, and every entry that reads them.

Not a test module: ``tests/test_malformed_inputs.py`` (Hypothesis) and
``benchmarks/malformed_inputs.py`` (counts per class) draw from it.

**Kinds** (:data:`KINDS`): the files a user gives roadgrip. Drives: canonical CSV and
Parquet, a DART run CSV and a frictionmaps run folder (the first rows of the shared
recordings, where present), ASAM MDF4 with a channel map, CAN logs (``.asc``,
``.blf``) with the shipped DBC, a ROS 1 bag (cut, empty, random bytes only); and the files beside them: an estimates table given to
``roadgrip map``, a vehicle YAML, a calibration YAML, a channel map and a signal map,
a DBC and a friction grid (``.npz``).

**Mutations** (:data:`MUTATIONS`): the file cut at a random byte, empty, random bytes;
text (``'n/a'``, ``''``, ``'-'``, ...) in numeric cells, NaN and inf, huge values
(1e300), duplicated and non-monotonic time, a required column (channel, key) missing,
a column of the wrong type (text, boolean, date, list). A mutation that a kind cannot
carry is left out of that kind (:func:`mutations_of`).

**Entries** (:data:`ENTRIES`): the library reader of each kind, and the command-line
commands that take it: ``info``, ``estimate``, ``map``, ``vehicle fit``,
``calibrate`` (typer's runner, in this process) and the fleet's per-drive task
(:func:`roadgrip.mapping.fleet.drive_part`, what ``roadgrip fleet`` runs on each drive
without starting a cluster).

**Outcome** (:func:`run_entry`): ``'accepted'``; ``'refused'`` (a ``ValueError``, or
a usage error of the command line, whose one-line message names the file or a mutated
column); ``'vague'`` (a ``ValueError`` that names neither); ``'crash'`` (any other
exception, or a ``ValueError`` raised from one, as the fleet wraps an estimator's
failure). The acceptance: no ``'crash'``.
"""

from __future__ import annotations

import functools
import json
import math
import shutil
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from test_drive_units import kinematic_drive

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
DART_RUN = DATA / "dart" / "high_grip_rubbery_floor" / "car_1_Datarecording_09_04_2024_12_11_23.csv"
FM_RUN = DATA / "frictionmaps" / "DS1"

TEXT_CELLS = ("n/a", "", "-", "abc", "1,5", "NaN%", "0x1F", "--", "null", "#VALUE!")
MUTATIONS = ("truncated", "empty", "random_bytes", "text_cells", "nan_inf", "huge", "dup_time",
             "nonmonotonic_time", "missing_column", "wrong_dtype")
DRIVE_KINDS = ("csv", "parquet", "dart", "frictionmaps", "mdf", "asc", "blf", "rosbag")
OTHER_KINDS = ("estimates", "vehicle", "calibration", "channel_map", "signal_map", "dbc", "grid")
KINDS = DRIVE_KINDS + OTHER_KINDS
REALDATA_KINDS = ("dart", "frictionmaps")
_BINARY_ONLY = ("truncated", "empty", "random_bytes")


def mutations_of(kind: str) -> tuple[str, ...]:
    """The mutations a kind can carry."""
    extra = {
        "dbc": ("text_cells", "missing_column"),
        "grid": (),
        "rosbag": (),
        "asc": ("text_cells", "dup_time", "nonmonotonic_time", "missing_column"),
        "blf": ("dup_time", "nonmonotonic_time", "missing_column"),
        **dict.fromkeys(("vehicle", "calibration", "channel_map", "signal_map"),
                        ("text_cells", "nan_inf", "huge", "missing_column", "wrong_dtype")),
        "mdf": tuple(m for m in MUTATIONS[3:] if m != "text_cells"),
    }.get(kind, MUTATIONS[3:])
    return (*_BINARY_ONLY, *extra)


@dataclass
class Case:
    """One malformed input: ``path`` (file or folder) of ``kind`` under ``mutation``.

    ``names``: the file and the columns, channels or keys mutated (a refusal names one).
    ``drive``: the (valid) drive file it goes with, for the kinds that are not drives.
    """

    kind: str
    mutation: str
    seed: int
    path: Path
    names: set[str] = field(default_factory=set)
    drive: Path | None = None
    options: dict = field(default_factory=dict)


# -- valid bases -----------------------------------------------------------------------------

@functools.cache
def base_frame() -> pd.DataFrame:
    """A 20 s sedan drive at 50 Hz that obeys the kinematics (tests/test_drive_units.py)."""
    return kinematic_drive(1, vehicle="sedan", duration=20.0, dt=0.02)


@functools.cache
def base_drive():
    from roadgrip.drive import Drive
    from roadgrip.vehicle import PRESETS

    return Drive.from_frame(base_frame(), PRESETS["sedan"], source="base")


@functools.cache
def base_estimates() -> pd.DataFrame:
    from roadgrip.estimators import run_estimator

    return run_estimator("cascade", base_drive()).table


CHANNEL_MAP = {
    "vehicle": "sedan",
    "channels": {"ax": {"channel": "AccX"}, "ay": {"channel": "AccY"}, "yaw_rate": {"channel": "Gyro"},
                 "steer": {"channel": "Steer"}, "vx": {"channel": "Speed"},
                 **{f"omega_{w}": {"channel": f"Whl_{w}", "unit": "rpm"} for w in ("fl", "fr", "rl", "rr")}},
}
_MDF_UNITS = {"ax": ("AccX", "g", 1 / 9.80665), "ay": ("AccY", "m/s^2", 1.0),
              "yaw_rate": ("Gyro", "deg/s", 180 / math.pi), "steer": ("Steer", "rad", 1.0),
              "vx": ("Speed", "km/h", 3.6)}


def _write_mdf(path: Path, df: pd.DataFrame, t_of: Callable[[str], np.ndarray] | None = None,
               value_of: Callable[[str, np.ndarray], np.ndarray] | None = None, skip: str = "") -> None:
    from asammdf import MDF, Signal

    t = df["t"].to_numpy(float)
    sigs = []

    def signal(name: str, v: np.ndarray, unit: str = "") -> Signal:
        v = value_of(name, v) if value_of else v
        enc = {"encoding": "utf-8"} if v.dtype.kind == "S" else {}
        return Signal(v, t_of(name) if t_of else t, name=name, unit=unit, **enc)

    for col, (name, unit, f) in _MDF_UNITS.items():
        if name != skip:
            sigs.append(signal(name, df[col].to_numpy(float) * f, unit))
    for w in ("fl", "fr", "rl", "rr"):
        name = f"Whl_{w}"
        if name != skip:
            sigs.append(signal(name, df[f"omega_{w}"].to_numpy(float) * 60 / (2 * math.pi)))
    mdf = MDF(version="4.10")
    for s in sigs:  # one group a channel: each may have its own time stamps
        mdf.append([s])
    mdf.save(path, overwrite=True)
    mdf.close()


def _write_can(path: Path, drive) -> None:
    import can

    from roadgrip.io.can import SHIPPED_DBC, SHIPPED_MAP, FrameEncoder, load_dbc, load_signal_map
    from roadgrip.live.replay import replay_drive

    enc = FrameEncoder(load_dbc(SHIPPED_DBC), load_signal_map(SHIPPED_MAP))
    with can.Logger(str(path)) as writer:
        replay_drive(drive, writer.on_message_received, enc, speed=float("inf"))


@functools.cache
def _can_base(suffix: str) -> bytes:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"base{suffix}"
        _write_can(p, base_drive())
        return p.read_bytes()


@functools.cache
def _bag_base() -> bytes:
    """A ROS 1 bag of a simulated 1:10 car on the F1TENTH topics (tests/test_io_rosbag.py)."""
    import tempfile

    from roadgrip.sim.scenarios import simulate_scenario
    from test_io_rosbag import _topic_map, write_drive_bag

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "base.bag"
        write_drive_bag(p, "ros1", simulate_scenario("f1tenth-patches", seed=3, duration=4.0), _topic_map())
        return p.read_bytes()


# -- mutations -------------------------------------------------------------------------------

def _cut(raw: bytes, rng: np.random.Generator) -> bytes:
    return raw[: int(rng.integers(0, max(len(raw), 1)))]


def _mutate_frame(df: pd.DataFrame, mutation: str, rng: np.random.Generator, protect: tuple[str, ...] = ()
                  ) -> tuple[pd.DataFrame, set[str]]:
    """A table under a cell-level mutation: ``(table, names of the columns touched)``."""
    df = df.copy()
    n = len(df)
    numeric = [c for c in df.columns if df[c].dtype.kind in "fiu" and c not in protect]
    col = str(rng.choice(numeric))
    rows = rng.choice(n, size=int(rng.integers(1, max(2, n // 20))), replace=False)
    tcol = "t" if "t" in df.columns else col
    if mutation == "text_cells":
        df[col] = df[col].astype(object)
        df.loc[rows, col] = [str(rng.choice(TEXT_CELLS)) for _ in rows]
        return df, {col}
    if mutation in ("nan_inf", "huge"):
        df[col] = df[col].astype(float)
    if mutation == "nan_inf":
        df.loc[rows, col] = rng.choice([np.nan, np.inf, -np.inf], size=len(rows))
        return df, {col}
    if mutation == "huge":
        df.loc[rows, col] = rng.choice([1e300, -1e300, 1.7e308, 1e30], size=len(rows))
        return df, {col}
    if mutation == "dup_time":
        i = int(rng.integers(1, n - 1))
        k = int(rng.integers(1, 20))
        df = pd.concat([df.iloc[:i], df.iloc[i:i + k], df.iloc[i:]], ignore_index=True)
        return df, {tcol}
    if mutation == "nonmonotonic_time":
        i = int(rng.integers(1, n - 30))
        k = int(rng.integers(2, 30))
        if rng.random() < 0.5:
            df.loc[i:i + k - 1, tcol] = df.loc[i:i + k - 1, tcol].to_numpy()[::-1]
        else:
            shift = float(rng.uniform(0.1, 5.0))
            df.loc[i:, tcol] = df.loc[i:, tcol] - (math.ceil(shift) if df[tcol].dtype.kind in "iu" else shift)
        return df, {tcol}
    if mutation == "missing_column":
        drop = str(rng.choice([c for c in df.columns if c not in protect] or list(df.columns)))
        return df.drop(columns=[drop]), {drop}
    if mutation == "wrong_dtype":
        kind = str(rng.choice(["text", "bool", "date", "int"]))
        if kind == "text":
            df[col] = [f"v{i}" for i in range(n)]
        elif kind == "bool":
            df[col] = df[col] > 0
        elif kind == "date":
            df[col] = pd.Timestamp("2024-01-01") + pd.to_timedelta(np.arange(n), unit="s")
        else:
            df[col] = rng.integers(-2**62, 2**62, size=n)
        return df, {col}
    raise AssertionError(mutation)


def _mutate_yaml(d: dict, mutation: str, rng: np.random.Generator) -> tuple[dict, set[str]]:
    """A map or vehicle under a field-level mutation: ``(mapping, names of the keys touched)``."""
    d = json.loads(json.dumps(d))
    paths: list[tuple[list, str]] = []

    def walk(node, trail):
        for k, v in node.items():
            if isinstance(v, dict):
                walk(v, [*trail, k])
            else:
                paths.append(([*trail], k))
    walk(d, [])
    trail, key = paths[int(rng.integers(0, len(paths)))]
    node = d
    for k in trail:
        node = node[k]
    value = {"text_cells": str(rng.choice(TEXT_CELLS)), "nan_inf": float(rng.choice([np.nan, np.inf, -np.inf])),
             "huge": float(rng.choice([1e300, -1e300, 1e30])), "wrong_dtype": [1, 2]}.get(mutation)
    if mutation == "missing_column":
        del node[key]
    else:
        node[key] = value
    return d, {str(key), *map(str, trail)}


def make_case(kind: str, mutation: str, seed: int, folder: Path) -> Case:
    """Write the malformed input ``kind`` under ``mutation`` (drawn with ``seed``) into ``folder``."""
    from roadgrip.io.can import SHIPPED_DBC, SHIPPED_MAP
    from roadgrip.vehicle import PRESETS

    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    df = base_frame()
    suffix = {"rosbag": ".bag", "csv": ".csv", "parquet": ".parquet", "dart": ".csv", "mdf": ".mf4", "asc": ".asc", "blf": ".blf",
              "estimates": ".parquet", "vehicle": ".yaml", "calibration": ".yaml", "channel_map": ".yaml",
              "signal_map": ".yaml", "dbc": ".dbc", "grid": ".npz"}.get(kind, "")
    path = folder / (f"{kind}_{mutation}{suffix}" if kind != "frictionmaps" else "DS1")
    case = Case(kind, mutation, seed, path, {path.name})

    def good_raw() -> bytes:
        """The valid file of this kind."""
        tmp = folder / f"good_{kind}{suffix}"
        if kind == "csv":
            df.to_csv(tmp, index=False)
        elif kind == "parquet":
            df.to_parquet(tmp, index=False)
        elif kind == "dart":
            return b"".join(DART_RUN.open("rb").readlines()[:3000])
        elif kind == "mdf":
            _write_mdf(tmp, df)
        elif kind in ("asc", "blf"):
            return _can_base(suffix)
        elif kind == "rosbag":
            return _bag_base()
        elif kind == "estimates":
            _write_estimates(tmp, base_estimates())
        elif kind == "vehicle":
            tmp.write_text(yaml.safe_dump(PRESETS["sedan"].to_dict()))
        elif kind == "calibration":
            tmp.write_text(yaml.safe_dump(_calibration()))
        elif kind == "channel_map":
            tmp.write_text(yaml.safe_dump(CHANNEL_MAP))
        elif kind == "signal_map":
            return SHIPPED_MAP.read_bytes()
        elif kind == "dbc":
            return SHIPPED_DBC.read_bytes()
        elif kind == "grid":
            from roadgrip.mapping import grid as G

            G.fuse(G.empty_grid(0.5), [0.1, 3.0], [0.2, 1.0], [0.5, 0.9], [0.01, 0.02]).to_npz(tmp)
        raw = tmp.read_bytes()
        tmp.unlink()
        return raw

    # the valid drive the non-drive kinds go with
    if kind in ("vehicle", "calibration"):
        case.drive = folder / "drive.csv"
        if not case.drive.exists():
            df.to_csv(case.drive, index=False)
    elif kind == "channel_map":
        case.drive = folder / "drive.mf4"
        if not case.drive.exists():
            _write_mdf(case.drive, df)
    elif kind in ("signal_map", "dbc"):
        case.drive = folder / "drive.asc"
        if not case.drive.exists():
            case.drive.write_bytes(_can_base(".asc"))
    if kind == "frictionmaps":
        return _frictionmaps_case(case, rng)
    if mutation in _BINARY_ONLY:
        raw = {"truncated": lambda: _cut(good_raw(), rng), "empty": lambda: b"",
               "random_bytes": lambda: rng.bytes(int(rng.integers(1, 4000)))}[mutation]()
        path.write_bytes(raw)
        return case
    if kind in ("csv", "parquet", "estimates"):
        table = base_estimates() if kind == "estimates" else df
        bad, names = _mutate_frame(table, mutation, rng)
        case.names |= names
        if kind == "csv":
            bad.to_csv(path, index=False)
            return case
        if bad.dtypes.eq(object).any():  # Parquet holds one type a column: text for mixed
            for c in bad.columns[bad.dtypes.eq(object)]:
                bad[c] = bad[c].map(lambda v: v if v is None else str(v))
        if kind == "estimates":
            _write_estimates(path, bad)
        else:
            bad.to_parquet(path, index=False)
        return case
    if kind == "dart":
        src = pd.read_csv(DART_RUN, nrows=3000)
        bad, names = _mutate_frame(src, mutation, rng)
        bad = bad.rename(columns={"t": "elapsed time sensors"})
        if mutation in ("dup_time", "nonmonotonic_time"):
            names.add("elapsed time sensors")
        case.names |= names
        bad.to_csv(path, index=False)
        return case
    if kind == "mdf":
        return _mdf_case(case, rng)
    if kind == "asc":
        return _asc_case(case, good_raw(), rng)
    if kind == "blf":
        return _blf_case(case, rng)
    if kind in ("vehicle", "calibration", "channel_map"):
        d = yaml.safe_load(good_raw())
        bad, names = _mutate_yaml(d, mutation, rng)
        case.names |= names
        path.write_text(yaml.safe_dump(bad))
        return case
    if kind == "signal_map":
        d = yaml.safe_load(SHIPPED_MAP.read_text())
        bad, names = _mutate_yaml(d, mutation, rng)
        case.names |= names
        path.write_text(yaml.safe_dump(bad))
        return case
    if kind == "dbc":
        lines = SHIPPED_DBC.read_text().splitlines(keepends=True)
        sig = [i for i, ln in enumerate(lines) if ln.lstrip().startswith("SG_ ")]
        i = int(rng.choice(sig))
        if mutation == "missing_column":
            case.names.add(lines[i].split()[1])
            del lines[i]
        else:  # text in a signal's numbers
            parts = lines[i].split(" ")
            j = int(rng.integers(0, len(parts)))
            parts[j] = str(rng.choice(TEXT_CELLS)) or "?"
            lines[i] = " ".join(parts)
        path.write_text("".join(lines))
        return case
    raise AssertionError((kind, mutation))


def _write_estimates(path: Path, table: pd.DataFrame) -> None:
    from roadgrip.estimators.base import EstimateResult

    EstimateResult("cascade", table, {}).to_parquet(path)


@functools.cache
def _calibration() -> dict:
    from roadgrip.cli.calibrate import write_calibration
    from roadgrip.estimators.classify import calibrate
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=2, duration=120.0)  # tests/test_cli_calibrate.py
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate([(drive.slice_time(0, 60), "high"), (drive.slice_time(60, 120), "low")])
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "cal.yaml"
        write_calibration(cal, p)
        return yaml.safe_load(p.read_text())


def _frictionmaps_case(case: Case, rng: np.random.Generator) -> Case:
    shutil.rmtree(case.path, ignore_errors=True)
    case.path.mkdir(parents=True)
    files = sorted(FM_RUN.glob("*.csv"))
    for f in files:
        lines = f.open("rb").readlines()[:600]
        (case.path / f.name).write_bytes(b"".join(lines))
    victim = case.path / str(rng.choice([f.name for f in files if f.name != "pfOdomData.csv"]))
    case.names |= {victim.name}
    if case.mutation in _BINARY_ONLY:
        raw = victim.read_bytes()
        victim.write_bytes({"truncated": _cut(raw, rng), "empty": b"",
                            "random_bytes": rng.bytes(int(rng.integers(1, 4000)))}[case.mutation])
        return case
    src = pd.read_csv(victim)
    bad, names = _mutate_frame(src.rename(columns={"s": "t"}), case.mutation, rng, protect=("Unnamed: 0",))
    case.names |= {"s" if n == "t" else n for n in names}
    bad.rename(columns={"t": "s"}).to_csv(victim, index=False)
    return case


def _mdf_case(case: Case, rng: np.random.Generator) -> Case:
    df = base_frame()
    names = [v[0] for v in _MDF_UNITS.values()] + [f"Whl_{w}" for w in ("fl", "fr", "rl", "rr")]
    victim = str(rng.choice(names))
    case.names.add(victim)
    n = len(df)
    t = df["t"].to_numpy(float)
    m = case.mutation
    rows = rng.choice(n, size=int(rng.integers(1, n // 20)), replace=False)

    def value_of(name, v):
        if name != victim:
            return v
        v = v.copy()
        if m == "nan_inf":
            v[rows] = rng.choice([np.nan, np.inf, -np.inf], size=len(rows))
        elif m == "huge":
            v[rows] = rng.choice([1e300, -1e300, 1e30], size=len(rows))
        elif m == "wrong_dtype":
            kind = str(rng.choice(["bool", "int", "bytes"]))
            return {"bool": v > 0, "int": rng.integers(-2**62, 2**62, size=n),
                    "bytes": np.array([b"v%d" % i for i in range(n)])}[kind]
        return v

    def t_of(name):
        if name != victim:
            return t
        tt = t.copy()
        i = int(rng.integers(1, n - 30))
        if m == "dup_time":
            tt[i:i + int(rng.integers(1, 20))] = tt[i]
        elif m == "nonmonotonic_time":
            tt[i:] -= float(rng.uniform(0.1, 5.0))
        return tt

    _write_mdf(case.path, df, t_of=t_of, value_of=value_of, skip=victim if m == "missing_column" else "")
    case.options = {"channels": CHANNEL_MAP}
    return case


def _asc_case(case: Case, raw: bytes, rng: np.random.Generator) -> Case:
    lines = raw.decode().splitlines(keepends=True)
    frames = [i for i, ln in enumerate(lines) if ln.startswith(" ") and " Rx " in ln]
    m = case.mutation
    if m == "text_cells":
        for i in rng.choice(frames, size=int(rng.integers(1, 20)), replace=False):
            parts = lines[i].split()
            j = int(rng.integers(0, len(parts)))
            parts[j] = str(rng.choice(TEXT_CELLS)) or "?"
            lines[i] = "   " + " ".join(parts) + "\n"
    elif m == "dup_time":
        i = int(rng.choice(frames))
        lines[i:i] = [lines[i]] * int(rng.integers(1, 50))
    elif m == "nonmonotonic_time":
        a = int(rng.integers(0, len(frames) - 100))
        idx = frames[a:a + int(rng.integers(2, 100))]
        block = [lines[i] for i in idx][::-1]
        for i, ln in zip(idx, block, strict=True):
            lines[i] = ln
    elif m == "missing_column":  # every frame of one message gone
        ids = sorted({lines[i].split()[2] for i in frames})
        gone = str(rng.choice(ids))
        case.names.add(gone)
        lines = [ln for i, ln in enumerate(lines) if not (i in set(frames) and ln.split()[2] == gone)]
    case.path.write_text("".join(lines))
    return case


def _blf_case(case: Case, rng: np.random.Generator) -> Case:
    import can

    folder = case.path.parent
    src = folder / "good_blf_source.blf"
    if not src.exists():
        src.write_bytes(_can_base(".blf"))
    msgs = list(can.BLFReader(str(src)))
    m = case.mutation
    if m == "dup_time":
        i = int(rng.integers(0, len(msgs)))
        msgs[i:i] = [msgs[i]] * int(rng.integers(1, 50))
    elif m == "nonmonotonic_time":
        a = int(rng.integers(0, len(msgs) - 100))
        k = int(rng.integers(2, 100))
        stamps = [mm.timestamp for mm in msgs[a:a + k]][::-1]
        for mm, s in zip(msgs[a:a + k], stamps, strict=True):
            mm.timestamp = s
    elif m == "missing_column":
        gone = int(rng.choice(sorted({mm.arbitration_id for mm in msgs})))
        case.names.add(hex(gone))
        msgs = [mm for mm in msgs if mm.arbitration_id != gone]
    with can.BLFWriter(str(case.path)) as w:
        for mm in msgs:
            w.on_message_received(mm)
    return case


# -- entries ---------------------------------------------------------------------------------

ENTRIES = ("read", "info", "estimate", "map", "vehicle_fit", "calibrate", "fleet")
"""Every way in: the library reader, five commands and the fleet's per-drive task."""


def _cli(args: list[str]) -> None:
    """Run ``roadgrip ARGS`` in this process: return, or raise what the command raised
    (a usage error or a non-zero typer exit as ``ValueError`` with its output)."""
    from typer.testing import CliRunner

    from roadgrip.cli import app

    res = CliRunner().invoke(app, args, catch_exceptions=True)
    if res.exception is None:
        return
    if isinstance(res.exception, SystemExit):
        if res.exit_code in (0, None):
            return
        out = (res.output or "").strip().splitlines()
        raise ValueError(" ".join(out[-3:]) if out else f"exit {res.exit_code}")
    raise res.exception


def _drive_args(case: Case) -> list[str]:
    """The command-line arguments that give the case's input as (or with) a drive."""
    from roadgrip.io.can import SHIPPED_DBC

    p = str(case.path)
    if case.kind in ("csv", "parquet"):
        return [p, "--vehicle", "sedan"]
    if case.kind in ("dart", "frictionmaps", "rosbag"):
        return [p]
    if case.kind == "mdf":
        cm = case.path.parent / "channels.yaml"
        cm.write_text(yaml.safe_dump(CHANNEL_MAP))
        return [p, "--channels", str(cm)]
    if case.kind in ("asc", "blf"):
        return [p, "--dbc", str(SHIPPED_DBC)]
    if case.kind == "vehicle":
        return [str(case.drive), "--vehicle", p]
    if case.kind == "channel_map":
        return [str(case.drive), "--channels", p]
    if case.kind == "signal_map":
        return [str(case.drive), "--dbc", str(SHIPPED_DBC), "--channels", p]
    if case.kind == "dbc":
        return [str(case.drive), "--dbc", p]
    if case.kind == "calibration":
        return [str(case.drive), "--vehicle", "sedan"]
    raise AssertionError(case.kind)


def entries_of(kind: str) -> tuple[str, ...]:
    """The entries that take a kind (the commands that have the options it needs)."""
    if kind in ("estimates", "grid"):
        return ("read", "map")
    if kind == "calibration":
        return ("read", "estimate")
    if kind in ("asc", "blf", "signal_map", "dbc"):  # --dbc: info and estimate
        return ("read", "info", "estimate")
    if kind in ("mdf", "channel_map"):  # the fleet reads a drive by its format alone
        return tuple(e for e in ENTRIES if e != "fleet")
    return ENTRIES


def _read(case: Case) -> None:
    from roadgrip.io import read_drive

    k = case.kind
    if k in DRIVE_KINDS or k in ("vehicle", "channel_map", "signal_map", "dbc"):
        args = _drive_args(case)
        kw: dict = {}
        for flag, key in (("--vehicle", "vehicle"), ("--channels", "channels"), ("--dbc", "dbc")):
            if flag in args:
                kw[key] = args[args.index(flag) + 1]
        read_drive(args[0], **kw)
    elif k == "estimates":
        from roadgrip.estimators.base import EstimateResult
        from roadgrip.mapping.estimates import observations_from_estimates

        observations_from_estimates(EstimateResult.read_parquet(case.path).table, None)
    elif k == "grid":
        from roadgrip.mapping import grid as G

        G.FrictionGrid.from_npz(case.path)
    elif k == "calibration":
        from roadgrip.cli.calibrate import read_calibration

        read_calibration(case.path)
    else:
        raise AssertionError(k)


def _entry(case: Case, entry: str, out: Path) -> None:
    if entry == "read":
        return _read(case)
    if case.kind == "estimates":
        return _cli(["map", str(case.path), "-o", str(out / "map.npz")])
    if case.kind == "grid":
        return _cli(["map", "show", str(case.path), "-o", str(out / "map.png")])
    args = _drive_args(case)
    if entry == "info":
        return _cli(["info", *args])
    if entry == "estimate":
        extra = ["--calibration", str(case.path)] if case.kind == "calibration" else []
        method = "brls" if case.kind == "calibration" else "cascade"
        return _cli(["estimate", *args, "--method", method, "-o", str(out / "est.parquet"), *extra])
    if entry == "map":
        return _cli(["map", *args, "-o", str(out / "map.npz")])
    if entry == "vehicle_fit":
        return _cli(["vehicle", "fit", *args])
    if entry == "calibrate":
        return _cli(["calibrate", *args, "--label", "high", "-o", str(out / "cal.yaml")])
    if entry == "fleet":
        from roadgrip.mapping.fleet import FleetConfig, drive_part

        veh = args[args.index("--vehicle") + 1] if "--vehicle" in args else None
        drive_part(args[0], FleetConfig(vehicle=veh))
        return None
    raise AssertionError(entry)


@dataclass(frozen=True)
class Outcome:
    """What one entry did with one case (module docstring)."""

    status: str
    message: str = ""


def run_entry(case: Case, entry: str, out: Path) -> Outcome:
    """Give ``case`` to ``entry``; classify what happens (module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            _entry(case, entry, out)
        except ValueError as exc:
            cause = exc.__cause__ or (None if exc.__suppress_context__ else exc.__context__)
            if cause is not None and not isinstance(cause, ValueError):
                return Outcome("crash", f"{type(cause).__name__} under ValueError: {exc}")
            msg = str(exc)
            named = any(n and n in msg for n in case.names)
            return Outcome("refused" if named else "vague", msg)
        except Exception as exc:
            tb = traceback.extract_tb(exc.__traceback__)
            where = next((f"{Path(f.filename).name}:{f.lineno}" for f in reversed(tb)
                          if "roadgrip" in f.filename), "?")
            return Outcome("crash", f"{type(exc).__name__} at {where}: {exc}")
    return Outcome("accepted")
