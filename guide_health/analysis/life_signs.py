"""Seed 004's failure signs offline: blocks and sound levels (from a bag or a simulation) through the same
:class:`~guide_health.models.rolling.life_signs.LifeTestSigns` the live ``vibration_monitor`` node uses, then the
failure travel into C_test / C (seed 004 Eq. 5) and several specimens into the interval-censored Weibull fit.
``p`` throughout: the vibration_monitor parameters (VibrationMonitorParams, guide_health.params.typed)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from guide_health.errors import InputError
from guide_health.io.bag.metadata import check_bag_file_paths
from guide_health.io.bag.typestore import typestore
from guide_health.io.bag.writer import SOUND_LEVEL_REFERENCE_PA
from guide_health.models.rolling import rating_life as lm
from guide_health.models.rolling import weibull
from guide_health.models.rolling.life_signs import LifeTestSigns, NoiseTrend, StampedLifeTest
from guide_health.models.rolling.vibration import AbnormalBand, GuideKinematics


def signs_from_params(p: Any) -> LifeTestSigns:
    """A fresh LifeTestSigns from the ``vibration_monitor`` parameters (VibrationMonitorParams; the live node
    calls this too)."""
    kin = GuideKinematics(p.ball_diameter_m, p.ball_pitch_m, p.loop_length_m,
                          math.radians(p.contact_angle_deg))
    bands = AbnormalBand(p.sample_rate_hz, n_bands=p.n_bands, baseline_blocks=p.baseline_blocks,
                         alpha_block=p.false_alarm_per_block, persist_k=p.persist_k,
                         persist_n=p.persist_n, segment=p.welch_segment)
    noise = NoiseTrend(baseline_samples=p.noise_baseline_samples, rise_allowance_db=p.noise_rise_allowance_db,
                       rise_cusum_db=p.noise_rise_cusum_db, drop_db=p.noise_drop_db)
    return LifeTestSigns(p.sample_rate_hz, kin, p.carriage_speed_m_s, bands, noise)


def detect_life_signs(p: Any, block_t_ns: np.ndarray, blocks, level_t_ns: np.ndarray, level_db: np.ndarray,
                      start_ns: int | None = None, stop_at_end_of_test: bool = False) -> LifeTestSigns:
    """Feed blocks and sound levels in stamp order (levels first at equal stamps); travel = speed x (t - start),
    start = the first stamp (the bag starts with the test)."""
    signs = signs_from_params(p)
    if start_ns is None:
        firsts = [int(a[0]) for a in (block_t_ns, level_t_ns) if len(a)]
        start_ns = min(firsts) if firsts else 0
    feed = StampedLifeTest(signs, p.carriage_speed_m_s, start_ns)
    events = sorted([(int(t), 0, i) for i, t in enumerate(level_t_ns)] +
                    [(int(t), 1, i) for i, t in enumerate(block_t_ns)])
    for t, kind, i in events:
        if kind == 0:
            signs.update_level(feed.travel_m(t), float(level_db[i]))
        else:
            signs.update_block(feed.travel_m(t), blocks[i])
        if stop_at_end_of_test and signs.level()[0].name == "ERROR":
            break
    return signs


def vibration_status_values(feed: StampedLifeTest) -> dict:
    """The `<joint> vibration` status values of a StampedLifeTest (live node and offline alike)."""
    signs = feed.signs
    s = signs.summary()
    last = feed.last_block
    energies = last.get("energies")
    band = s["abnormal_band_hz"]
    defect_hz = signs.defects_hz.get(f"{signs.defect}_hz", math.nan) if signs.defect else math.nan
    return {
        "blocks": signs.blocks, "rejected_blocks": feed.rejected_blocks, "rejected_levels": feed.rejected_levels,
        "travel_km": s["last_travel_km"], "z_max": s["z_max"], "z_threshold": s["z_threshold"],
        "abnormal_band_hz": f"{band[0]:.0f}-{band[1]:.0f}" if band and last.get("abnormal") else "",
        "defect": signs.defect or "", "defect_frequency_hz": defect_hz,
        "noise_level_db": s["noise_level_db"], "noise_rise_db": s["noise_rise_db"],
        "noise_rise_km": s["noise_rise_km"], "noise_drop_km": s["noise_drop_km"],
        "failure_travel_km": s["failure_travel_km"],
        "band_energies_m2_s4": "" if energies is None else " ".join(f"{e:.4g}" for e in energies),
        "raceway_hz": signs.defects_hz["raceway_hz"], "ball_defect_hz": signs.defects_hz["ball_defect_hz"],
        "recirculation_hz": signs.defects_hz["recirculation_hz"],
    }



def c_ratio_of(signs: LifeTestSigns, p: Any) -> float | None:
    """C_test / C of the detected failure travel (seed 004 Eq. 5, ball exponent); None without a failure."""
    if signs.failure_travel_m is None:
        return None
    return lm.c_ratio_from_life(p.load_fraction, signs.failure_travel_m / 1e3, p.rating_distance_km)


def weibull_of_specimens(intervals_km: list[tuple[float, float]], p: Any, confidence: float = 0.90) -> dict:
    """Interval-censored Weibull fit of several specimens' (lower, upper] failure travels [km] (upper inf: the
    specimen survived to lower), B10 and C_test / C of B10 (seed 004 Sec. 3.2, Eq. 5)."""
    lo = np.array([a for a, _ in intervals_km], dtype=float)
    up = np.array([b for _, b in intervals_km], dtype=float)
    fit = weibull.fit_weibull(lo, up, np.ones(lo.size), confidence=confidence)
    return {"n": fit.n, "failures": fit.failures, "shape": fit.shape, "scale_km": fit.scale_km,
            "b10_km": fit.b_life_km, "b10_ci_km": list(fit.b_life_ci_km),
            "c_ratio": lm.c_ratio_from_life(p.load_fraction, fit.b_life_km, p.rating_distance_km),
            "c_ratio_ci": [lm.c_ratio_from_life(p.load_fraction, b, p.rating_distance_km)
                           for b in fit.b_life_ci_km]}


def read_life_test_bag(path) -> dict:
    """Blocks and sound levels of a life-test bag (``guide/acceleration`` sensor_msgs/LaserScan,
    ``guide/sound_pressure`` sensor_msgs/FluidPressure); InputError on a missing bag or topic."""
    from rosbags.rosbag2 import Reader


    store = typestore()
    out = {"block_t_ns": [], "blocks": [], "level_t_ns": [], "level_db": [], "sample_rate_hz": None}
    check_bag_file_paths(Path(path))        # no storage file outside the bag folder
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - any unreadable bag is one line
        raise InputError(f"cannot open life-test bag {path}: {str(exc).splitlines()[0] if str(exc) else exc}") from None
    try:
        for conn, _t, raw in reader.messages():
            if conn.topic.endswith("guide/acceleration") and conn.msgtype == "sensor_msgs/msg/LaserScan":
                m = store.deserialize_cdr(raw, conn.msgtype)
                out["block_t_ns"].append(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)
                out["blocks"].append(np.asarray(m.ranges, dtype=float))
                out["sample_rate_hz"] = 1.0 / m.time_increment if m.time_increment > 0 else None
            elif conn.topic.endswith("guide/sound_pressure") and conn.msgtype == "sensor_msgs/msg/FluidPressure":
                m = store.deserialize_cdr(raw, conn.msgtype)
                if m.fluid_pressure > 0:
                    out["level_t_ns"].append(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)
                    out["level_db"].append(20.0 * math.log10(m.fluid_pressure / SOUND_LEVEL_REFERENCE_PA))
    finally:
        reader.close()
    if not out["blocks"]:
        raise InputError(f"{path}: no guide/acceleration (sensor_msgs/msg/LaserScan) blocks")
    return out


def life_test_from_bag(path, p: Any) -> dict:
    """The seed's chain from a bag: failure travel from the recorded signs -> C_test / C (seed 004 Eq. 5)."""
    return life_test_from_data(path, read_life_test_bag(path), p)


def life_test_from_data(path, d: dict, p: Any) -> dict:
    """:func:`life_test_from_bag` on data already read by :func:`read_life_test_bag` (``path`` names it)."""
    if d["sample_rate_hz"] and abs(d["sample_rate_hz"] - p.sample_rate_hz) > 1e-6 * p.sample_rate_hz:
        raise InputError(f"{path}: blocks at {d['sample_rate_hz']:g} Hz, sample_rate_hz is {p.sample_rate_hz:g}")
    try:
        signs = detect_life_signs(p, np.array(d["block_t_ns"]), d["blocks"], np.array(d["level_t_ns"]),
                                  np.array(d["level_db"]))
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from None
    return signs.summary() | {"c_ratio": c_ratio_of(signs, p), "load_fraction": p.load_fraction}


def specimen_interval_km(summary: dict) -> tuple[float, float]:
    """A specimen's interval-censored life [km]: (previous block, failure block] when it failed, (last travel,
    inf) when it survived the recorded test (seed 004 Sec. 3.2)."""
    if summary.get("failure_interval_km"):
        lower, upper = summary["failure_interval_km"]
        return float(lower), float(upper)
    return float(summary["last_travel_km"]), math.inf
