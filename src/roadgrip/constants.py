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
