"""`guide-health fleet trend HISTORY.db`: the fleet_monitor history as per-machine trends, CSV, PNG and a
static HTML page whose every image is checked to exist and decode (and, where Debian's chromium is
installed, rendered headless to a screenshot)."""
import base64
import csv
import io
import json
import re
import shutil
import subprocess
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from guide_health.analysis import fleet_trend_plots
from guide_health.analysis.fleet_trend_plots import min_max_per_bin
from guide_health.cli.app import main
from guide_health.io.outputs.fleet_history import FleetHistory

T0_UNIX_S = 1.8e9
LIFE_RATE_H_PER_H = {"m1": 1.0, "m2": 3.0, "m3": 0.5}     # remaining life lost per hour of history


def life_h(machine: str, hour: int) -> float:
    return 300.0 - LIFE_RATE_H_PER_H[machine] * hour


def level_of(life: float) -> int:
    return 0 if life > 200 else 1 if life > 100 else 2


@pytest.fixture
def history(tmp_path):
    """40 hourly statuses of three wear monitors (life falling 1, 3, 0.5 h per h; WARN below 200 h, ERROR
    below 100 h), one fatigue status (m2) and one slewing monitor (c1), written by fleet_monitor's history."""
    db = tmp_path / "fleet.db"
    h = FleetHistory(str(db), 0.0)
    for hour in range(40):
        t = T0_UNIX_S + 3600.0 * hour
        for m in LIFE_RATE_H_PER_H:
            life = life_h(m, hour)
            h.record(t, m, "wear_monitor: x precision", level_of(life), f"life {life:.0f} h",
                     {"remaining_life_h": repr(life), "straightness_um": repr(15.0 + hour)})
        h.record(t, "m2", "wear_monitor: x fatigue", 0, "", {"life_used_fraction": repr(0.01 * hour)})
        h.record(t, "c1", "slewing_monitor: b1 roller contact", 0, "", {"end_stress_ratio": repr(1.1 + 0.001 * hour)})
    h.close()
    return db


class ImageSources(HTMLParser):
    def __init__(self):
        super().__init__()
        self.sources, self.links, self.names = [], [], []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.sources.append(a["src"])
        if tag == "a" and not a["href"].startswith("#"):
            self.links.append(a["href"])
            self.names.append(a.get("download"))


def check_page(page: Path) -> list[np.ndarray]:
    """The page is self-contained: every image is a data URI that decodes, every link (but the page's own
    anchors) a data URI whose CSV equals the file of the same name written beside it; no relative link."""
    parser = ImageSources()
    parser.feed(page.read_text())
    assert all(src.startswith("data:image/png;base64,") for src in parser.sources), "an image file link"
    images = [imread(io.BytesIO(base64.b64decode(src.split(",", 1)[1])), format="png") for src in parser.sources]
    assert all(href.startswith("data:text/csv;base64,") for href in parser.links), "a link to a sibling file"
    embedded = {name: base64.b64decode(href.split(",", 1)[1]) for name, href in zip(parser.names, parser.links)}
    assert embedded == {p.name: p.read_bytes() for p in page.parent.glob("*.csv")}     # every table, exactly
    assert all(img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100 for img in images)
    return images


