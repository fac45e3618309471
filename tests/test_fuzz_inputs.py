"""Property tests on generated bad inputs: nothing crashes, every refusal names what is wrong.

Mutation classes (each a Hypothesis strategy below):

- readers: encodings (BOM, UTF-16 LE/BE with and without mark), compression by
  content (gzip, bzip2, xz, truncated archives), comment and blank lines, CRLF,
  ``;`` delimiters with decimal commas, thousands separators, cell values
  (empty, NaN, inf, 1e400, text, hexadecimal, complex), duplicated and missing
  columns, ragged rows, files cut at any byte, duplicated and reversed
  timestamps, time in ms / µs / ns;
- validation: frames with extreme, non-finite, text and complex values;
- vehicle YAML: fields of any type and magnitude, missing and unknown keys, any
  Unicode encoding;
- the grid: positions up to 1e308, cell sizes from 1 mm to 1 km, merges, files
  that are not grids;
- estimators (cheaply): every method on a short drive mutated within the
  validated ranges (extreme values, reversing, gaps, constant signals, extreme
  vehicles) must run and give no inf and no partial NaN in its contract columns.

The property for every input: it is accepted (and then consistent) or refused by
a ``ValueError`` whose one-line message contains the offending name (file,
column or field). The number of examples per test is ``ROADGRIP_FUZZ_EXAMPLES``
(default: a few seconds' worth in ``make test``; ``make fuzz`` runs more than
10,000 cases); examples are derandomised, so every run is the same.
"""

from __future__ import annotations

import bz2
import functools
import gzip
import json
import lzma
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from roadgrip.drive import SIGNAL_RANGES, Drive, DriveValidationError
from roadgrip.io.canonical import read_canonical_csv
from roadgrip.mapping import grid as G
from roadgrip.vehicle import PRESETS, load_vehicle
from roadgrip.vehicle.params import FIELD_RANGES

_SCALE = int(os.environ.get("ROADGRIP_FUZZ_EXAMPLES", "0"))


