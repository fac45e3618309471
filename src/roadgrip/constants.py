"""Physical constants and numerical regularisation constants, named once."""

GRAVITY = 9.80665
"""Standard gravity [m/s²]."""

V_EPS = 0.5
"""Speed regularisation for slip computations [m/s].

Slip angles and longitudinal slips divide by a speed. Below a few m/s the
kinematic slip definitions become singular; every slip function in roadgrip
replaces the denominator ``|vx|`` by ``sqrt(vx**2 + V_EPS**2)`` so that slips
stay finite and continuous down to standstill, and agree with the textbook
definition to better than 0.5 % once ``|vx| > 5 m/s`` (for F1TENTH-scale cars a
smaller value can be passed explicitly).
"""

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal distribution, ``Phi^-1(0.975)`` [-].

``mean ± Z95 std`` is the central 95 % interval of a normal estimate.
"""

GRIP_CLASS_SPLIT = 0.7
"""Peak friction [-] that separates the grip classes, the one split of the project.

A surface whose peak friction is at least this is 'high' grip, below it 'low'
(between gravel, 0.6, and wet asphalt, 0.75). The classifiers' published bounds
follow from it ('high': at least the split; 'low': below it) and the honesty rule
(:mod:`roadgrip.evaluate.honesty`) judges grip classes against it.
"""

FRICTION_MAX = 2.0
"""Upper end of a friction band that claims nothing [-]: no tire-road peak friction
reaches it (racing slicks on a dry track stay below 1.8 without downforce)."""
