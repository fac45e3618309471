"""Reading and describing drives.

``read_drive``     canonical CSV/Parquet and the shared ``dart`` / ``frictionmaps`` data sets
``read_mapped``    foreign logs through a column-mapping YAML file
``resample``       asynchronous streams onto one clock
``describe_drive`` the summary printed by ``roadgrip info``
"""

from roadgrip.io.describe import (
    Excitation,
    describe_drive,
    nonlinear_fraction,
    slip_at_fraction_of_peak,
)
from roadgrip.io.mapping import load_mapping, read_mapped
from roadgrip.io.read import FORMATS, detect_format, read_drive
from roadgrip.io.resample import make_clock, resample

__all__ = [
    "FORMATS",
    "Excitation",
    "describe_drive",
    "detect_format",
    "load_mapping",
    "make_clock",
    "nonlinear_fraction",
    "read_drive",
    "read_mapped",
    "resample",
    "slip_at_fraction_of_peak",
]
