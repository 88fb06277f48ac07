"""The precision-retention model of one guide on its own: a single-guide axis seen as one object.

:class:`PrecisionMonitor` is an :class:`~guide_health.models.wear.axis.AxisMonitor` with one guide, seen
through its :class:`~guide_health.models.wear.axis.GuideView`: samples go through the axis's input gate
(models/wear/gate.py: bad ones are rejected with a reason and never change the state) to the guide's
physics (models/wear/guide.py: Archard work, the wear effects, K from measured straightness), and the
report gives straightness, wear and the remaining precision life with its 90 % interval (seed 000 Eqs. 7,
10, 11, 12; models/wear/life.py).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from guide_health.models.wear.axis import AxisMonitor, GuideView
from guide_health.models.wear.gate import STREAMS
from guide_health.models.wear.guide import TEMPERATURE_HISTORY, GuideWear

__all__ = ["STREAMS", "TEMPERATURE_HISTORY", "GuideWear", "PrecisionMonitor"]


class PrecisionMonitor(GuideView):
    """Sliding-guide precision monitor (parameters: the frozen guide_health.params.typed.WearAxisParams): one
    guide, its input gate and its report."""

    STATE_VERSION = GuideWear.STATE_VERSION

    def __init__(self, params: Any = None, axis: AxisMonitor | None = None):
        """``params``: a guide of its own (an axis of one guide); ``axis``: the first guide of that axis, its
        inputs going to the whole axis (the single-joint node's ``monitor``)."""
        axis = AxisMonitor(params, guides=("guide",)) if axis is None else axis
        super().__init__(axis, axis.primary_name)

    def on_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """Axis sample; returns the rejection reason or None when accepted."""
        return self.axis.on_joint(t_ns, position_m, velocity_m_s)

    def on_load(self, t_ns: int, load_n: float) -> str | None:
        """Guide-load sample [N]; returns the rejection reason or None when accepted."""
        return self.axis.on_load(t_ns, load_n)

    def on_straightness(self, t_ns: int, straightness_m: float) -> str | None:
        """Straightness measurement [m]; returns the rejection reason or None when accepted."""
        return self.axis.on_straightness(t_ns, straightness_m)

    def on_temperature(self, t_ns: int, temperature_c: float) -> str | None:
        """A guide/temperature reading [degC]; returns the rejection reason of an implausible one, else None."""
        return self.axis.on_temperature(t_ns, temperature_c)

    def reject_input(self, stream: str, reason: str) -> str:
        return self.axis.reject_input(stream, reason)

    def process_run(self, run, progress: Callable[[int, int], None] | None = None) -> None:
        """Feed a whole :class:`~guide_health.runs.MachineRun` with the same rules as the live callbacks."""
        self.axis.process_run(run, progress)
