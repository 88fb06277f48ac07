"""`guide-health fleet plan`: a simulated fleet of 6 machines with different duties (loads) replayed with
`fleet replay`; the schedule lists exactly the machines whose limit date at the 90 % lower bound falls within
the horizon, grouped by the documented rule, and the .ics parses with the icalendar package with one event
per stop. From the fleet_monitor history: the same rule, the newest row as the start, and the trend page's
section."""
from __future__ import annotations

import csv
import json
import math
from datetime import UTC, date, datetime, timedelta
from pathlib import Path

import pytest

from guide_health.analysis.fleet_plan import DAY_S, Due, schedule, unix_s
from guide_health.cli.app import main
from guide_health.io.outputs.ical import fold

CONFIG = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
LOADS_N = (3000.0, 4500.0, 6000.0, 9000.0, 12000.0, 18000.0)     # the duties: feed and retract load


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """6 bags of 1 h (10 Hz), machine m0..m5 by namespace, each at its load; `fleet replay --workers 0`."""
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    root = tmp_path_factory.mktemp("fleetplan")
    params = wear_monitor_params(CONFIG)
    for i, load in enumerate(LOADS_N):
        sim = dict(simulation_params(CONFIG), duration_h=1.0, joint_state_rate_hz=10.0, measurement_interval_h=0.25,
                   feed_load_n=load, retract_load_n=load)
        write_machine_bag(simulate_machine(params, sim, seed=10 + i), root / "bags" / f"bag{i}", namespace=f"/m{i}")
    assert main(["fleet", "replay", str(root / "bags"), "--params", str(CONFIG), "--workers", "0", "--no-plot",
                 "--out", str(root / "fleet")]) == 0
    return root / "fleet"


