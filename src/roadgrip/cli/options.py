"""Checks of command-line options, run before any drive is read or any estimate starts.

Every check raises ``ValueError`` with one line that names the option, the value given
and the accepted range, so that a mistyped option costs a second, not an estimation
run. Resource requests (GP-SSM particles and basis size, simulated duration) are
compared with the memory they would need (:func:`gpssm_memory`) against the memory
available (:func:`available_memory`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

__all__ = [
    "ESTIMATE_KEY",
    "SEED_MAX",
    "address_space_free",
    "available_memory",
    "cgroup_free",
    "check_cell",
    "check_choice",
    "check_drive_args",
    "check_duration",
    "check_folder_output",
    "check_gpssm_resources",
    "check_input",
    "check_not_estimates",
    "check_output",
    "check_seed",
    "check_vehicle",
    "gpssm_memory",
    "parse_curve_times",
    "proc_kib",
    "vehicle_presets",
]

SEED_MAX = 2**32 - 1
"""Largest random seed [-]: every random stream of the library accepts ``0 .. 2**32 - 1``."""

CURVE_TIME_MAX = 1.0e7
"""Largest ``--curve-times`` entry [s] (115 days; a time past the drive's end gives its last sample)."""

DURATION_MAX = 86_400.0
"""Longest simulated drive [s] (24 h)."""

SIM_BYTES_PER_SAMPLE = 2_000
"""Memory of one recorded sample of a simulated drive [B]: its columns (about 60, float64),
the truth and the integrator's arrays at the recorded rate, with the copies of building
the frame (an upper estimate; a 180 s multi-body drive at 100 Hz peaks below 40 MB)."""

MEMORY_FRACTION = 0.8
"""Share of the available memory a request may take."""

GIB = 2.0**30


def _bad(option: str, accepted: str, value: Any) -> ValueError:
    return ValueError(f"{option} must be {accepted}, got {value!r}")


def check_seed(seed: int, option: str = "--seed") -> int:
    """A seed in ``0 .. SEED_MAX``."""
    if not 0 <= int(seed) <= SEED_MAX:
        raise _bad(option, f"an integer from 0 to {SEED_MAX}", seed)
    return int(seed)


def check_choice(value: str | None, option: str, choices: Iterable[str]) -> None:
    """``value`` is one of ``choices`` (or None, the default)."""
    choices = tuple(choices)
    if value is not None and value not in choices:
        raise _bad(option, f"one of {', '.join(choices)}", value)


def check_input(path: str | Path | None, option: str | None = None) -> None:
    """An input file or folder exists (``option`` None for a command's argument, the path
    itself naming it)."""
    if path is not None and not Path(path).exists():
        raise ValueError(f"{option + ': ' if option else ''}no such file or folder: {path}")


def check_output(path: str | Path | None, option: str, suffixes: Iterable[str] | None = None) -> None:
    """An output file can be written: its folder exists and is writable, it is not a folder,
    and its name ends in one of ``suffixes`` (lower case, with the dot; None for any)."""
    if path is None:
        return
    p = Path(path)
    if suffixes is not None:
        suffixes = tuple(suffixes)
        if p.suffix.lower() not in suffixes:
            raise ValueError(f"{option} must name a {' or '.join(suffixes)} file, got {str(p)!r}")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"{option}: folder {parent} does not exist (for {p})")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"{option}: folder {parent} is not writable (for {p})")
    if p.is_dir():
        raise ValueError(f"{option}: {p} is a folder, expected a file name")