def test_trend_of_a_history(history, tmp_path, capsys):
    assert main(["fleet", "trend", str(history), "--out", str(tmp_path / "t"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert (result["machines"], result["rows"]) == (4, 40 * 5)
    # ranking by latest remaining life (hour 39): 300 - rate x 39 h = 183 (m2), 261 (m1), 280.5 (m3)
    ranked = [(r["machine"], r["remaining_life_h"], r["level"]) for r in result["ranking"]]
    assert ranked[:3] == [("m2", 183.0, "WARN"), ("m1", 261.0, "OK"), ("m3", 280.5, "OK")]
    assert ranked[3][0] == "c1" and result["ranking"][3]["end_stress_ratio"] == pytest.approx(1.139)
    # m2 drops below 200 h at hour 34 (300 - 3 h = 198): one change OK -> WARN
    changes = result["level_changes"]["m2"]
    assert [(c["from"], c["to"], c["t_unix_s"]) for c in changes] == [("OK", "WARN", T0_UNIX_S + 34 * 3600.0)]
    assert result["level_changes"]["m1"] == []
    with open(tmp_path / "t" / "machine_m2.csv") as handle:
        rows = list(csv.DictReader(handle))
    precision = [r for r in rows if r["status"] == "wear_monitor: x precision"]
    assert [float(r["remaining_life_h"]) for r in precision] == [life_h("m2", h) for h in range(40)]
    assert float(rows[-1]["life_used_fraction"]) == pytest.approx(0.39)
    images = check_page(Path(result["files"]["html"]))
    assert len(images) == 1 + 4                            # the overview and one plot per machine
    only = tmp_path / "only"
    assert main(["fleet", "trend", str(history), "--machine", "m3", "--out", str(only)]) == 0
    assert sorted(p.name for p in only.glob("machine_*")) == ["machine_m3.csv", "machine_m3.png"]
    capsys.readouterr()
    assert main(["fleet", "trend", str(history), "--days", str(10 / 24), "--out", str(tmp_path / "d"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["rows"] == 11 * 5          # hours 29..39 of 5 statuses


def test_trend_draws_figures_for_the_first_machines_of_the_ranking_only(history, tmp_path, capsys):
    """--plots 2: figures for the two least remaining lives (m2 183 h, m1 261 h); every machine keeps its
    CSV, embedded in the page; --plots 0: the overview only."""
    assert main(["fleet", "trend", str(history), "--out", str(tmp_path / "t"), "--plots", "2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in (tmp_path / "t").glob("machine_*.png")) == ["machine_m1.png", "machine_m2.png"]
    assert len(list((tmp_path / "t").glob("machine_*.csv"))) == 4
    assert len(check_page(Path(result["files"]["html"]))) == 1 + 2
    assert main(["fleet", "trend", str(history), "--out", str(tmp_path / "z"), "--plots", "0"]) == 0
    assert not list((tmp_path / "z").glob("machine_*.png")) and len(check_page(tmp_path / "z" / "index.html")) == 1
    assert main(["fleet", "trend", str(history), "--plots", "-1"]) == 2
    assert "--plots must be >= 0" in capsys.readouterr().err


def test_trend_bad_input_is_one_line(history, tmp_path, capsys):
    assert main(["fleet", "trend", str(history), "--machine", "m9", "--out", str(tmp_path / "x")]) == 2
    assert "no history of machine 'm9'; machines: c1, m1, m2, m3" in capsys.readouterr().err
    junk = tmp_path / "junk.db"
    junk.write_text("not sqlite")
    assert main(["fleet", "trend", str(junk)]) == 2
    assert "not a fleet history" in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("chromium") is None, reason="Debian's chromium is not installed")
def test_trend_page_renders_in_headless_chromium(history, tmp_path, capsys):
    assert main(["fleet", "trend", str(history), "--out", str(tmp_path / "t")]) == 0
    shot = tmp_path / "screenshot.png"
    subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--window-size=1200,1800", f"--screenshot={shot}", (tmp_path / "t" / "index.html").as_uri()],
                   check=True, capture_output=True, timeout=120)
    img = imread(shot)
    assert img.shape[:2] == (1800, 1200)
    # the page is drawn: the ranking rows' colours (ERROR/WARN red/orange, OK green) are on the screen
    rgb = (img[..., :3] * 255).round().astype(int).reshape(-1, 3)
    assert (np.abs(rgb - [0xfd, 0xeb, 0xd0]).sum(axis=1) == 0).sum() > 1000     # the WARN row (m2)
    assert (np.abs(rgb - [0xd5, 0xf5, 0xe3]).sum(axis=1) == 0).sum() > 1000     # OK rows
    assert rgb.std() > 20                                                      # not a blank page


rclpy = pytest.importorskip("rclpy")


@pytest.mark.ros
def test_trend_of_a_history_written_by_a_live_fleet_monitor(ros_context, tmp_path, capsys):
    """A live fleet_monitor records two machines whose life falls; the trend reads it back."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from guide_health.nodes.fleet_monitor import FleetMonitorNode

    db = tmp_path / "live.db"
    fleet = FleetMonitorNode(context=ros_context, parameter_overrides=[
        Parameter("history_file", value=str(db)), Parameter("history_period_s", value=0.05),
        Parameter("diagnostics_period_s", value=0.1)])
    source = rclpy.create_node("machines", context=ros_context)
    pub = source.create_publisher(DiagnosticArray, "/diagnostics", 10)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(fleet)
    ex.add_node(source)

    def status(hw, life):
        values = [KeyValue(key="remaining_life_h", value=repr(life)), KeyValue(key="straightness_um", value="20.0")]
        return DiagnosticStatus(level=bytes([level_of(life)]), name="wear_monitor: x precision", hardware_id=hw,
                                message=f"life {life:.0f} h", values=values)
    sent = []

    def publish(step):
        life = (300.0 - 5.0 * step, 250.0 - 1.0 * step)
        pub.publish(DiagnosticArray(status=[status("a1", life[0]), status("a2", life[1])]))
        sent.append(life)
        end = time.monotonic() + 0.1
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.01)
    try:
        deadline = time.monotonic() + 120.0          # discovery: step 0 until the fleet monitor has both
        while len(fleet.board.statuses) < 2 and time.monotonic() < deadline:
            publish(0)
        assert len(fleet.board.statuses) == 2
        for step in range(1, 30):
            publish(step)
    finally:
        fleet.close()
        ex.shutdown()
        fleet.destroy_node()
        source.destroy_node()
    assert main(["fleet", "trend", str(db), "--out", str(tmp_path / "t"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["machines"] == 2
    by_machine = {r["machine"]: r for r in result["ranking"]}
    with open(tmp_path / "t" / "machine_a1.csv") as handle:
        lives = [float(r["remaining_life_h"]) for r in csv.DictReader(handle)]
    assert len(lives) >= 5 and all(b < a for a, b in zip(lives, lives[1:]))    # recorded in order, falling
    assert set(lives) <= {s[0] for s in sent}                                 # only values that were sent
    assert by_machine["a1"]["remaining_life_h"] == lives[-1]
    # a1 crossed 200 h (OK -> WARN at step 21); a2 stays above 200 h (OK)
    assert lives[0] == 300.0 and lives[-1] < 200.0
    assert [(c["from"], c["to"]) for c in result["level_changes"]["a1"]] == [("OK", "WARN")]
    assert result["level_changes"]["a2"] == []
    check_page(Path(result["files"]["html"]))


LAYOUT1 = """CREATE TABLE fleet_history (t_unix_s REAL NOT NULL, hardware_id TEXT NOT NULL, name TEXT NOT NULL,
    level INTEGER NOT NULL, message TEXT NOT NULL, values_json TEXT NOT NULL);
CREATE INDEX fleet_history_machine ON fleet_history (hardware_id, name, t_unix_s);"""


def test_a_layout_1_history_is_migrated_by_fleet_monitor_with_the_same_trends(tmp_path):
    """A history of layout 1 (values as one JSON text per row): the trend reader refuses it in one line; the
    history fleet_monitor opens migrates it (json_extract of the same keys), after which the trends are the
    numbers the layout-1 reader gave: a text number, a JSON number, 'nan', no JSON / no object / a missing
    key -> NaN; the limit date texts kept for the plan; the other keys dropped."""
    import math
    import sqlite3

    from guide_health.analysis.fleet_trend import read_trends
    from guide_health.errors import InputError

    db = tmp_path / "old.db"
    con = sqlite3.connect(db)
    con.executescript(LAYOUT1)
    texts = ("not json", "[1, 2]", json.dumps({"remaining_life_h": 12.5, "extra": "x" * 1000}),
             json.dumps({"remaining_life_h": "7.25", "straightness_um": None, "limit_date_utc_low": "2027-01-05"}),
             json.dumps({"remaining_life_h": "nan", "life_used_fraction": "0.5", "end_stress_ratio": "banana"}))
    con.executemany("INSERT INTO fleet_history VALUES (?, ?, ?, ?, ?, ?)",
                    [(T0_UNIX_S + i, "m9", "wear_monitor: x precision", i % 2, f"row {i}", text)
                     for i, text in enumerate(texts)])
    con.commit()
    con.close()
    with pytest.raises(InputError, match="layout 1 .*open it once with fleet_monitor") as info:
        read_trends(db)
    assert "\n" not in str(info.value)
    FleetHistory(str(db), 60.0).close()                     # what fleet_monitor does at start
    m9 = read_trends(db)["m9"]
    life = m9.values["remaining_life_h"]
    assert [math.isnan(v) for v in life] == [True, True, False, False, True]
    assert life[2:4].tolist() == [12.5, 7.25]
    assert math.isnan(m9.values["straightness_um"][3]) and m9.values["life_used_fraction"][4] == 0.5
    assert math.isnan(m9.values["end_stress_ratio"][4])
    assert (m9.level.tolist(), m9.message) == ([0, 1, 0, 1, 0], [f"row {i}" for i in range(5)])
    con = sqlite3.connect(db)
    assert con.execute("SELECT limit_date_utc_low FROM fleet_history WHERE limit_date_utc_low IS NOT NULL"
                       ).fetchall() == [("2027-01-05",)]
    assert con.execute("PRAGMA user_version").fetchone()[0] == 3     # layout 1 -> 2 -> 3 (the hourly rows)
    assert con.execute("SELECT SUM(rows) FROM fleet_history_hourly").fetchone()[0] == 5
    assert "values_json" not in [r[1] for r in con.execute("PRAGMA table_info(fleet_history)")]
    con.close()


def test_history_rows_hold_the_trend_values_as_numbers(history):
    """The node's rows: the trend values as REAL columns (the trend reads them, no text parsed)."""
    from guide_health.analysis import fleet_trend

    trends = fleet_trend.read_trends(history)
    assert trends["m2"].latest("remaining_life_h") == life_h("m2", 39)
    assert trends["m2"].values["life_used_fraction"][-1] == pytest.approx(0.39)


def test_csv_times_of_a_whole_machine_equal_the_per_row_text():
    """iso_array (numpy, the CSV's column) == iso (datetime) to the character, at second and microsecond
    roundings included."""
    from guide_health.analysis.fleet_trend import iso, iso_array

    t = [T0_UNIX_S, T0_UNIX_S + 0.9999996, T0_UNIX_S - 4e-7, T0_UNIX_S + 59.9999994, 0.0, 86399.5, 4.1e9]
    t += list(np.random.default_rng(3).uniform(0.0, 4e9, 2000))
    assert iso_array(t) == [iso(x) for x in t]


def test_a_decimated_line_keeps_the_min_and_max_of_every_time_bin():
    """30 days of a status every 60 s (43 200 rows) with one alarm spike of a single row: the drawn series
    has at most 2 x 800 + 2 points, and per bin the same min and max as the raw rows, the spike among them."""
    rng = np.random.default_rng(3)
    t = T0_UNIX_S + 60.0 * np.arange(43_200)
    v = 500.0 - np.arange(43_200) / 60.0 + rng.normal(0.0, 2.0, t.size)
    v[31_337] = -50.0                                            # the one row in alarm
    td, vd = min_max_per_bin(t, v, t[0], t[-1], bins=800)
    assert td.size <= 1602 and np.all(np.diff(td) > 0)
    assert (td[0], td[-1]) == (t[0], t[-1]) and -50.0 in vd
    raw_bin = np.clip(((t - t[0]) / (t[-1] - t[0]) * 800).astype(int), 0, 799)
    drawn_bin = np.clip(((td - t[0]) / (t[-1] - t[0]) * 800).astype(int), 0, 799)
    for b in range(800):
        assert (vd[drawn_bin == b].min(), vd[drawn_bin == b].max()) == (v[raw_bin == b].min(), v[raw_bin == b].max())
    assert min_max_per_bin(t[:1600], v[:1600], t[0], t[1599], bins=800)[0].size == 1600     # short: whole
    assert min_max_per_bin(t, v, t[0], t[-1], bins=0)[1].size == 43_200                       # bins 0: whole


def test_decimated_figures_leave_the_page_text_and_tables_as_they_were(history, tmp_path, monkeypatch):
    """The page drawn from 2 bins per series (every line decimated) and from whole series: the same text,
    ranking and embedded CSV tables; only the images differ."""
    pages = {}
    for bins in (0, 2):
        monkeypatch.setattr(fleet_trend_plots, "PLOT_BINS", bins)
        assert main(["fleet", "trend", str(history), "--out", str(tmp_path / str(bins))]) == 0
        text = (tmp_path / str(bins) / "index.html").read_text().replace(str(tmp_path / str(bins)), "OUT")
        pages[bins] = re.sub(r"src='data:image/png;base64,[^']*'|src=\"data:image/png;base64,[^\"]*\"", "IMG", text)
    assert pages[0].count("IMG") == 1 + 4 and pages[0].count("<tr") == 1 + 4
    assert pages[2] == pages[0]


def test_trends_read_as_columns_equal_the_row_by_row_reading(tmp_path):
    """The reader groups machines by a stable sort of numpy columns, finds level changes per status by array
    comparison and writes the CSV column-wise: on a history with equal times, every level, NULL, text and
    unreadable values and messages that need quoting, the same trends, changes and CSV bytes as a loop over
    the rows in time order."""
    import random
    import sqlite3

    from guide_health.analysis.fleet_trend import TREND_KEYS, read_trends, write_trend_csv
    from guide_health.io.outputs.fleet_history import HISTORY_SCHEMA, INSERT_ROW, history_row
    from guide_health.models.levels import LEVEL_NAMES

    rng, db, rows = random.Random(5), tmp_path / "h.db", []
    for k in range(300):
        for m in ("m2", "c,1", "m1"):
            for name in ("x precision", 'b1 "roller"'):
                if rng.random() < 0.7:
                    values = {"remaining_life_h": rng.choice(["", "nan", "inf", repr(rng.uniform(-5.0, 900.0))]),
                              "straightness_um": repr(rng.uniform(0.0, 30.0))}
                    rows.append(history_row(T0_UNIX_S + 60.0 * (k // 4), m, name, rng.choice([0, 0, 1, 2, 3]),
                                            rng.choice(["", 'a, "b"', "c\nd"]), values))
    con = sqlite3.connect(db)
    con.executescript(HISTORY_SCHEMA)
    con.executemany(INSERT_ROW, rows)
    con.execute("UPDATE fleet_history SET straightness_um = CASE WHEN rowid % 2 THEN 'abc' ELSE '2.5' END "
                "WHERE rowid % 37 = 0")
    con.commit()
    ordered = con.execute("SELECT * FROM fleet_history ORDER BY t_unix_s").fetchall()
    con.close()
    trends = read_trends(db)
    assert list(trends) == list(dict.fromkeys(r[1] for r in ordered))           # order of the first row
    for m, trend in trends.items():
        mine = [r for r in ordered if r[1] == m]
        assert trend.t_unix_s.tolist() == [r[0] for r in mine] and trend.message == [r[4] for r in mine]
        changes, last = [], {}
        for t, _, name, level, text, *_ in mine:
            if name in last and last[name] != level:
                changes.append({"t_unix_s": t, "status": name, "from": LEVEL_NAMES[last[name]],
                                "to": LEVEL_NAMES[level], "message": text})
            last[name] = level
        assert trend.level_changes() == changes and len(changes) > 50
        assert trend.latest_level() == max(last.values())
        write_trend_csv(tmp_path / "m.csv", trend)
        expected = io.StringIO()
        writer = csv.writer(expected)
        writer.writerow(["t_unix_s", "time_utc", "status", "level", *[k for k, _ in TREND_KEYS], "message"])
        for r in mine:
            numbers = [float(v) if isinstance(v, float) or v == "2.5" else float("nan") for v in r[5:9]]
            writer.writerow([f"{r[0]:.3f}", time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(r[0])), r[2],
                             LEVEL_NAMES[r[3]], *["" if v != v else f"{v:.6g}" for v in numbers], r[4]])
        assert (tmp_path / "m.csv").read_bytes() == expected.getvalue().encode()


def test_a_machine_figure_drawn_again_equals_a_new_one(history, tmp_path):
    """The page draws every machine into one reused figure per panel count (MachineFigures): after other
    machines of the same and of other panel counts and statuses, each PNG equals the machine's figure drawn
    alone, byte for byte."""
    from guide_health.analysis.fleet_trend import read_trends
    from guide_health.analysis.fleet_trend_plots import MachineFigures, plot_machine_trend

    trends, figures = read_trends(history), MachineFigures()
    for i, m in enumerate(["m1", "c1", "m2", "m3", "c1", "m1"]):
        plot_machine_trend(tmp_path / f"reused{i}.png", trends[m], figures)
        plot_machine_trend(tmp_path / f"alone{i}.png", trends[m])
        assert (tmp_path / f"reused{i}.png").read_bytes() == (tmp_path / f"alone{i}.png").read_bytes(), m
    assert sorted(figures._figures) == [2, 3, 4]    # panels: c1 1 key + levels; m1, m3 2 keys; m2 3 keys + levels


# ---- the hourly rows (layout 3) and the trend read by the hour -------------------------------------------------

def blip_history(db, commit_every=7):
    """Three statuses over 30 h at uneven times (a row every 170-1900 s), written by FleetHistory (period 0)
    with a commit every `commit_every` rows: levels that blip inside an hour and change at an hour's first row,
    values that are sometimes not reported (NULL) or no number, an hour with no rows at all."""
    rng = np.random.default_rng(5)
    h = FleetHistory(str(db), 0.0)
    t, n = T0_UNIX_S + 1234.5, 0
    while t < T0_UNIX_S + 30 * 3600.0:
        if not (T0_UNIX_S + 12 * 3600.0 <= t < T0_UNIX_S + 13 * 3600.0):       # hour 12: silent
            for m, name in (("m1", "wear_monitor: x precision"), ("m1", "wear_monitor: y precision"),
                            ("m2", "slewing_monitor: b1 roller contact")):
                level = int(rng.choice([0, 0, 0, 0, 1, 2]))
                values = {"remaining_life_h": repr(float(rng.uniform(10, 900))),
                          "straightness_um": "banana" if rng.random() < 0.1 else repr(float(rng.normal(20, 3)))}
                if rng.random() < 0.3:
                    values.pop("remaining_life_h")
                if name.startswith("slewing"):
                    values = {"end_stress_ratio": repr(float(rng.uniform(0.5, 1.5)))}
                elif rng.random() < 0.5:
                    values.update(limit_date_utc_low="2027-05-01", limit_date_utc="2027-06-01")
                h.record(t, m, name, level, f"level {level} at {t:.0f}", values)
                n += 1
                if n % commit_every == 0:
                    h.commit()
        t += float(rng.uniform(170.0, 1900.0))
    h.close()
    return db


def hourly_by_hand(db):
    """fleet_history_hourly as a loop over the rows in time order: {(hw, name, hour): row dict}."""
    import sqlite3

    con = sqlite3.connect(db)
    keys = ("remaining_life_h", "straightness_um", "life_used_fraction", "end_stress_ratio")
    rows = con.execute(f"SELECT t_unix_s, hardware_id, name, level, message, limit_date_utc_low, {', '.join(keys)} "
                       "FROM fleet_history ORDER BY t_unix_s, rowid").fetchall()
    con.close()
    out = {}
    for t, hw, name, level, message, low, *values in rows:
        b = out.setdefault((hw, name, int(t // 3600)), {
            "rows": 0, "t_first": t, "level_first": level, "level_min": level, "level_max": level, "dates_t_last": None,
            **{f"{k}_{e}": None for k in keys for e in ("min", "max", "last", "t_last")}})
        if low is not None:
            b["dates_t_last"] = t
        b["rows"] += 1
        b.update(t_last=t, level_last=level, message_last=message, level_min=min(b["level_min"], level),
                 level_max=max(b["level_max"], level))
        for k, v in zip(keys, values):
            if v is not None:
                b[f"{k}_min"] = v if b[f"{k}_min"] is None else min(b[f"{k}_min"], v)
                b[f"{k}_max"] = v if b[f"{k}_max"] is None else max(b[f"{k}_max"], v)
                b[f"{k}_last"], b[f"{k}_t_last"] = v, t
    return out


def hourly_table(db):
    import sqlite3

    con = sqlite3.connect(db)
    con.row_factory = sqlite3.Row
    table = {(r["hardware_id"], r["name"], r["hour"]): {k: r[k] for k in r.keys()
                                                        if k not in ("hardware_id", "name", "hour")}
             for r in con.execute("SELECT * FROM fleet_history_hourly")}
    con.close()
    return table


def test_hourly_rows_equal_an_aggregation_written_here_live_and_migrated(tmp_path):
    """The hourly rows kept at each commit equal a loop over the rows; a layout-2 file (hourly rows dropped)
    gets the same ones when fleet_monitor opens it."""
    import sqlite3

    db = blip_history(tmp_path / "h.db")
    expected = hourly_by_hand(db)
    assert hourly_table(db) == expected
    assert sum(b["rows"] for b in expected.values()) > 250 and not any(k[2] == 12 + int(T0_UNIX_S // 3600)
                                                                      for k in expected)
    assert any(b["level_min"] != b["level_max"] for b in expected.values())
    con = sqlite3.connect(db)
    nulls = con.execute("SELECT COUNT(*) FROM fleet_history WHERE name LIKE '%precision' AND (straightness_um IS NULL "
                        "OR remaining_life_h IS NULL)").fetchone()[0]
    assert nulls > 20                                       # the NULL paths of min, max and last are taken
    con.executescript("DROP TABLE fleet_history_hourly; PRAGMA user_version = 2;")
    con.close()
    FleetHistory(str(db), 60.0).close()                     # fleet_monitor's start migrates 2 -> 3
    assert hourly_table(db) == expected


def test_prune_deletes_whole_hours_of_the_hourly_rows(tmp_path):
    db = blip_history(tmp_path / "h.db")
    h = FleetHistory(str(db), 60.0, retention_days=1.0)
    now = T0_UNIX_S + 30 * 3600.0
    h.prune(now)
    h.close()
    hours = sorted({k[2] for k in hourly_table(db)})
    assert hours[0] == int((now - 86400.0) // 3600)          # the hour the cutoff falls in stays, whole
    assert all(b["t_last"] >= now - 86400.0 for b in hourly_table(db).values())


def test_rows_after_a_prune_of_every_row_are_rolled_up(tmp_path):
    """Retention deletes every row (the fleet silent longer than it): SQLite numbers the next rows from 1
    again, and they still reach the hourly rows."""
    db = blip_history(tmp_path / "h.db")
    h = FleetHistory(str(db), 0.0, retention_days=1.0)
    later = T0_UNIX_S + 40 * 86400.0
    assert h.prune(later) > 250 and hourly_table(db) == {}
    for k in range(5):
        h.record(later + 600.0 * k, "m7", "wear_monitor: x precision", k % 2, "", {"remaining_life_h": str(50 - k)})
        h.commit()
    h.close()
    assert hourly_table(db) == hourly_by_hand(db) and sum(b["rows"] for b in hourly_table(db).values()) == 5


def test_rows_and_hourly_rows_are_written_together_or_not_at_all(tmp_path, monkeypatch):
    """A commit whose roll-up fails (here a broken statement) leaves neither the rows nor their hourly rows,
    keeps the rows pending, and the next commit writes both."""
    import guide_health.io.outputs.fleet_history as fleet_history

    db = tmp_path / "h.db"
    h = FleetHistory(str(db), 0.0)
    h.record(T0_UNIX_S, "m1", "wear_monitor: x precision", 0, "", {"remaining_life_h": "9"})
    good = fleet_history.ROLL_UP
    broken = good.replace("INSERT INTO fleet_history_hourly", "INSERT INTO nowhere")
    monkeypatch.setattr(fleet_history, "ROLL_UP", broken)
    with pytest.raises(Exception, match="nowhere"):
        h.commit()
    assert h.db.execute("SELECT COUNT(*) FROM fleet_history").fetchone()[0] == 0 and hourly_table(db) == {}
    monkeypatch.setattr(fleet_history, "ROLL_UP", good)
    h.commit()
    h.close()
    assert hourly_table(db) == hourly_by_hand(db) and len(hourly_table(db)) == 1


def test_trend_read_by_the_hour_has_the_rows_ranking_and_every_level_change(tmp_path):
    """The same history read by every row and by the hour: the same machines, row counts, latest values and
    levels (the ranking), the same level changes, one by one (a blip inside an hour, a change at an hour's
    first row); each hour's drawn points hold the least and largest value of its rows."""
    from guide_health.analysis.fleet_trend import read_trends, write_trend_csv

    db = blip_history(tmp_path / "h.db")
    by_row, by_hour = read_trends(db, resolution="rows"), read_trends(db, resolution="hourly")
    assert list(by_row) == list(by_hour) == ["m1", "m2"]
    for m in by_row:
        r, h = by_row[m], by_hour[m]
        assert h.hourly is not None and r.hourly is None
        assert h.row_count() == r.row_count() and h.first_t() == r.t_unix_s[0]
        assert h.latest_level() == r.latest_level() and h.t_unix_s[-1] == r.t_unix_s[-1]
        for key in ("remaining_life_h", "straightness_um", "end_stress_ratio"):
            assert h.latest(key) == r.latest(key) or (np.isnan(h.latest(key)) and np.isnan(r.latest(key)))
        assert h.level_changes() == r.level_changes() and len(r.level_changes()) > 20
        t, v, status = h.points("remaining_life_h")
        rt, rv, rstatus = r.points("remaining_life_h")
        for name in set(r.status):
            for hour in set((rt[rstatus == name] // 3600).astype(int).tolist()):
                sel = (rstatus == name) & (rt // 3600 == hour) & np.isfinite(rv)
                mine = (status == name) & (t // 3600 == hour) & np.isfinite(v)
                if sel.any():
                    assert (v[mine].min(), v[mine].max()) == (rv[sel].min(), rv[sel].max())
    write_trend_csv(tmp_path / "m1.csv", by_hour["m1"])
    with open(tmp_path / "m1.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert sum(int(r["rows"]) for r in rows) == by_row["m1"].row_count()
    assert rows[0]["hour_utc"].endswith(":00:00") and {r["level_worst"] for r in rows} >= {"ERROR"}


def test_trend_resolution_auto_and_its_bad_uses(tmp_path, monkeypatch, capsys):
    """auto reads by the hour above RAW_ROWS_MAX rows in the window; --resolution hourly of a layout-2 file and
    an unknown resolution are one line each."""
    import sqlite3

    from guide_health.analysis import fleet_trend

    db = blip_history(tmp_path / "h.db")
    assert main(["fleet", "trend", str(db), "--out", str(tmp_path / "a"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["resolution"] == "rows"
    monkeypatch.setattr(fleet_trend, "RAW_ROWS_MAX", 100)
    assert main(["fleet", "trend", str(db), "--out", str(tmp_path / "b"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["resolution"] == "hourly" and result["rows"] == fleet_trend.read_trends(db, resolution="rows")[
        "m1"].row_count() + fleet_trend.read_trends(db, resolution="rows")["m2"].row_count()
    check_page(Path(result["files"]["html"]))
    assert "read by the hour" in Path(result["files"]["html"]).read_text()
    con = sqlite3.connect(db)
    con.executescript("DROP TABLE fleet_history_hourly; PRAGMA user_version = 2;")
    con.close()
    assert main(["fleet", "trend", str(db), "--resolution", "hourly", "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip()
    assert "layout 2 has no hourly rows" in err and "\n" not in err
    assert main(["fleet", "trend", str(db), "--out", str(tmp_path / "d"), "--json"]) == 0   # auto: every row
    assert json.loads(capsys.readouterr().out)["resolution"] == "rows"
