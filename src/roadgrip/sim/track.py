"""Closed tracks and the path-following driver that laps them.

The driver (compiled in :func:`roadgrip.sim.engine.integrate_planar`) steers by
pure pursuit: it aims at the path point one look-ahead distance
``L = lookahead0 + lookahead_gain vx`` away and steers
``delta = arctan(2 l y_L / L²)`` with ``y_L`` the point's lateral offset in body
axes. Its speed reference is the track's speed profile (lateral-acceleration
limited in the corners, acceleration and braking limited between them), read
``speed_preview`` seconds ahead, tracked by a PI controller.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["ClosedTrack", "TrackDriver"]


@dataclass(frozen=True, eq=False)
class ClosedTrack:
    """A closed centre line, sampled densely and counter-clockwise.

    Attributes
    ----------
    x, y : ndarray, shape (n,)
        Points [m]; the last point connects back to the first.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]

    def __post_init__(self) -> None:
        if len(self.x) != len(self.y) or len(self.x) < 8:
            raise ValueError("a closed track needs at least 8 points with matching x and y")

    @classmethod
    def rounded_rectangle(
        cls, length: float, width: float, radius: float, ds: float = 0.05,
        center: tuple[float, float] = (0.0, 0.0),
    ) -> ClosedTrack:
        """Rectangle ``length x width`` [m] with corner arcs of ``radius`` [m], spacing ``ds`` [m].

        Starts in the middle of the bottom straight heading +x (counter-clockwise laps).
        """
        if not (0 < 2 * radius <= min(length, width)):
            raise ValueError("corner radius must be positive and at most half the shorter side")
        a, b = length / 2 - radius, width / 2 - radius
        pts = []
        # corners: centres and start angles, counter-clockwise from the bottom straight
        segs = [
            ((-0.0, -width / 2), (a, -width / 2)),
            ("arc", (a, -b), -np.pi / 2),
            ((length / 2, -b), (length / 2, b)),
            ("arc", (a, b), 0.0),
            ((a, width / 2), (-a, width / 2)),
            ("arc", (-a, b), np.pi / 2),
            ((-length / 2, b), (-length / 2, -b)),
            ("arc", (-a, -b), np.pi),
            ((-a, -width / 2), (0.0, -width / 2)),
        ]
        for seg in segs:
            if seg[0] == "arc":
                (cx, cy), th0 = seg[1], seg[2]
                n = max(2, int(np.ceil(radius * np.pi / 2 / ds)))
                th = th0 + np.linspace(0, np.pi / 2, n, endpoint=False)
                pts.append(np.stack([cx + radius * np.cos(th), cy + radius * np.sin(th)], 1))
            else:
                (x0, y0), (x1, y1) = seg
                d = np.hypot(x1 - x0, y1 - y0)
                n = max(1, int(np.ceil(d / ds)))
                s = np.linspace(0, 1, n, endpoint=False)
                pts.append(np.stack([x0 + s * (x1 - x0), y0 + s * (y1 - y0)], 1))
        p = np.concatenate(pts) + np.asarray(center)
        return cls(p[:, 0].copy(), p[:, 1].copy())

    @property
    def n(self) -> int:
        return len(self.x)

    def segment_lengths(self) -> NDArray[np.float64]:
        """Distance from point i to point i+1 (cyclic) [m], shape (n,)."""
        return np.hypot(np.roll(self.x, -1) - self.x, np.roll(self.y, -1) - self.y)

    @property
    def length(self) -> float:
        """Lap length [m]."""
        return float(self.segment_lengths().sum())

    def heading(self) -> NDArray[np.float64]:
        """Tangent direction at each point [rad]."""
        return np.arctan2(np.roll(self.y, -1) - np.roll(self.y, 1), np.roll(self.x, -1) - np.roll(self.x, 1))

    def curvature(self) -> NDArray[np.float64]:
        """Signed curvature [1/m] (positive turning left), central differences."""
        h = np.unwrap(self.heading())
        dh = np.roll(h, -1) - np.roll(h, 1)
        dh = (dh + np.pi) % (2 * np.pi) - np.pi
        ds = self.segment_lengths() + np.roll(self.segment_lengths(), 1)
        return dh / ds

    def speed_profile(
        self, v_max: float, ay_max: float | NDArray[np.float64], a_acc: float, a_brake: float
    ) -> NDArray[np.float64]:
        """Speed limit along the track [m/s]: ``sqrt(ay_max / |kappa|)`` capped at ``v_max``,
        then forward (acceleration ``a_acc``) and backward (braking ``a_brake``) passes,
        repeated around the loop. ``ay_max`` [m/s²] is one budget or one per point, shape (n,)."""
        k = np.abs(self.curvature())
        # smooth the curvature so the straight-to-arc jump is seen a little early
        k = np.maximum.reduce([np.roll(k, s) for s in range(-3, 4)])
        v = np.minimum(v_max, np.sqrt(ay_max / np.maximum(k, 1e-9)))
        ds = self.segment_lengths()
        n = self.n
        for _ in range(2):
            for i in range(2 * n):  # forward: acceleration limit
                j, jn = i % n, (i + 1) % n
                v[jn] = min(v[jn], np.sqrt(v[j] ** 2 + 2 * a_acc * ds[j]))
            for i in range(2 * n, 0, -1):  # backward: braking limit
                j, jp = i % n, (i - 1) % n
                v[jp] = min(v[jp], np.sqrt(v[j] ** 2 + 2 * a_brake * ds[jp]))
        return v

    def to_dict(self) -> dict:
        return {"x": self.x.tolist(), "y": self.y.tolist()}


@dataclass(frozen=True)
class TrackDriver:
    """Lap a :class:`ClosedTrack` with pure pursuit and a PI speed controller.

    Attributes
    ----------
    track : ClosedTrack
    v_max : float
        Top speed on the straights [m/s].
    ay_max : float
        Lateral acceleration the speed profile plans for in corners [m/s²].
    a_acc, a_brake : float
        Planned acceleration and braking [m/s²], both positive.
    lookahead0 : float
        Pure-pursuit look-ahead at standstill [m].
    lookahead_gain : float
        Look-ahead growth with speed [s].
    speed_preview : float
        Speed reference preview [s].
    """

    track: ClosedTrack
    v_max: float
    ay_max: float
    a_acc: float = 2.0
    a_brake: float = 3.0
    lookahead0: float = 0.5
    lookahead_gain: float = 0.15
    speed_preview: float = 0.4

    def path_speed(self) -> NDArray[np.float64]:
        return self.track.speed_profile(self.v_max, self.ay_max, self.a_acc, self.a_brake)