def check_folder_output(path: str | Path, option: str) -> None:
    """An output folder exists or can be created in an existing, writable folder."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{option}: {p} exists and is not a folder")
    if not p.exists():
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.is_dir():
            raise ValueError(f"{option}: folder {parent} does not exist (for {p})")
        if not os.access(parent, os.W_OK):
            raise ValueError(f"{option}: folder {parent} is not writable (for {p})")


def vehicle_presets() -> str:
    """The shipped vehicle presets, comma-separated, in their registry's order
    (:data:`roadgrip.vehicle.params.PRESETS`): the one list that ``--vehicle``'s help and
    its error name."""
    from roadgrip.vehicle.params import PRESETS

    return ", ".join(PRESETS)


def check_vehicle(vehicle: str | None, option: str = "--vehicle") -> None:
    """``vehicle`` (None: the drive's own) is a preset or a valid vehicle YAML file."""
    if vehicle is None:
        return
    from roadgrip.vehicle.params import PRESETS, load_vehicle

    if vehicle in PRESETS:
        return
    p = Path(vehicle)
    if p.suffix not in (".yaml", ".yml") and not p.exists():  # what load_vehicle reads as a file
        raise ValueError(f"{option}: unknown vehicle {vehicle!r}: not a preset ({vehicle_presets()}) "
                         "nor a YAML file")
    try:
        load_vehicle(vehicle)
    except ValueError as exc:
        raise ValueError(f"{option}: {exc}") from None


ESTIMATE_KEY = b"roadgrip_estimate"
"""Schema metadata key of an estimates Parquet file
(:meth:`roadgrip.estimators.base.EstimateResult.to_parquet`)."""


def check_not_estimates(path: str | Path | None) -> None:
    """``path`` is not an estimates file (the output of ``roadgrip estimate``) given as a drive.

    An estimates table has no drive metadata, so the reader would ask for the vehicle,
    which does not help: the drive the estimates came from is what is needed.
    """
    if path is None:
        return
    p = Path(path)
    if not (p.is_file() and p.suffix.lower() in (".parquet", ".pq")):
        return
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        md = pq.read_schema(str(p)).metadata or {}
    except (pa.ArrowException, OSError):
        return  # not readable as Parquet: the reader says why
    if ESTIMATE_KEY not in md:
        return
    try:
        method = json.loads(md[ESTIMATE_KEY]).get("method")
    except (ValueError, AttributeError):
        method = None
    by = f" --method {method}" if isinstance(method, str) else ""
    raise ValueError(f"{p.name} is an estimates table (output of `roadgrip estimate{by}`), not a drive: "
                     "pass the drive it was estimated from")


def check_drive_args(path: str | None, fmt: str | None, vehicle: str | None,
                     topics: str | None = None, channels: str | None = None) -> None:
    """The drive arguments shared by every command that reads a drive: the file exists and
    is not an estimates table, the format is known, the vehicle is a preset or a valid YAML
    file, the map files exist."""
    from roadgrip.io.read import FORMATS

    if fmt is not None and fmt not in FORMATS:
        raise ValueError(f"--format: unknown format {fmt!r}; expected one of {', '.join(FORMATS)}")
    check_input(path)
    check_not_estimates(path)
    check_vehicle(vehicle)
    if channels is not None:
        check_input(channels, "--channels")
    if topics is not None and (topics.endswith((".yaml", ".yml")) or os.sep in topics):
        check_input(topics, "--topics")


def parse_curve_times(text: str | None) -> tuple[float, ...] | None:
    """``--curve-times`` as seconds: comma-separated, each finite and in ``[0, 1e7]``."""
    if text is None:
        return None
    accepted = f"comma-separated seconds, each from 0 to {CURVE_TIME_MAX:g} s"
    try:
        times = tuple(float(s) for s in text.split(","))
    except ValueError:
        raise _bad("--curve-times", accepted, text) from None
    if not times or not all(math.isfinite(t) and 0.0 <= t <= CURVE_TIME_MAX for t in times):
        raise _bad("--curve-times", accepted, text)
    return times


def check_cell(cell: float) -> None:
    """``roadgrip map --cell``: a finite size in ``[0.01, 1000]`` m."""
    if not (math.isfinite(cell) and 0.01 <= cell <= 1000.0):
        raise _bad("--cell", "a cell size from 0.01 to 1000 m", cell)


def proc_kib(path: str, key: str) -> float | None:
    """A ``key: N kB`` line of a Linux ``/proc`` file, in bytes (``None``: no such file or key)."""
    try:
        with open(path) as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return None


def available_memory() -> float:
    """Memory the process may still allocate [B].

    The least of ``MemAvailable`` of ``/proc/meminfo`` (else the physical memory, else
    8 GiB), what the memory control group's limit leaves (:func:`cgroup_free`) and what
    the address-space limit (``ulimit -v``) leaves beside this process's ``VmSize``: in a
    container or under a ulimit, the machine's free memory is not the process's.
    """
    avail = proc_kib("/proc/meminfo", "MemAvailable")
    if avail is None:
        try:
            avail = float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
        except (ValueError, OSError, AttributeError):
            avail = 8.0 * GIB
    for free in (cgroup_free(), address_space_free()):
        if free is not None:
            avail = min(avail, free)
    return avail


CGROUP_FILES = (
    ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current",
     "/sys/fs/cgroup/memory.stat", "inactive_file"),
    ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes",
     "/sys/fs/cgroup/memory/memory.stat", "total_inactive_file"),
)
"""Memory control group files, v2 then v1: limit, usage, statistics and the statistic of the
reclaimable file cache counted in the usage."""


def cgroup_free(files: tuple[tuple[str, str, str, str], ...] = CGROUP_FILES) -> float | None:
    """What the memory control group's limit leaves [B]: the limit less the usage that is
    not inactive file cache (None without a cgroup or a limit)."""
    for limit_file, usage_file, stat_file, inactive_key in files:
        try:
            limit_text = Path(limit_file).read_text().strip()
            usage = float(Path(usage_file).read_text())
        except (OSError, ValueError):
            continue
        if limit_text == "max" or not limit_text.isdigit() or float(limit_text) >= 2.0**60:
            return None  # v2 'max', v1's page-rounded 2**63: no limit
        inactive = 0.0
        try:
            for line in Path(stat_file).read_text().splitlines():
                key, _, value = line.partition(" ")
                if key == inactive_key:
                    inactive = float(value)
        except (OSError, ValueError):
            pass
        return max(float(limit_text) - max(usage - inactive, 0.0), 0.0)
    return None


