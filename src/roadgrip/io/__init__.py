"""Reading and describing drives.

``read_drive``     canonical CSV/Parquet and the shared ``dart`` / ``frictionmaps`` data sets
``read_mapped``    foreign logs through a column-mapping YAML file
``resample``       asynchronous streams onto one clock
``describe_drive`` the summary printed by ``roadgrip info``
"""

from roadgrip.io.read import FORMATS, detect_format, read_drive
from roadgrip.io.resample import make_clock, resample

__all__ = ["FORMATS", "detect_format", "make_clock", "read_drive", "resample"]
