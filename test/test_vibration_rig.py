"""Seed 004's failure signs on signals written here (not sim/life_test.py): impacts of a spall ringing a structural
resonance in broadband noise, a flat sound level that drops when the carriage loosens, a bench stop, a 3-channel
accelerometer. Truth: the impact rate, the onset and loosening travels and the stop written in each test; the
kinematic frequencies from the closed forms f_race = (v/2)/p, f_ball = v / (pi D cos alpha)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from guide_health.analysis.life_signs import feed_life_test
from guide_health.io.accel_channels import decode_channels, encode_channels
from guide_health.models.rolling import envelope as env
from guide_health.models.rolling.travel import TravelClock
from guide_health.params import SCHEMAS
from guide_health.params.typed import vibration_monitor_params

FS, N = 25600.0, 4096
D_M, ANGLE = 6.35e-3, math.pi / 4


def pitch_for(ratio: float) -> float:
    """The ball pitch p with f_ball / f_race = 2 p / (pi D cos alpha) = ratio."""
    return ratio * math.pi * D_M * math.cos(ANGLE) / 2.0


def candidates(pitch_m: float, speed: float = 1.0) -> dict:
    return {"raceway": 0.5 * speed / pitch_m, "ball_defect": speed / (math.pi * D_M * math.cos(ANGLE))}


def impacts(rate_hz: float, duration_s: float, rng, amp=3.0, f_res=4200.0, noise=1.0, t0_s=0.0) -> np.ndarray:
    """Noise + an impact every 1 / rate (jitter 1 % of the period) ringing at f_res (decay 0.5 ms)."""
    n = int(round(duration_s * FS))
    x = noise * rng.standard_normal(n)
    first = (-t0_s) % (1.0 / rate_hz)
    hits = np.arange(first, duration_s, 1.0 / rate_hz)
    hits = hits + 0.01 / rate_hz * rng.standard_normal(hits.size)
    k = np.arange(400)
    ring = amp * np.exp(-k / FS / 5e-4) * np.sin(2 * np.pi * f_res * k / FS)
    for h in hits:
        i = int(h * FS)
        if 0 <= i < n:
            m = min(ring.size, n - i)
            x[i:i + m] += ring[:m]
    return x


def test_ball_defect_named_when_the_candidates_differ_by_5_percent():
    """Rates 5 % apart, 2 s of signal (resolution 0.5 Hz = 0.7 %): the ball defect named, measured within 1 %
    (the raceway 5 % away matches nothing: slip tolerance 2 %)."""
    f = candidates(pitch_for(1.05))
    assert f["ball_defect"] / f["raceway"] == pytest.approx(1.05)
    for name in ("ball_defect", "raceway"):
        m = env.measure_defect(impacts(f[name], 2.0, np.random.default_rng(7)), FS, f, 2.0)
        assert m.named == name and m.spectrum == "envelope"
        assert m.frequency_hz == pytest.approx(f[name], rel=0.01)
        assert abs(m.frequency_hz - f[name]) <= 3 * m.uncertainty_hz + 0.002 * f[name]    # bound is honest
        assert m.resolution_hz == pytest.approx(0.5) and len(m.harmonics) >= 3
        assert m.candidates[name]["matches"] and not m.candidates[{"raceway": "ball_defect"}.get(name, "raceway")][
            "matches"]


def test_not_separable_when_the_candidates_differ_by_half_a_percent_in_1_s():
    f = candidates(pitch_for(1.005))
    gap = f["ball_defect"] - f["raceway"]                  # 0.35 Hz < 1 / (1 s)
    m = env.measure_defect(impacts(f["ball_defect"], 1.0, np.random.default_rng(3)), FS, f, 2.0)
    assert m.frequency_hz == pytest.approx(f["ball_defect"], rel=0.01)
    assert m.named == (f"ball_defect or raceway (not separable at this resolution: {1.0 / gap:.2g} s of signal "
                       "would separate them)")
    # the same impacts over the 3 s the text asks for: named
    assert env.measure_defect(impacts(f["ball_defect"], 3.0, np.random.default_rng(3)), FS, f, 2.0).named == \
        "ball_defect"


def test_noise_names_nothing():
    f = candidates(pitch_for(1.05))
    rng = np.random.default_rng(11)
    named = [env.measure_defect(rng.standard_normal(N), FS, f).named for _ in range(100)]
    assert named.count(None) >= 98


# --- a life test written here ---------------------------------------------------------------------------------
ONSET_KM, LOOSE_KM, BLOCK_KM, LEVEL_KM, END_KM = 100.0, 110.0, 2.0, 0.5, 130.0


def rig_params(**over):
    return vibration_monitor_params(SCHEMAS["vibration_monitor"].defaults() | {"ball_pitch_m": pitch_for(1.05)}
                                    | over)


def life_test(seed=0, stop_after_km=None, stop_s=12 * 3600.0, loosen_km=LOOSE_KM):
    """Blocks every 2 km and levels every 0.5 km at 1 m/s; impacts at the raceway rate from ONSET_KM; a flat level
    of 70 dB (sd 0.3 dB) dropping 6 dB at loosen_km; an optional bench stop after stop_after_km."""
    rng = np.random.default_rng(seed)
    f = candidates(pitch_for(1.05))
    travel = np.arange(0.0, END_KM + 1e-9, BLOCK_KM) * 1e3
    blocks = [impacts(f["raceway"], N / FS, rng, amp=3.0 if s >= ONSET_KM * 1e3 else 0.0, t0_s=s)
              for s in travel]
    level_s = np.arange(0.0, END_KM + 1e-9, LEVEL_KM) * 1e3
    level_db = 70.0 + 0.3 * rng.standard_normal(level_s.size) - 6.0 * (level_s >= loosen_km * 1e3)

    def stamp(s):
        stopped = stop_s * (np.asarray(s) > stop_after_km * 1e3) if stop_after_km is not None else 0.0
        return ((1.7e9 + np.asarray(s) / 1.0 + stopped) * 1e9).astype(np.int64)
    return travel, stamp(travel), blocks, stamp(level_s), level_db, stamp


def test_loosening_without_a_prior_rise_is_an_error():
    """Loosening 10 km after onset, the level flat before it: the drop found within 5 km, level ERROR; the same
    run without the drop stays WARN (spall signature only)."""
    _travel, t, blocks, lt, ldb, _ = life_test()
    feed = feed_life_test(rig_params(), t, blocks, lt, ldb)
    signs = feed.signs
    assert signs.failure_travel_m / 1e3 == pytest.approx(ONSET_KM, abs=BLOCK_KM)
    assert signs.noise.rise_travel_m is None                                    # no prior rise
    drop_km, size_db = signs.loosening()
    assert LOOSE_KM <= drop_km / 1e3 <= LOOSE_KM + 5.0 and size_db == pytest.approx(6.0, abs=0.6)
    assert signs.level()[0].name == "ERROR"
    assert signs.noise.shift.sd_db == pytest.approx(0.3, rel=0.35)             # the level's own noise
    no_drop = feed_life_test(rig_params(), t, blocks, lt, ldb + 6.0 * (ldb < 67.0))
    assert no_drop.signs.loosening() is None and no_drop.signs.level()[0].name == "WARN"


def positions_of(travel_m: np.ndarray, stamp, stroke_m: float = 100.0):
    """A reciprocating axis (stroke 100 m at 1 m/s, turns every 100 s) sampled every 50 s (on every turn), and
    standing during a stop: sum |dx| = travel."""
    s = np.arange(0.0, travel_m[-1] + 1e-9, 50.0)
    x = stroke_m - np.abs((s % (2 * stroke_m)) - stroke_m)
    return stamp(s), x


def test_a_12_h_stop_leaves_the_failure_travel_unchanged():
    """A 12 h stop at 60 km: with the position topic the failure travel equals the run without the stop; without
    it the stop is found (no input for > pause_gap_s) and the failure travel is unchanged too; with the stop
    ignored (pause_gap_s above 12 h) the failure travel moves by 43.2 km."""
    travel, t, blocks, lt, ldb, stamp = life_test()
    want = feed_life_test(rig_params(), t, blocks, lt, ldb).signs.failure_travel_m
    travel, t2, blocks, lt2, ldb, stamp2 = life_test(stop_after_km=60.0)
    pt, px = positions_of(travel, stamp2)
    with_pos = feed_life_test(rig_params(), t2, blocks, lt2, ldb, position_t_ns=pt, position_m=px)
    assert with_pos.signs.failure_travel_m == pytest.approx(want, abs=1e-6)
    assert with_pos.clock.source().startswith("position")
    without = feed_life_test(rig_params(), t2, blocks, lt2, ldb)
    assert without.clock.pauses == 1 and without.signs.failure_travel_m == pytest.approx(want, abs=1e-6)
    assert "1 stops, 12.00 h" in without.clock.source()
    ignored = feed_life_test(rig_params(pause_gap_s=50_000.0), t2, blocks, lt2, ldb)
    assert ignored.signs.failure_travel_m - want == pytest.approx(43_200.0, abs=1.0)


def test_travel_clock_offset_and_start_stamp():
    clock = TravelClock(0.5, pause_gap_s=100.0, offset_m=2000.0, start_ns=10 * 10**9)
    assert clock.travel_m(30 * 10**9) == pytest.approx(2010.0)                  # 20 s at 0.5 m/s after the start
    assert clock.travel_m(40 * 10**9) == pytest.approx(2015.0)
    assert clock.travel_m(1000 * 10**9) == pytest.approx(2022.5)     # a 960 s stop adds the median spacing 15 s
    assert clock.travel_m(5 * 10**9) < 2000.0                                    # before the start: refused upstream


def test_three_channel_accelerometer_names_the_defect_channel():
    """ax, ay noise only, az the spall: the PointCloud2 form decodes to the three channels at 25.6 kHz and the
    status is az's, equal to the single-channel run of az."""
    _travel, t, blocks, lt, ldb, _ = life_test()
    rng = np.random.default_rng(5)
    chans, names, rates, stamps = [], [], [], []
    for i, b in enumerate(blocks):
        fields, step, data = encode_channels(FS, {"ax": rng.standard_normal(N), "ay": rng.standard_normal(N),
                                                  "az": b})
        fs, decoded = decode_channels(fields, N, 1, step, False, data)
        assert fs == pytest.approx(FS, rel=1e-6)
        for name, x in decoded.items():
            chans.append(x)
            names.append(name)
            rates.append(fs)
            stamps.append(t[i])
    multi = feed_life_test(rig_params(), np.array(stamps), chans, lt, ldb, channels=names, block_rates=rates)
    az = np.asarray(blocks, dtype=np.float32).astype(float)
    single = feed_life_test(rig_params(), t, list(az), lt, ldb)
    assert multi.worst_channel == "az" and set(multi.channels) == {"ax", "ay", "az"}
    s_multi, s_single = multi.signs.summary(), single.signs.summary()
    for key in ("failure_travel_km", "defect", "defect_measured_hz", "level", "noise_drop_km", "z_max"):
        assert s_multi[key] == s_single[key], key
    assert multi.channels["ax"].failure_travel_m is None and multi.channels["ay"].failure_travel_m is None
    wrong_rate = feed_life_test(rig_params(), t[:3], blocks[:3], lt[:0], ldb[:0], block_rates=[FS, 20000.0, FS])
    assert wrong_rate.rejected_blocks == 1 and wrong_rate.signs.blocks == 2


def test_malformed_channel_blocks_are_refused():
    fields, step, data = encode_channels(FS, {"az": np.zeros(8)})
    with pytest.raises(ValueError):
        decode_channels(fields, 8, 1, step, False, data[:-4])                  # short buffer
    with pytest.raises(ValueError):
        decode_channels(fields[1:], 8, 1, step, False, data)                    # no time field
    bad_t = np.frombuffer(data, "<f4").copy().reshape(8, 2)
    bad_t[3, 0] += 1e-3
    with pytest.raises(ValueError):
        decode_channels(fields, 8, 1, step, False, bad_t.tobytes())            # non-uniform sample times