def address_space_free() -> float | None:
    """What ``RLIMIT_AS`` (``ulimit -v``) leaves beside this process's ``VmSize`` [B]
    (None without a limit)."""
    try:
        import resource
    except ImportError:  # not Unix
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    return max(float(soft) - (proc_kib("/proc/self/status", "VmSize") or 0.0), 0.0)


def check_duration(duration: float | None, rate_hz: float, available: float | None = None) -> None:
    """``roadgrip simulate --duration``: finite, in ``(0, 86400]`` s, and its samples fit in memory."""
    if duration is None:
        return
    if not (math.isfinite(duration) and 0.0 < duration <= DURATION_MAX):
        raise _bad("--duration", f"a time in seconds in (0, {DURATION_MAX:g}]", duration)
    need = duration * rate_hz * SIM_BYTES_PER_SAMPLE
    avail = available_memory() if available is None else available
    if need > MEMORY_FRACTION * avail:
        longest = MEMORY_FRACTION * avail / (rate_hz * SIM_BYTES_PER_SAMPLE)
        raise ValueError(f"--duration {duration:g} s would need about {need / GIB:.1f} GiB at "
                         f"{rate_hz:g} Hz; {avail / GIB:.1f} GiB are available, so at most "
                         f"{longest:.0f} s")


def gpssm_memory(basis: Any, particles: int, linalg: str = "exact", history: int = 80) -> tuple[float, float]:
    """Memory of a GP-SSM run [B]: (per particle, fixed), from its per-particle state.

    Per particle, with ``G`` groups of ``m`` features and ``d`` outputs (the basis) and
    ``J = history`` buffered updates (:class:`~roadgrip.estimators.gpssm.GPSSMState`):
    the information matrices and their inverses with one spare of each, ``4 G m²``
    (``G m²`` in ``'direct'`` mode); the buffered features ``J G m`` and their rows ``J``;
    the statistics ``Psi`` and ``Phi``, ``G d (m + d)`` (twice in ``'fast'`` mode, which
    carries ``M`` and ``Lambda``); the peak features ``2 G m`` and pending updates ``G m``;
    the state, weights and friction sample. All float64, with a margin of a quarter for
    resampling's copies and the step's temporaries (a run of 6000 particles with the
    default basis grew the resident memory by 285 MiB against a state of 301 MiB). The
    fixed part is the basis' features and one step's
    temporaries (``m²`` per group, small).

    Parameters
    ----------
    basis : TensorBasis or SeparableBasis
    particles : int
    linalg : {'exact', 'fast', 'direct'}
    history : int
        ``GPSSMConfig.refactor_every``.

    Returns
    -------
    per_particle, fixed : float
        Bytes.
    """
    G, d, m = int(basis.groups), int(basis.outputs), int(basis.m)
    J = max(int(history), 1)
    if linalg == "direct":
        words = G * m * m + G * m + 4
    else:
        words = 4 * G * m * m + J * G * m + J + G * m + G + 2 + 2 * G * m
    words += G * d * (m + d) * (2 if linalg == "fast" else 1)
    words += 8  # x (3), mu (2), logw, ancestors
    per = 1.25 * 8.0 * words
    fixed = 8.0 * (16 * G * m * m + 64 * G * m) + 2.0**20
    return per, fixed


def check_gpssm_resources(options: dict[str, Any], available: float | None = None) -> None:
    """Refuse GP-SSM particles or a basis whose state would not fit in memory.

    ``options`` are the estimator options (``particles``, ``basis``, ``linalg``,
    ``refactor_every``; missing ones take the configuration's defaults). The message
    gives the estimate, the memory available and the largest particle count that fits.
    """
    from roadgrip.estimators.gpssm.config import DEFAULT_BASIS, GPSSMConfig
    from roadgrip.inference.basis import make_basis

    default = GPSSMConfig.__dataclass_fields__
    particles = options.get("particles", default["particles"].default)
    if int(particles) != particles or particles < 2:
        raise _bad("--particles", "an integer >= 2", particles)
    spec = options.get("basis", DEFAULT_BASIS)
    try:
        basis = make_basis(spec) if isinstance(spec, str) else spec
    except ValueError as exc:
        raise ValueError(f"--basis: {exc}") from None
    if basis.m < 1:
        raise _bad("--basis", "a basis with at least one function per axle", spec)
    linalg = options.get("linalg", default["linalg"].default)
    history = options.get("refactor_every", default["refactor_every"].default)
    per, fixed = gpssm_memory(basis, int(particles), linalg, history)
    need = per * particles + fixed
    avail = available_memory() if available is None else available
    budget = MEMORY_FRACTION * avail
    if need > budget:
        label = spec if isinstance(spec, str) else basis.label()
        most = int((budget - fixed) // per)
        fit = (f"at most {most} particles fit with basis {label}" if most >= 2 else
               f"basis {label} does not fit even with 2 particles; use fewer functions "
               f"(the default is {DEFAULT_BASIS})")
        raise ValueError(
            f"--particles {particles} with --basis {label} would need about {need / GIB:.1f} GiB "
            f"({per / 1024:.0f} KiB per particle); {avail / GIB:.1f} GiB are available: {fit}"
        )
