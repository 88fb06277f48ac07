"""An iCalendar file (RFC 5545) of all-day events, written by hand: VCALENDAR / VEVENT with UID, DTSTAMP,
DTSTART / DTEND as DATE values, SUMMARY and DESCRIPTION; TEXT values escaped (3.3.11: backslash, semicolon,
comma, newline), content lines ended by CRLF and folded at 75 octets (3.1) without splitting a UTF-8
character."""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from datetime import UTC, date, datetime, timedelta

PRODID = "-//guide_health//fleet plan//EN"


@dataclass(frozen=True)
class AllDayEvent:
    day: date
    summary: str
    description: str


def escape_text(text: str) -> str:
    """RFC 5545 3.3.11 TEXT: \\ ; , escaped, a newline as \\n."""
    return (text.replace("\\", "\\\\").replace(";", "\\;").replace(",", "\\,")
            .replace("\r\n", "\\n").replace("\n", "\\n"))


def fold(line: str) -> str:
    """One content line folded at 75 octets (3.1): CRLF and a space before each continuation."""
    data, parts, limit = line.encode("utf-8"), [], 75
    while len(data) > limit:
        cut = limit
        while cut > 0 and (data[cut] & 0xC0) == 0x80:       # not inside a UTF-8 sequence
            cut -= 1
        parts.append(data[:cut])
        data, limit = data[cut:], 74                        # the leading space counts
    parts.append(data)
    return "\r\n ".join(p.decode("utf-8") for p in parts) + "\r\n"


def calendar_text(events: list[AllDayEvent], stamp: datetime) -> str:
    """The VCALENDAR of ``events``; ``stamp`` (UTC) is every event's DTSTAMP. The UID is a hash of the
    event's day and summary: the same stop planned again keeps its UID (a calendar import updates it)."""
    lines = ["BEGIN:VCALENDAR", "VERSION:2.0", f"PRODID:{PRODID}", "CALSCALE:GREGORIAN", "METHOD:PUBLISH"]
    dtstamp = stamp.astimezone(UTC).strftime("%Y%m%dT%H%M%SZ")
    for e in events:
        uid = hashlib.sha1(f"{e.day.isoformat()} {e.summary}".encode()).hexdigest()[:24]
        lines += ["BEGIN:VEVENT", f"UID:{uid}@guide_health", f"DTSTAMP:{dtstamp}",
                  f"DTSTART;VALUE=DATE:{e.day.strftime('%Y%m%d')}",
                  f"DTEND;VALUE=DATE:{(e.day + timedelta(days=1)).strftime('%Y%m%d')}",
                  f"SUMMARY:{escape_text(e.summary)}", f"DESCRIPTION:{escape_text(e.description)}",
                  "TRANSP:OPAQUE", "END:VEVENT"]
    lines.append("END:VCALENDAR")
    return "".join(fold(line) for line in lines)