def _budget(default: int, share: float) -> settings:
    """Examples: ``default`` in ``make test``, ``share`` of ROADGRIP_FUZZ_EXAMPLES in ``make fuzz``."""
    n = max(1, int(_SCALE * share)) if _SCALE else default
    return settings(max_examples=n, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


COLUMNS = ["t", "ax", "ay", "yaw_rate", "steer", "vx", "omega_fl", "omega_fr", "omega_rl", "omega_rr",
           "x", "y", "psi"]
N_ROWS = 40


def _base_rows() -> list[list[str]]:
    rng = np.random.default_rng(0)
    rows = []
    for i in range(N_ROWS):
        t = 0.01 * i
        vx = 10.0 + 0.1 * rng.standard_normal()
        r = 0.2 * np.sin(t)
        rows.append([f"{t:.2f}", f"{0.1 * rng.standard_normal():.4f}", f"{vx * r:.4f}", f"{r:.4f}",
                     f"{0.02 * r:.4f}", f"{vx:.4f}", *[f"{vx / 0.31:.4f}"] * 4, f"{vx * t:.4f}", "0.0",
                     "0.0"])
    return rows


BAD_CELLS = ["", "nan", "NaN", "inf", "-inf", "1.8e308", "1e400", "-1e400", "abc", "1,5", "0x10",
             "1e-320", "(1+2j)", "  3 ", "--1", "1.0.0", "TRUE", "99999999999999999999", "#", '"', "'",
             "\u00e9", "1_000", "-0", "2e9", "1e19"]


_ANY = (st.floats() | st.integers(-10**30, 10**30) | st.text(max_size=5) | st.booleans() | st.none()
        | st.lists(st.floats(), max_size=2))


@st.composite
def csv_files(draw):
    """``(name, raw bytes, names)``: a canonical CSV under one or more mutations."""
    header = list(COLUMNS)
    rows = [list(r) for r in _base_rows()]
    names: set[str] = set()
    kinds = draw(st.lists(st.sampled_from(
        ["cell", "cell", "cell", "dupcol", "dropcol", "renamecol", "ragged", "short", "duptime",
         "reverse", "timescale", "comment", "blank", "header_only", "empty", "thousands",
         "deccomma"]), min_size=1, max_size=3))
    sep, decimal = ",", "."
    for kind in kinds:
        if kind == "cell" and rows and header:
            r = draw(st.integers(0, len(rows) - 1))
            c = draw(st.integers(0, len(header) - 1))
            if c < len(rows[r]):
                rows[r][c] = draw(st.sampled_from(BAD_CELLS) | st.floats().map(repr)
                                  | st.text(max_size=6))
                names.add(header[c])
        elif kind == "dupcol" and len(header) > 1:
            c = draw(st.integers(1, len(header) - 1))
            header[c] = header[c - 1]
            names.add(header[c])
        elif kind == "dropcol" and len(header) > 1:
            c = draw(st.integers(0, len(header) - 1))
            names.add(header[c])
            del header[c]
            for row in rows:
                if c < len(row):
                    del row[c]
        elif kind == "renamecol" and header:
            c = draw(st.integers(0, len(header) - 1))
            header[c] = draw(st.text(min_size=0, max_size=5))
            names.add(header[c])
        elif kind == "ragged" and rows:
            rows[draw(st.integers(0, len(rows) - 1))].append("1")
        elif kind == "short" and rows:
            r = draw(st.integers(0, len(rows) - 1))
            rows[r] = rows[r][: draw(st.integers(0, len(rows[r])))]
        elif kind == "duptime" and len(rows) > 2:
            r = draw(st.integers(1, len(rows) - 1))
            rows.insert(r, list(rows[r]))
            names.add("t")
        elif kind == "reverse" and len(rows) > 3:
            r = draw(st.integers(1, len(rows) - 2))
            rows[r], rows[r + 1] = rows[r + 1], rows[r]
            names.add("t")
        elif kind == "timescale" and "t" in header and header.count("t") == 1:
            f = draw(st.sampled_from([1e3, 1e6, 1e9, 1e-6]))
            c = header.index("t")
            for row in rows:
                try:
                    row[c] = repr(float(row[c]) * f)
                except (ValueError, IndexError):
                    pass
            names.add("t")
        elif kind == "comment":
            rows.insert(draw(st.integers(0, len(rows))), ["# logger restarted here"])
        elif kind == "blank":
            rows.insert(draw(st.integers(0, len(rows))), [""])
        elif kind == "header_only":
            rows = []
        elif kind == "empty":
            header, rows = [], []
        elif kind == "thousands" and rows and header:
            c = draw(st.integers(0, len(header) - 1))
            rows[draw(st.integers(0, len(rows) - 1))][c:c + 1] = ['"1,234.5"']
            names.add(header[c])
        elif kind == "deccomma":
            sep, decimal = ";", ","
    meta = None
    if draw(st.integers(0, 3)) == 0:  # a metadata line, possibly damaged
        meta = {"vehicle": PRESETS["sedan"].to_dict(), "source": "x", "sample_rate": 100.0,
                "truth": None, "extra": {}, "dtypes": {c: "float64" for c in header}}
        key = draw(st.sampled_from(["vehicle", "source", "sample_rate", "truth", "extra", "dtypes",
                                    "mass", "none"]))
        value = draw(_ANY | st.dictionaries(st.text(max_size=3), _ANY, max_size=2)
                     | st.sampled_from([{"surfaces": 1}, {"surfaces": {"snow": 1}}, {"t": "complex128"},
                                        {"t": "datetime64[ns]"}, {"ax": "bogus"}]))
        if key == "mass":
            meta["vehicle"]["mass"] = value
            names.add("mass")
        elif key != "none":
            meta[key] = value
            names.add(key)
            if key == "dtypes" and isinstance(value, dict):
                names.update(map(str, value))

    def line(cells):
        text = sep.join(cells)
        return text.replace(".", ",") if decimal == "," and not text.startswith("#") else text
    text = "\n".join([line(header), *(line(r) for r in rows)]) + "\n" if header else ""
    if meta is not None:
        text = "# roadgrip-meta " + json.dumps(meta) + "\n" + text
    if draw(st.booleans()):
        text = text.replace("\n", "\r\n")
    enc = draw(st.sampled_from(["utf-8", "utf-8", "bom", "utf-16", "utf-16-le", "utf-16-be", "gzip",
                                "bz2", "xz", "latin-1"]))
    raw = {"bom": lambda s: b"\xef\xbb\xbf" + s.encode(), "gzip": lambda s: gzip.compress(s.encode()),
           "bz2": lambda s: bz2.compress(s.encode()), "xz": lambda s: lzma.compress(s.encode()),
           }.get(enc, lambda s: s.encode(enc, errors="replace"))(text)
    if draw(st.integers(0, 9)) == 0:  # cut anywhere
        raw = raw[: draw(st.integers(0, len(raw)))]
    return "drive.csv", raw, names, decimal


def _names_something(msg: str, file: str, names: set[str], header_names: list[str]) -> bool:
    if file in msg:
        return True
    return any(f"'{n}'" in msg or f'"{n}"' in msg for n in {*names, *header_names})


def _check_drive(d: Drive) -> None:
    """What passes validation is consistent: finite, in range, time increasing."""
    t = d.t
    assert np.all(np.diff(t) > 0)
    for c, (lo, hi, _) in SIGNAL_RANGES.items():
        if c in d.data.columns and c not in ("vx_pose", "vy_pose", "motor_rpm"):
            v = d.col(c)
            assert np.all(np.isfinite(v)) and np.all((v >= lo) & (v <= hi)), c


@_budget(60, 0.35)
@given(csv_files())
def test_reader_accepts_or_names_the_problem(case):
    name, raw, names, decimal = case
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / name
        p.write_bytes(raw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            try:
                d = read_canonical_csv(p, PRESETS["sedan"], decimal=decimal)
            except ValueError as exc:
                msg = str(exc)
                assert "\n" not in msg.strip(), msg
                assert _names_something(msg, name, names, COLUMNS), msg
                event(f"refused: {type(exc).__name__}")
                return
    event("accepted")
    _check_drive(d)
    from roadgrip.io.describe import describe_drive, format_text

    assert format_text(describe_drive(d))


@st.composite
def frames(draw):
    n = draw(st.integers(1, 30))
    df = pd.DataFrame({"t": np.arange(n) * 0.01, "ax": np.zeros(n), "ay": np.zeros(n),
                       "vx": np.full(n, 5.0), "omega_fl": np.full(n, 16.0)})
    names = set()
    for _ in range(draw(st.integers(1, 3))):
        col = draw(st.sampled_from([*df.columns, "vx_pose", "psi", "steer", "mu_true", "x"]))
        names.add(col)
        kind = draw(st.sampled_from(["float", "text", "complex", "int", "bool", "scale"]))
        if kind == "float":
            v = draw(st.lists(st.floats(), min_size=n, max_size=n))
            df[col] = np.array(v, dtype=float)
        elif kind == "text":
            df[col] = draw(st.lists(st.text(max_size=4), min_size=n, max_size=n))
        elif kind == "complex":
            df[col] = np.zeros(n) + 1j
        elif kind == "int":
            df[col] = draw(st.lists(st.integers(-2**62, 2**62), min_size=n, max_size=n))
        elif kind == "bool":
            df[col] = np.ones(n, bool)
        elif col in df.columns and df[col].dtype.kind in "fiu":
            df[col] = df[col] * draw(st.sampled_from([1e3, 1e6, 1e9, -1.0, 0.0]))
    if draw(st.booleans()) and n > 1:
        df = pd.concat([df, df.iloc[:, :1]], axis=1)
        names.add("t")
    return df, names


@_budget(60, 0.2)
@given(frames())
def test_validation_accepts_or_names_the_column(case):
    df, names = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            d = Drive.from_frame(df, PRESETS["sedan"], source="fuzz")
        except DriveValidationError as exc:
            assert _names_something(str(exc), "fuzz", names, list(df.columns)) or "empty" in str(exc)
            event("refused")
            return
    event("accepted")
    _check_drive(d)



@st.composite
def vehicle_files(draw):
    d: dict = dict(PRESETS["sedan"].to_dict())
    names = set()
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["value", "value", "missing", "unknown", "range"]))
        key = draw(st.sampled_from(sorted(d) or ["mass"]))
        names.add(key)
        if kind == "value":
            d[key] = draw(_ANY)
        elif kind == "range" and key in FIELD_RANGES:
            lo, hi, _, _ = FIELD_RANGES[key]
            d[key] = draw(st.sampled_from([lo, hi, lo * 0.999, hi * 1.001, -lo, 0.0]))
        elif kind == "missing":
            d.pop(key, None)
        else:
            k = draw(st.text(min_size=1, max_size=6))
            names.add(k)
            d[k] = 1.0
    text = yaml.safe_dump(d, allow_unicode=True)
    enc = draw(st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be"]))
    raw = text.encode(enc)
    if draw(st.integers(0, 9)) == 0:
        raw = raw[: draw(st.integers(0, len(raw)))]
    return raw, names


@_budget(60, 0.15)
@given(vehicle_files())
def test_vehicle_yaml_accepts_or_names_the_field(case):
    raw, names = case
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "car.yaml"
        p.write_bytes(raw)
        try:
            v = load_vehicle(p)
        except ValueError as exc:
            msg = str(exc)
            assert "car.yaml" in msg or any(f"'{n}'" in msg for n in names), msg
            event("refused")
            return
    event("accepted")
    for f, (lo, hi, _, _) in FIELD_RANGES.items():
        assert lo <= getattr(v, f) <= hi, f
    assert isinstance(v.name, str)


_COORD = st.floats(-1e308, 1e308) | st.floats(-1e5, 1e5) | st.just(float("nan"))


@_budget(40, 0.15)
@given(st.lists(st.tuples(_COORD, _COORD, st.floats(-1, 3), st.floats(-1, 1)), min_size=1, max_size=6),
       st.sampled_from([0.001, 0.5, 2.0, 1000.0]), st.booleans())
def test_grid_fuses_or_refuses_with_a_reason(obs, cell, split):
    x, y, mu, var = (np.array(v, float) for v in zip(*obs, strict=True))
    g0 = G.empty_grid(cell)
    try:
        if split and len(x) > 1:
            a = G.fuse(g0, x[:1], y[:1], mu[:1], var[:1])
            b = G.fuse(g0, x[1:], y[1:], mu[1:], var[1:])
            g = G.merge(a, b)
        else:
            g = G.fuse(g0, x, y, mu, var)
    except ValueError as exc:
        msg = str(exc)
        assert "observation" in msg or "map would need" in msg, msg
        event("refused: " + ("observation" if "observation" in msg else "size"))
        return
    event("accepted")
    # sparse: memory follows the observed cells, whatever their spread
    assert g.n_cells <= len(x) and g.nbytes == g.n_cells * 48
    assert int(g.cells.n_obs.sum()) == len(x)
    m, s = g.cell_posterior()
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(s))
    qm, _ = g.query(x, y)
    np.testing.assert_allclose(np.sort(np.unique(qm)), np.sort(np.unique(m)), rtol=1e-12)


