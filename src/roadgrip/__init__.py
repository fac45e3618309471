"""roadgrip: online tire-road friction estimation and mapping.

Everything inside the package is in SI units with ISO 8855 vehicle axes
(x forward, y left, z up, yaw positive counter-clockwise). Degrees, g and
km/h appear only at the edges (file readers, CLI flags, plot labels).
"""

from roadgrip.constants import GRAVITY

__all__ = ["GRAVITY", "__version__"]
__version__ = "0.1.0"
