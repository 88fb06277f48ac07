"""The form of a worn rail: minimum-zone straightness of a profile and the stroke range of an axis.

Both serve the straightness models of :mod:`guide_health.models.wear.archard` (seed 000 Eq. 7 needs the
stroke range l_min .. l_max; the ``profile`` model the minimum-zone width of the worn profile), and both
are used by the live and the offline paths alike.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# ---------------------------------------------------------------------------------------------
# Minimum-zone straightness
# ---------------------------------------------------------------------------------------------


def minimum_zone_straightness_m(position_m: np.ndarray, height_m: np.ndarray) -> float:
    """Width of the narrowest pair of parallel lines enclosing the profile (u, h) [m] (minimum zone).

    The optimal lines are parallel to an edge of the convex hull (rotating calipers), so the width is the
    minimum over hull edges of the vertical spread of h - s u. Measured vertically (slopes are ~1e-5).
    """
    u = np.asarray(position_m, dtype=float)
    h = np.asarray(height_m, dtype=float)
    from scipy.spatial import ConvexHull, QhullError  # here: readers import this package, few need the hull

    spread_h = float(np.ptp(h)) if h.size else 0.0
    if h.size < 3 or spread_h == 0.0:
        return spread_h
    spread_u = float(np.ptp(u))
    points = np.column_stack(((u - u.min()) / spread_u, (h - h.min()) / spread_h))
    try:
        hull = ConvexHull(points)
    except QhullError:  # collinear: a straight (tilted) line has zero straightness error
        return 0.0
    vertices = points[hull.vertices]
    best = math.inf
    for i, j in hull.simplices:
        du = points[j, 0] - points[i, 0]
        if du == 0.0:
            continue
        slope = (points[j, 1] - points[i, 1]) / du
        residual = vertices[:, 1] - slope * vertices[:, 0]
        best = min(best, float(residual.max() - residual.min()))
    return best * spread_h


# ---------------------------------------------------------------------------------------------
# Stroke tracking (zig-zag with hysteresis): shared by the live and offline paths
# ---------------------------------------------------------------------------------------------


@dataclass
class StrokeTracker:
    """Detects stroke reversals of an axis: a reversal is confirmed when the position retreats from its
    running extreme by more than ``threshold_m``; a stroke is the distance between two confirmed extremes.

    Feeding only the local extrema of a sample sequence gives the same strokes as feeding every sample
    (between extrema the motion is monotonic), which is how :meth:`update_many` stays fast.
    """

    threshold_m: float = 0.005
    direction: int = 0                    # +1 rising, -1 falling, 0 unknown
    extreme_m: float = math.nan           # running extreme in the current direction
    anchor_m: float = math.nan            # last confirmed extreme (start of the current stroke)
    stroke_min_m: float = math.inf
    stroke_max_m: float = 0.0
    stroke_count: int = 0
    stroke_sum_m: float = 0.0
    stroke_sum_sq_m2: float = 0.0

    def _confirm(self, extreme: float) -> None:
        if not math.isnan(self.anchor_m):
            stroke = abs(extreme - self.anchor_m)
            if stroke >= self.threshold_m:
                self.stroke_min_m = min(self.stroke_min_m, stroke)
                self.stroke_max_m = max(self.stroke_max_m, stroke)
                self.stroke_count += 1
                self.stroke_sum_m += stroke
                self.stroke_sum_sq_m2 += stroke * stroke
        self.anchor_m = extreme

    def update(self, position_m: float) -> None:
        x = float(position_m)
        if math.isnan(self.extreme_m):
            self.extreme_m = x
            self.anchor_m = x
            return
        if self.direction >= 0 and x >= self.extreme_m:
            self.extreme_m = x
            if self.direction == 0 and x - self.anchor_m > self.threshold_m:
                self.direction = 1
        elif self.direction <= 0 and x <= self.extreme_m:
            self.extreme_m = x
            if self.direction == 0 and self.anchor_m - x > self.threshold_m:
                self.direction = -1
        elif abs(x - self.extreme_m) > self.threshold_m:
            # retreat beyond the hysteresis: the running extreme was a reversal
            if self.direction != 0:
                self._confirm(self.extreme_m)
            self.direction = 1 if x > self.extreme_m else -1
            self.extreme_m = x

    def update_many(self, position_m: np.ndarray) -> None:
        x = np.asarray(position_m, dtype=float)
        if x.size <= 2:
            for value in x:
                self.update(value)
            return
        dx = np.diff(x)
        sign = np.sign(dx)
        nz = np.flatnonzero(sign)
        # indices where the direction of motion changes (local extrema), plus both ends
        if nz.size:
            changes = nz[1:][sign[nz[1:]] != sign[nz[:-1]]]
        else:
            changes = np.empty(0, dtype=np.int64)
        candidates = np.concatenate(([0], changes, [x.size - 1]))
        for value in x[candidates]:
            self.update(value)

    def stroke_range_m(self) -> tuple[float, float]:
        """(l_min, l_max) of completed strokes, NaN before the first one."""
        if self.stroke_count == 0:
            return math.nan, math.nan
        return self.stroke_min_m, self.stroke_max_m

    def state(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    @classmethod
    def from_state(cls, state: dict) -> StrokeTracker:
        return cls(**state)