@_budget(20, 0.05)
@given(st.binary(max_size=2000), st.integers(0, 4000))
def test_grid_file_that_is_not_a_grid_names_the_file(data, cut):
    with tempfile.TemporaryDirectory() as tmp:
        good = Path(tmp) / "good.npz"
        G.fuse(G.empty_grid(0.5), [0.1], [0.2], [0.5], [0.01]).to_npz(good)
        raw = good.read_bytes()
        for name, content in (("random.npz", data), ("cut.npz", raw[: cut % len(raw)]),
                              ("spliced.npz", raw[:100] + data + raw[100 + len(data):])):
            p = Path(tmp) / name
            p.write_bytes(content)
            try:
                G.FrictionGrid.from_npz(p)
            except ValueError as exc:
                assert name in str(exc) and "pickle" not in str(exc)


# -- estimators on drives that passed validation ---------------------------------------------

@functools.cache
def _sim_frame() -> pd.DataFrame:
    from roadgrip.sim.scenarios import simulate_scenario

    d = simulate_scenario("snow-slalom", seed=0, duration=3.0)
    return d.data[[c for c in d.data.columns if not c.endswith("_true") and c != "surface"]].copy()


@st.composite
def mutated_drives(draw):
    df = _sim_frame().copy()
    n = len(df)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["extreme", "constant", "reverse", "gaps", "long_gap", "spike",
                                     "zero_speed", "noise", "jitter", "drop_column"]))
        col = draw(st.sampled_from([c for c in df.columns if c != "t"]))
        lo, hi, _ = SIGNAL_RANGES.get(col, (-1e3, 1e3, ""))
        if kind == "extreme":
            df[col] = draw(st.sampled_from([lo, hi, 0.0, 0.5 * hi, 1e-300]))
        elif kind == "constant":
            df[col] = float(df[col].iloc[0])
        elif kind in ("reverse", "zero_speed"):
            for w in {"vx", "omega_fl", "omega_fr", "omega_rl", "omega_rr"} & set(df.columns):
                df[w] = -df[w] if kind == "reverse" else 0.0
        elif kind in ("gaps", "long_gap") and n > 6:
            if kind == "gaps":
                keep = np.ones(n, bool)
                i = draw(st.integers(1, n - 3))
                keep[i:i + draw(st.integers(1, n // 3))] = False
                keep[0] = keep[-1] = True
                df = df[keep].reset_index(drop=True)
                n = len(df)
            else:  # a logger pause: the time jumps, the signals do not
                i = draw(st.integers(1, n - 2))
                df.loc[i:, "t"] = df.loc[i:, "t"] + draw(st.sampled_from([0.9, 5.0, 60.0, 200.0, 3600.0]))
        elif kind == "spike":
            df.loc[draw(st.integers(0, n - 1)), col] = draw(st.sampled_from([lo, hi]))
        elif kind == "noise":
            rng = np.random.default_rng(draw(st.integers(0, 1000)))
            df[col] = np.clip(df[col] + draw(st.sampled_from([0.1, 10.0, 1e3])) * rng.standard_normal(n),
                              lo, hi)
        elif kind == "jitter":
            rng = np.random.default_rng(draw(st.integers(0, 1000)))
            dt = np.diff(df["t"].to_numpy())
            df["t"] = np.concatenate([[0.0], np.cumsum(dt * rng.uniform(0.05, 1.95, len(dt)))])
        elif kind == "drop_column" and col not in ("t",):
            df = df.drop(columns=[col])
    base = PRESETS[draw(st.sampled_from(sorted(PRESETS)))]
    changes = {}
    for field in draw(st.lists(st.sampled_from(sorted(FIELD_RANGES)), max_size=4, unique=True)):
        lo, hi, _, _ = FIELD_RANGES[field]
        top = hi * (0.999 if field in ("roll_gradient", "pitch_gradient") else 1)
        changes[field] = draw(st.sampled_from([lo if lo > 0 else top * 1e-6, top]))
    try:
        vehicle = base.replace(**changes)
    except ValueError:  # a combination no vehicle has (tests/test_vehicle.py)
        vehicle = base
    method = draw(st.sampled_from(["brls", "slipmap", "cascade", "gpssm"]))
    return df, vehicle, method


@_budget(8, 0.02)
@given(mutated_drives())
def test_estimators_run_on_what_validation_accepts(case):
    from roadgrip.estimators import CONTRACT_COLUMNS, run_estimator

    df, vehicle, method = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            drive = Drive.from_frame(df, vehicle, source="fuzz", check_units=False)
        except DriveValidationError:
            event("refused by validation")
            return
        t0 = time.perf_counter()
        try:
            res = run_estimator(method, drive, {"particles": 50} if method == "gpssm" else None)
        except DriveValidationError as exc:  # a required column missing: a clean refusal
            assert "column" in str(exc)
            event(f"{method}: refused (column missing)")
            return
        assert time.perf_counter() - t0 < 60.0, method
        event(f"{method}: ran")
    for c, kind in CONTRACT_COLUMNS.items():
        if kind != "float" or c not in res.table.columns:
            continue
        v = res.table[c].to_numpy(float)
        assert not np.isinf(v).any(), (method, c)
        assert np.isnan(v).all() or not np.isnan(v).any(), (method, c)


def test_fuzz_regressions():
    """Examples found by the generator, kept as plain cases."""
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "drive.csv"
        # a header cell that pandas would read as a number and a text cell in 't'
        p.write_bytes(b"t,ax\n0.00,1\n,2\nabc,3\n")
        with pytest.raises(ValueError, match=r"drive.csv:4: column 't' holds 'abc'"):
            read_canonical_csv(p, PRESETS["sedan"])
    # a variance of 1e-203 overflowed the squared sums of the posterior
    g = G.fuse(G.empty_grid(0.001), [0.0, 0.0], [0.0, 0.0], [0.0, 1.0], [1.0, 1.0496507466775351e-203])
    m, s = g.posterior()
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(s))
    assert float(m.ravel()[0]) == pytest.approx(1.0, abs=1e-6)
    with pytest.raises(ValueError, match=r"observation 0 is not usable.*mu = 1e\+300"):
        G.fuse(G.empty_grid(0.5), [0.0], [0.0], [1e300], [0.01])


def test_brls_after_a_long_pause():
    """Found by the generated corpus: a logger paused for 1000 s in a valid drive."""
    from roadgrip.estimators import run_estimator

    df = _sim_frame().copy()
    df.loc[50:, "t"] += 1000.0
    drive = Drive.from_frame(df, PRESETS["suv"], source="pause", check_units=False)
    res = run_estimator("brls", drive)
    assert np.isfinite(res.table["grip_index"].to_numpy(float)).all()


# -- estimates tables and files given to a map -------------------------------------------------

@st.composite
def estimates_files(draw):
    """``(raw bytes of an estimates Parquet file, names)``: cells replaced by text, numbers of
    any size or missing values in the columns a map reads, the file cut anywhere."""
    from roadgrip.estimators.base import EstimateResult

    n = 30
    tab = pd.DataFrame({"t": np.arange(n) * 0.1, "x": np.arange(n) * 1.0, "y": np.zeros(n),
                        "mu_front_obs": np.full(n, 0.8), "mu_front_obs_std": np.full(n, 0.1),
                        "excited_front": np.ones(n, bool), "mu_rear": np.full(n, 0.7),
                        "mu_rear_lower": np.full(n, 0.5), "mu_rear_upper": np.full(n, 0.9),
                        "excited": np.ones(n, bool)})
    names: set[str] = set()
    for _ in range(draw(st.integers(0, 3))):
        c = draw(st.sampled_from(list(tab.columns)))
        names.add(c)
        tab = tab.astype({c: object})
        tab.loc[draw(st.integers(0, n - 1)), c] = draw(
            st.sampled_from(["n/a", "", "NaN", "-", "1,5", None, "inf", "0x10"]) | st.floats()
            | st.text(max_size=4))
        if tab[c].map(type).nunique() > 1:  # Parquet holds one type a column: text for mixed
            tab[c] = tab[c].map(lambda v: v if v is None else str(v))
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "estimates.parquet"
        EstimateResult("cascade", tab, {}).to_parquet(p)
        raw = p.read_bytes()
    if draw(st.integers(0, 4)) == 0:
        raw = raw[: draw(st.integers(0, len(raw)))]
    return raw, names


@_budget(30, 0.05)
@given(estimates_files(), st.sampled_from([None, 0.5]))
def test_map_of_estimates_accepts_or_names_the_problem(case, cell):
    from roadgrip.estimators.base import EstimateResult
    from roadgrip.mapping.estimates import observations_from_estimates

    raw, names = case
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "estimates.parquet"
        p.write_bytes(raw)
        try:
            obs = observations_from_estimates(EstimateResult.read_parquet(p).table, cell)
        except ValueError as exc:
            msg = str(exc)
            assert "\n" not in msg.strip() and ("estimates.parquet" in msg
                                                 or any(f"'{n}'" in msg for n in names)), msg
            event("refused")
            return
    event("accepted")
    assert np.all(np.isfinite(obs.mu)) and np.all(obs.var > 0)
