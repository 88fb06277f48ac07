"""Status levels: the one enum behind every monitor's judgement, the nodes' DiagnosticStatus and the reports.

The values are those of diagnostic_msgs/DiagnosticStatus (OK 0, WARN 1, ERROR 2, STALE 3), so a level
converts to the message's byte with ``bytes([level])`` and back with ``Level(byte)``.
"""
from __future__ import annotations

from enum import IntEnum


class Level(IntEnum):
    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3

    @classmethod
    def parse(cls, value) -> Level:
        """A level from an int, a DiagnosticStatus byte (b'\\x01') or a name ('WARN'); ValueError otherwise."""
        if isinstance(value, (bytes, bytearray)):
            if len(value) != 1:
                raise ValueError(f"level must be one byte, got {value!r}")
            value = value[0]
        if isinstance(value, str):
            try:
                return cls[value.strip().upper()]
            except KeyError:
                raise ValueError(f"unknown level {value!r}") from None
        return cls(int(value))


OK, WARN, ERROR, STALE = Level.OK, Level.WARN, Level.ERROR, Level.STALE
LEVEL_NAMES = {level: level.name for level in Level}


# --- alarms: hysteresis and latching (the one place of these rules; docs/ros.md "Alarms") ----------------

def exceeds(value: float, threshold: float, margin: float = 0.0, inclusive: bool = False) -> bool:
    """``value`` above a level's threshold (the worse side is above). ``margin`` > 0: the threshold of the
    clearing test, lowered by that fraction: a level raised at ``threshold`` holds while ``value`` stays above
    ``threshold (1 - margin)``."""
    limit = threshold * (1.0 - margin)
    return value >= limit if inclusive else value > limit


def falls_below(value: float, threshold: float, margin: float = 0.0) -> bool:
    """``value`` below a level's threshold (the worse side is below, e.g. a remaining life); the clearing
    test's threshold is raised by ``margin``: the level holds while ``value`` < ``threshold (1 + margin)``."""
    return value < threshold * (1.0 + margin)


def hysteresis_level(current: Level | None, level_set: Level, level_clear: Level) -> Level:
    """Schmitt trigger over levels. ``level_set``: the level judged at the thresholds; ``level_clear``: judged
    with every threshold moved by the clear margin towards the good side (so ``level_clear >= level_set``). A
    level rises as soon as ``level_set`` does, and drops only as far as ``level_clear`` allows: a value
    hovering within the margin of a threshold keeps its level instead of toggling every period."""
    if current is None or level_set >= current:
        return Level(level_set)
    return Level(min(current, max(level_set, level_clear)))


class Alarm:
    """One status's alarm: the hysteresis level, and ERROR events latched until acknowledged.

    ``update(level_set, level_clear, message)`` -> (level, message) to publish: the hysteresis level; an ERROR
    event (a rise to ERROR) is counted and latched, so that a one-period ERROR (a slewing overstress between
    two OK periods) is still published as ERROR, with its message, until ``acknowledge()``. STALE is passed
    through and changes nothing.
    """

    def __init__(self):
        self.level: Level | None = None
        self.events = 0                       # ERROR events since start
        self.latched: str | None = None       # message of the first unacknowledged ERROR event
        self.latched_events = 0               # ERROR events since the last acknowledgement

    def update(self, level_set: Level, level_clear: Level, message: str) -> tuple[Level, str]:
        if level_set == Level.STALE:
            return Level.STALE, message
        previous = self.level
        self.level = hysteresis_level(previous, Level(level_set), Level(min(level_clear, Level.ERROR)))
        if self.level == Level.ERROR and previous != Level.ERROR:
            self.events += 1
            self.latched_events += 1
            if self.latched is None:
                self.latched = message
        if self.latched is not None and self.level < Level.ERROR:
            return Level.ERROR, (f"ERROR latched until acknowledged ({self.latched_events} events; first: "
                                 f"{self.latched}); now {Level(self.level).name}: {message}")
        return self.level, message

    def acknowledge(self) -> int:
        """Clear the latch; the number of ERROR events it held."""
        held = self.latched_events if self.latched is not None else 0
        self.latched, self.latched_events = None, 0
        return held

    def values(self) -> dict:
        return {"alarm_events": self.events, "alarm_latched": int(self.latched is not None)}   # numbers only
