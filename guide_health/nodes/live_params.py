"""Run-time parameter changes applied to a running node (``ros2 param set``, the set_parameters service).

The schema (guide_health/params/) says which parameters are dynamic; ``declare_parameters`` validates a
change with the loader's rules (type, range, cross-checks) and refuses a bad one with its reason, then calls
the node's ``on_applied({name: value})``. The functions here carry an accepted change into the objects
that use it, so that the next status is judged with it:

- thresholds (levels, alarm clear margin): the monitors read them from their ``params`` (a dict, or a frozen
  parameter object replaced by one with the change, guide_health.params.typed) at each report;
- plausibility limits of the inputs: the monitor's InputLimits rebuilt (guide_health.models.wear.input_rules);
- ``straightness_noise_m``: the K estimator's measurement noise (the posterior is recomputed per report);
- windows: ``input_align_window_s`` (StampAlignedFeed), ``rejected_window_samples`` (the recent-sample
  deques keep their newest entries);
- periods: a timer keeps its callback and takes the new period (:class:`PeriodicTimers`);
- ``input_timeout_s``: the StatusUpdater's STALE rule.

A change applies from the next sample or status on; the state (wear, measurements) is never reset by it,
and it is not written back to the parameters file: an offline replay with the file uses the file's values.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

from guide_health.params.typed import with_changes

#: wear_monitor parameters whose change rebuilds the input plausibility limits
LIMIT_PARAMS = ("travel_margin_m", "load_max_n", "load_max_rating_multiple", "straightness_max_multiple")


class PeriodicTimers:
    """The node's timers by the parameter holding their period [s]: ``create(name, period_s, callback)``;
    ``apply(changed)`` gives a timer a changed period (rclpy Timer.timer_period_ns)."""

    def __init__(self, node):
        self.node = node
        self.timers: dict[str, object] = {}

    def create(self, name: str, period_s: float, callback: Callable[[], None]):
        timer = self.node.create_timer(period_s, callback)
        self.timers[name] = timer
        return timer

    def apply(self, changed: dict) -> None:
        for name, timer in self.timers.items():
            if name in changed:
                timer.timer_period_ns = int(round(float(changed[name]) * 1e9))
                timer.reset()


def apply_wear_changes(changed: dict, axes: Iterable, feeds: Iterable, updater, timers: PeriodicTimers,
                       alarms: Iterable = ()) -> None:
    """wear_monitor: every axis's model (AxisMonitor.apply_params: its guides and its input gate), every
    axis's feed, the STALE rule, the timers, the alarms."""
    for axis in axes:
        axis.apply_params(changed, with_changes, LIMIT_PARAMS)
    if "input_align_window_s" in changed:
        for feed in feeds:
            feed.window_s = float(changed["input_align_window_s"])
    apply_common(changed, updater, timers, alarms)


def apply_common(changed: dict, updater, timers: PeriodicTimers, alarms: Iterable = ()) -> None:
    """What every node has: the STALE timeout of its StatusUpdater, its timers, its alarms' clear margin."""
    if "input_timeout_s" in changed and updater is not None:
        updater.input_timeout_s = float(changed["input_timeout_s"])
    timers.apply(changed)
    for alarm in alarms:
        alarm.apply_params(changed)


def apply_slewing_changes(changed: dict, core, updater, timers: PeriodicTimers, alarms: Iterable = ()) -> None:
    """slewing_monitor: the allowable stress and warn fraction of the contact model (cached floats)."""
    core.params = with_changes(core.params, changed)
    model = core.model
    model.params = with_changes(model.params, changed)
    if "allowable_contact_stress_pa" in changed:
        model.allowable_pa = float(changed["allowable_contact_stress_pa"])
    if "warn_fraction" in changed:
        model.warn_fraction = float(changed["warn_fraction"])
    apply_common(changed, updater, timers, alarms)


def apply_fleet_changes(changed: dict, board, history, timers: PeriodicTimers) -> None:
    """fleet_monitor: the board's STALE/forget ages, the history period, the status timer."""
    if "stale_after_s" in changed:
        board.stale_after_s = float(changed["stale_after_s"])
    if "forget_after_s" in changed and hasattr(board, "forget_after_s"):
        board.forget_after_s = float(changed["forget_after_s"])
    if "history_period_s" in changed and history is not None:
        history.period_s = float(changed["history_period_s"])
    timers.apply(changed)
