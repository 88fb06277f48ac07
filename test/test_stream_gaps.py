"""Samples missing by stamp gaps (guide_health/models/wear/stream_gaps.py): closed-form counts, the live
per-sample path equal to the offline array path, and properties over arbitrary stamps."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from guide_health.models.wear.stream_gaps import StampGaps, StreamGaps

MS = 1_000_000
T0 = 1_700_000_000_000_000_000


def count(t_ns, **kwargs) -> StampGaps:
    g = StampGaps(**kwargs)
    for t in np.asarray(t_ns).tolist():
        g.add(t)
    return g


def removed(n: int, holes: list[tuple[int, int]], period_ns: int = MS) -> np.ndarray:
    """Stamps of a stream of ``n`` samples at ``period_ns`` with ``holes`` (start index, length) removed."""
    keep = np.ones(n, dtype=bool)
    for start, length in holes:
        keep[start:start + length] = False
    return T0 + np.arange(n, dtype=np.int64)[keep] * period_ns


HOLES = [(7, 1), (40, 3), (500, 10), (2000, 20), (4990, 3)]      # 37 samples in 5 places, one in the warm-up


def test_1khz_stream_with_37_samples_removed_in_5_places_counts_37():
    g = count(removed(5000, HOLES))
    assert sum(n for _, n in HOLES) == 37
    assert (g.missing, g.gaps, g.pauses) == (37, 5, 0)
    assert g.period_ns == MS


def test_offline_array_path_equals_live_per_sample_path():
    t = removed(5000, HOLES)
    offline = StampGaps()
    for chunk in np.array_split(t, [1, 17, 31, 700, 2500]):     # chunks across block boundaries
        offline.add_many(chunk)
    live = count(t)
    state = (offline.missing, offline.gaps, offline.judged_missing, offline.period_ns, offline.last_t_ns)
    assert state == (live.missing, live.gaps, live.judged_missing, live.period_ns, live.last_t_ns)
    assert state == (37, 5, 34, MS, int(t[-1]))       # the last hole's 3 are provisional (not judged yet)


def test_stamp_jitter_of_30_percent_of_the_period_counts_nothing():
    rng = np.random.default_rng(7)
    t = T0 + np.arange(20000, dtype=np.int64) * MS + rng.integers(-300_000, 300_001, 20000)
    # dt ranges over 0.4..1.6 periods; the counter only needs increasing stamps
    assert np.all(np.diff(t) > 0) and np.diff(t).max() > 1.5 * MS
    assert count(t).missing == 0


def test_ten_second_pause_is_not_loss():
    t = np.concatenate((T0 + np.arange(3000) * MS, T0 + 10_000 * MS + 2999 * MS + np.arange(3000) * MS))
    g = count(t)
    assert (g.missing, g.pauses) == (0, 1)


def test_slow_stream_gaps_count_until_50_periods():
    # 1 Hz load stream: 2 samples missing (a 3 s gap, longer than max_pause_s) count, a 60 s stop is a pause
    t = removed(300, [(100, 2)], 1000 * MS)
    t = np.concatenate((t, t[-1] + 60_000 * MS + np.arange(100) * 1000 * MS))
    g = count(t)
    assert (g.missing, g.gaps, g.pauses) == (2, 1, 1)


def test_a_long_stall_of_a_fast_stream_is_loss_not_a_pause():
    # 10 kHz stream whose reader lost 0.5 s (5000 samples, 5000 periods but < max_pause_s) in one gap
    g = count(removed(20000, [(8000, 5000)], 100_000))
    assert (g.missing, g.gaps, g.pauses) == (5000, 1, 0)


def test_rate_change_learns_the_new_period():
    # 1 kHz for 3000 samples, then 500 Hz (period 2 ms) with 10 samples removed in 2 places, the change in
    # the middle of a block: the slower samples of the new rate are not loss
    fast = T0 + np.arange(3000, dtype=np.int64) * MS
    slow = fast[-1] + 2 * MS + removed(3000, [(1000, 4), (2000, 6)], 2 * MS) - T0
    g = count(np.concatenate((fast, slow)))
    assert (g.missing, g.gaps, g.period_ns) == (10, 2, 2 * MS)


def test_first_sample_backward_and_duplicate_stamps_are_ignored():
    t = removed(200, [(100, 2)]).tolist()
    t = t[:50] + [t[49], t[10]] + t[50:]          # a duplicate and a backward stamp
    g = count(t)
    assert g.missing == 2 and g.last_t_ns == t[-1]


def test_nothing_is_counted_during_warm_up_without_a_period():
    g = count(removed(20, [(5, 3)]))          # 16 differences < one block: no period estimate yet
    assert (g.missing, g.period_ns) == (0, 0)


def test_stream_gaps_status_values_and_message():
    gaps = StreamGaps()
    for t in removed(5000, HOLES).tolist():
        gaps.joint.add(t)
    for t in removed(500, [(200, 2)], 10 * MS).tolist():
        gaps.load.add(t)
    assert gaps.values() == {"samples_missing_estimate": 39, "joint_samples_missing_estimate": 37,
                             "load_samples_missing_estimate": 2, "joint_period_estimate_us": 1000.0,
                             "joint_stamp_pauses": 0}
    assert gaps.message() == "39 samples missing (stamp gaps: joint_states 37, load 2)"
    assert StreamGaps().message() == ""


@pytest.mark.parametrize("kwargs", [{"block": 4}, {"block": 1}, {"gap_factor": 1.2}, {"pause_periods": 1.5}])
def test_bad_settings_refused(kwargs):
    with pytest.raises(ValueError):
        StampGaps(**kwargs)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(min_value=-2**40, max_value=2**40), max_size=300),
       st.lists(st.integers(min_value=0, max_value=299), max_size=6))
def test_arbitrary_stamps_never_raise_and_stay_bounded(stamps, cuts):
    live = count(stamps)
    offline = StampGaps()
    for chunk in np.array_split(np.asarray(stamps, dtype=np.int64), sorted(cuts)):
        offline.add_many(chunk)
    assert (live.missing, live.gaps, live.pauses, live.last_t_ns) == \
           (offline.missing, offline.gaps, offline.pauses, offline.last_t_ns)
    assert live.missing >= 0
    t = np.maximum.accumulate(np.asarray(stamps, dtype=np.int64)) if stamps else np.zeros(0, np.int64)
    dt = np.diff(t)
    dt = dt[dt > 0]
    if dt.size:       # every period estimate is one of the differences, so >= the smallest
        assert live.missing <= (int(t[-1]) - int(t[0])) / dt.min()
    else:
        assert live.missing == 0


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(min_value=0, max_value=2000), min_size=1, max_size=40),
       st.integers(min_value=100, max_value=3000), st.integers(min_value=0, max_value=2**31),
       st.lists(st.integers(min_value=0, max_value=3000), max_size=5))
def test_fixed_rate_stream_with_holes_live_equals_offline_and_counts_the_holes(holes, n, seed, cuts):
    # a 1 kHz stream with holes of 1..4 samples at arbitrary places: the count is exact
    rng = np.random.default_rng(seed)
    steps = np.ones(n, dtype=np.int64)
    where = []
    for h in sorted({h for h in holes if 1 <= h < n}):      # >= 3 apart: under half of any block are gaps
        if not where or h - where[-1] >= 3:
            where.append(h)
    steps[where] += rng.integers(1, 5, len(where))
    t = T0 + np.cumsum(steps) * MS
    dense = sum(int(steps[i]) - 1 for i in where)
    live = count(t)
    offline = StampGaps()
    for chunk in np.array_split(t, sorted(cuts)):
        offline.add_many(chunk)
    assert live.counts().tolist() == offline.counts().tolist()
    assert (live.period_ns, live.judged_missing) == (offline.period_ns, offline.judged_missing)
    assert live.missing == dense
