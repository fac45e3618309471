"""Figures. One module per figure family (``plots.gpssm``, ``plots.classification``,
``plots.cascade``, ``plots.maps``, ``plots.signals``); all use the non-interactive
Agg backend and label friction in absolute units (force over load, not normalised).
"""

import matplotlib

matplotlib.use("Agg")