def run_cli(capsys, argv):
    code = main([*argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_fleet_plan_lists_exactly_the_machines_due_within_the_horizon(fleet_dir, tmp_path, capsys):
    import icalendar

    results = json.loads((fleet_dir / "fleet.json").read_text())["bags"]
    low = {e["machine"]: unix_s(e["result"]["limit_date_utc_low"]) for e in results}
    lives = [e["result"]["remaining_life_h"] for e in results]
    assert lives == sorted(lives, reverse=True)                    # the heavier duty wears out first
    start = min(low.values()) - 0.5 * DAY_S
    horizon_h = (sorted(low.values())[3] - start) / 3600.0 + 0.5     # the 4 earliest fall within it
    code, plan = run_cli(capsys, ["fleet", "plan", str(fleet_dir), "--horizon", f"{horizon_h}h", "--group-days",
                                  "0.25", "--from", datetime.fromtimestamp(start, tz=UTC).isoformat(),
                                  "--out", str(tmp_path / "plan")])
    assert code == 0
    expected = sorted((m for m, t in low.items() if t <= start + horizon_h * 3600), key=low.get)
    assert [r["machine"] for r in plan["rows"]] == expected == ["m5", "m4", "m3", "m2"]
    # the grouping rule by hand: a stop opens at the earliest ungrouped due, takes those within 0.25 d
    stops, opened = [], None
    for m in expected:
        if opened is None or low[m] > opened + 0.25 * DAY_S:
            opened = low[m]
            stops.append([])
        stops[-1].append(m)
    assert [[d["machine"] for d in s["dues"]] for s in plan["stops"]] == stops and len(stops) >= 2
    with open(plan["files"]["csv"]) as handle:
        assert [r["machine"] for r in csv.DictReader(handle)] == expected
    calendar = icalendar.Calendar.from_ical(Path(plan["files"]["ics"]).read_bytes())
    events = list(calendar.walk("VEVENT"))
    assert len(events) == len(stops)
    for event, stop, s in zip(events, stops, plan["stops"]):
        assert event.decoded("DTSTART") == date.fromisoformat(s["date"])
        assert event.decoded("DTEND") - event.decoded("DTSTART") == timedelta(days=1)
        assert str(event["SUMMARY"]) == "guide regrind stop: " + ", ".join(f"{m} axis" for m in stop)
        assert str(event["DESCRIPTION"]).count("\n") == len(stop) - 1


def test_history_plan_and_the_trend_page_section(tmp_path, capsys):
    """Statuses in the fleet_monitor history: the latest row of each status counts, the newest row is the
    start; overdue lower bounds go in the first stop, at the start; the trend page carries the section."""
    from guide_health.io.outputs.fleet_history import FleetHistory

    t0 = datetime(2027, 1, 4, tzinfo=UTC).timestamp()

    def iso(d: float) -> str:
        return datetime.fromtimestamp(t0 + d * DAY_S, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")

    history = FleetHistory(str(tmp_path / "fleet.db"), period_s=0.0)
    # lower-bound day after t0 (the limit 5 days later: m7's lower bound is within 12 weeks, its limit not)
    days = {"m1": 200, "m2": 10, "m3": 12, "m4": -1, "m5": 30, "m6": 90, "m7": 80}
    for m, d in days.items():
        history.record(t0 - 5 * DAY_S, m, "x precision", 0, "ok", {"limit_date_utc_low": iso(1),
                                                                  "limit_date_utc": iso(2), "limit_date_utc_high": ""})
        history.record(t0, m, "x precision", 0, "ok", {"remaining_life_h": 10.0, "limit_date_utc_low": iso(d),
                                                      "limit_date_utc": iso(d + 5), "limit_date_utc_high": ""})
    history.commit()
    code, plan = run_cli(capsys, ["fleet", "plan", str(tmp_path / "fleet.db"), "--out", str(tmp_path / "p")])
    assert code == 0 and plan["start_utc"].startswith("2027-01-04")
    assert [r["machine"] for r in plan["rows"]] == ["m4", "m2", "m3", "m5", "m7"]   # 12 weeks: not m6 (90 d)
    assert [(s["date"], [d["machine"] for d in s["dues"]]) for s in plan["stops"]] == [
        ("2027-01-04", ["m4"]), ("2027-01-14", ["m2", "m3"]), ("2027-02-03", ["m5"]), ("2027-03-25", ["m7"])]
    assert [r["overdue"] for r in plan["rows"]] == [True, False, False, False, False]
    assert plan["stops"][0]["dues"][0]["limit_date_utc_high"] == ""                 # never: no upper bound
    assert main(["fleet", "trend", str(tmp_path / "fleet.db"), "--out", str(tmp_path / "trend")]) == 0
    page = (tmp_path / "trend" / "index.html").read_text()
    section = page[page.index("<h2 id='plan'>"):page.index("<h2>Fleet overview</h2>")]
    assert section.count("<tr><td>") == 5 and "4 stops" in section and "overdue" in section


def test_schedule_rule_and_ics_folding():
    """Group 0 days: one stop per distinct date; a due past the horizon is left out; a long line folds at 75
    octets without cutting a UTF-8 character."""
    dues = [Due("a", "x", 5.0, 1.0, 9.0), Due("b", "x", 5.0, 1.0, math.inf), Due("c", "y", 9.0, 3.0, 20.0),
            Due("d", "x", 99.0, 50.0, 200.0)]
    stops = schedule(dues, 0.0, 10.0, 0.0)
    assert [[d.machine for d in s["dues"]] for s in stops] == [["a", "b"], ["c"]]
    line = "DESCRIPTION:" + "ü" * 80
    folded = fold(line)
    assert all(len(part.encode()) <= 75 for part in folded.split("\r\n"))
    assert folded.replace("\r\n ", "").rstrip("\r\n") == line


def test_history_dues_are_each_status_newest_readable_dates(tmp_path):
    """dues_from_history: a status's newest row with dates counts; newest dates unreadable: its last readable
    ones before them; none readable: no due; a newer row without dates changes nothing."""
    from guide_health.analysis.fleet_plan import dues_from_history
    from guide_health.io.outputs.fleet_history import FleetHistory

    t0 = datetime(2027, 1, 4, tzinfo=UTC).timestamp()
    history = FleetHistory(str(tmp_path / "fleet.db"), period_s=0.0)
    rows = [("m1", -3, "2027-01-20"), ("m1", -2, "2027-02-01"), ("m1", 0, "garbage"), ("m2", -1, "2027-02-05"),
            ("m2", 0, "2027-02-07"),
            ("m3", -1, "not a date"), ("m3", 0, "garbage"), ("m2", 1, None)]
    for m, day, low in rows:
        dates = {} if low is None else {"limit_date_utc_low": low, "limit_date_utc": "2027-03-01"}
        history.record(t0 + day * DAY_S, m, "x precision", 0, "", {"remaining_life_h": 5.0, **dates})
    history.commit()
    dues, newest = dues_from_history(tmp_path / "fleet.db")
    assert newest == t0 + DAY_S
    assert sorted((d.machine, _iso_day(d.limit_low_s)) for d in dues) == [("m1", "2027-02-01"), ("m2", "2027-02-07")]
    # the same through the rows alone (layout 2), and with m2's newest dated row deleted after its hourly row
    # named it (retention keeps whole hours): its older dates, through the index
    import shutil
    import sqlite3

    history.close()
    layout2 = tmp_path / "layout2.db"
    shutil.copy(tmp_path / "fleet.db", layout2)
    con = sqlite3.connect(layout2)
    con.executescript("DROP TABLE fleet_history_hourly; PRAGMA user_version = 2;")
    con.close()
    assert sorted((d.machine, d.limit_low_s) for d in dues_from_history(layout2)[0]) == sorted(
        (d.machine, d.limit_low_s) for d in dues)
    con = sqlite3.connect(tmp_path / "fleet.db")
    con.execute("DELETE FROM fleet_history WHERE hardware_id = 'm2' AND t_unix_s = ?", (t0,))
    con.commit()
    con.close()
    dues, _ = dues_from_history(tmp_path / "fleet.db")
    assert sorted((d.machine, _iso_day(d.limit_low_s)) for d in dues) == [("m1", "2027-02-01"), ("m2", "2027-02-05")]


def _iso_day(t_s: float) -> str:
    return datetime.fromtimestamp(t_s, tz=UTC).strftime("%Y-%m-%d")
