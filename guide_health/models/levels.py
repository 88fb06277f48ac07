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
