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
from guide_health.io.accel_channels import decode_channels
from guide_health.io.bag.metadata import check_bag_file_paths
from guide_health.io.bag.typestore import typestore
from guide_health.io.bag.writer import SOUND_LEVEL_REFERENCE_PA
from guide_health.models.rolling import rating_life as lm
from guide_health.models.rolling import weibull
from guide_health.models.rolling.life_signs import LevelShift, LifeTestSigns, NoiseTrend, StampedLifeTest
from guide_health.models.rolling.travel import TravelClock
from guide_health.models.rolling.vibration import AbnormalBand, GuideKinematics


def signs_from_params(p: Any) -> LifeTestSigns:
    """A fresh LifeTestSigns from the ``vibration_monitor`` parameters (VibrationMonitorParams; the live node
    calls this too)."""
    kin = GuideKinematics(p.ball_diameter_m, p.ball_pitch_m, p.loop_length_m,
                          math.radians(p.contact_angle_deg))
    bands = AbnormalBand(p.sample_rate_hz, n_bands=p.n_bands, baseline_blocks=p.baseline_blocks,
                         alpha_block=p.false_alarm_per_block, persist_k=p.persist_k,
                         persist_n=p.persist_n, segment=p.welch_segment)
    shift = LevelShift(learn_samples=p.noise_baseline_samples, allowance_sd=p.noise_change_allowance_sd,
                       decision_sd=p.noise_change_decision_sd, min_drop_db=p.noise_drop_db)
    noise = NoiseTrend(baseline_samples=p.noise_baseline_samples, rise_allowance_db=p.noise_rise_allowance_db,
                       rise_cusum_db=p.noise_rise_cusum_db, shift=shift)
    return LifeTestSigns(p.sample_rate_hz, kin, p.carriage_speed_m_s, bands, noise, p.envelope_max_s)


def clock_from_params(p: Any, travel_offset_km: float | None = None, start_ns: int | None = None) -> TravelClock:
    """The travel clock of the ``vibration_monitor`` parameters (the arguments, when given, over
    travel_offset_km and test_start_time_s; start 0 = the first stamp)."""
    offset_km = p.travel_offset_km if travel_offset_km is None else travel_offset_km
    if start_ns is None and p.test_start_time_s > 0:
        start_ns = int(round(p.test_start_time_s * 1e9))
    return TravelClock(p.carriage_speed_m_s, p.pause_gap_s, offset_km * 1e3, start_ns, p.joint_name)


def feed_from_params(p: Any, travel_offset_km: float | None = None, start_ns: int | None = None) -> StampedLifeTest:
    """The StampedLifeTest of the ``vibration_monitor`` parameters (live node and offline chain)."""
    return StampedLifeTest(signs_from_params(p), p.carriage_speed_m_s,
                           clock=clock_from_params(p, travel_offset_km, start_ns))


def detect_life_signs(p: Any, block_t_ns: np.ndarray, blocks, level_t_ns: np.ndarray, level_db: np.ndarray,
                      start_ns: int | None = None, stop_at_end_of_test: bool = False, *,
                      position_t_ns=(), position_m=(), channels=None, block_rates=None,
                      travel_offset_km: float | None = None) -> LifeTestSigns:
    """:func:`feed_life_test` and its worst channel's LifeTestSigns."""
    return feed_life_test(p, block_t_ns, blocks, level_t_ns, level_db, start_ns, stop_at_end_of_test,
                          position_t_ns=position_t_ns, position_m=position_m, channels=channels,
                          block_rates=block_rates, travel_offset_km=travel_offset_km).signs


def feed_life_test(p: Any, block_t_ns, blocks, level_t_ns, level_db, start_ns: int | None = None,
                   stop_at_end_of_test: bool = False, *, position_t_ns=(), position_m=(), channels=None,
                   block_rates=None, travel_offset_km: float | None = None) -> StampedLifeTest:
    """Feed positions, sound levels and blocks in stamp order (positions, then levels, then blocks at equal
    stamps) through the StampedLifeTest of the parameters; ``channels[i]`` names block i's channel (default
    the single channel), ``block_rates[i]`` its sample rate (checked per block)."""
    feed = feed_from_params(p, travel_offset_km, start_ns)
    if feed.clock.start_ns is None:
        firsts = [int(a[0]) for a in (block_t_ns, level_t_ns, position_t_ns) if len(a)]
        feed.clock.start_ns = min(firsts) if firsts else 0
    events = sorted([(int(t), 0, i) for i, t in enumerate(position_t_ns)] +
                    [(int(t), 1, i) for i, t in enumerate(level_t_ns)] +
                    [(int(t), 2, i) for i, t in enumerate(block_t_ns)])
    for t, kind, i in events:
        if kind == 0:
            feed.on_position(t, float(position_m[i]))
        elif kind == 1:
            feed.on_level(t, float(level_db[i]))
        else:
            feed.on_block(t, blocks[i], "" if channels is None else channels[i],
                          None if block_rates is None else block_rates[i])
        if stop_at_end_of_test and feed.signs.level()[0].name == "ERROR":
            break
    return feed


def vibration_status_values(feed: StampedLifeTest) -> dict:
    """The `<joint> vibration` status values of a StampedLifeTest (live node and offline alike): the worst
    channel's (named in ``channel``)."""
    signs = feed.signs
    s = signs.summary()
    last = signs.last
    energies = last.get("energies")
    band = s["abnormal_band_hz"]
    return {
        "blocks": sum(c.blocks for c in feed.channels.values()), "channel": feed.worst_channel,
        "levels": signs.noise.levels,
        "rejected_blocks": feed.rejected_blocks, "rejected_levels": feed.rejected_levels,
        "rejected_positions": feed.rejected_positions,
        "travel_km": s["last_travel_km"], "travel_source": feed.clock.source(),
        "z_max": s["z_max"], "z_threshold": s["z_threshold"],
        "abnormal_band_hz": f"{band[0]:.0f}-{band[1]:.0f}" if band and last.get("abnormal") else "",
        "defect": signs.defect or "", "defect_frequency_hz": s["defect_measured_hz"],
        "defect_frequency_uncertainty_hz": s["defect_measured_uncertainty_hz"],
        "defect_resolution_hz": s["defect_resolution_hz"], "defect_spectrum": s["defect_spectrum"],
        "noise_level_db": s["noise_level_db"], "noise_rise_db": s["noise_rise_db"], "noise_sd_db": s["noise_sd_db"],
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


def life_units(p: Any) -> float:
    """km per unit of the rig-free life u = L (F/C)^3 / L_ref (seed 004 Eq. 5 solved: u = (C_test / C)^3 for a
    life L at F = load_fraction x C)."""
    return p.rating_distance_km / p.load_fraction ** 3


def weibull_of_rigs(intervals_km: list[tuple[float, float]], ps: list, confidence: float = 0.90) -> dict:
    """One interval-censored Weibull fit of specimens from several rigs (``ps[i]``: specimen i's parameters).
    Rigs of one load_fraction and rating distance: the fit in km (:func:`weibull_of_specimens`). Otherwise the
    lives in rig-free units u = L / life_units (the same guide type gives them one distribution), B10_u and
    C_test / C = B10_u^(1/3); per rig its B10 [km] at its own load and its C_test / C (Eq. 5)."""
    keys = {(p.load_fraction, p.rating_distance_km) for p in ps}
    if len(keys) == 1:
        fit = weibull_of_specimens(intervals_km, ps[0], confidence) | {"units": "km"}
        b10_u = fit["b10_km"] / life_units(ps[0])
    else:
        scale = np.array([life_units(p) for p in ps])
        lo = np.array([a for a, _ in intervals_km], dtype=float) / scale
        up = np.array([b for _, b in intervals_km], dtype=float) / scale
        w = weibull.fit_weibull(lo, up, np.ones(lo.size), confidence=confidence)
        b10_u = w.b_life_km
        fit = {"n": w.n, "failures": w.failures, "shape": w.shape, "scale": w.scale_km, "b10": b10_u,
               "b10_ci": list(w.b_life_ci_km), "units": "L_ref at F = C (life x (F/C)^3 / L_ref)",
               "c_ratio": b10_u ** (1.0 / 3.0), "c_ratio_ci": [b ** (1.0 / 3.0) for b in w.b_life_ci_km]}
    rigs = []
    for p in ps:
        b10_km = b10_u * life_units(p)
        rigs.append({"load_fraction": p.load_fraction, "rating_distance_km": p.rating_distance_km,
                     "b10_km": b10_km, "c_ratio": float(lm.c_ratio_from_life(p.load_fraction, b10_km,
                                                                             p.rating_distance_km))})
    return fit | {"rigs": rigs}


ACCEL_TOPIC, ACCEL_CHANNELS_TOPIC = "guide/acceleration", "guide/acceleration_channels"
PRESSURE_TOPIC, LEVEL_DB_TOPIC, POSITION_TOPIC = "guide/sound_pressure", "guide/sound_level_db", "joint_states"


def _stamp_ns(m) -> int:
    return m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec


def _add_message(out: dict, store, conn, t_log: int, raw) -> None:
    """One bag message into the life-test data (module docstring of read_life_test_bag)."""
    topic, kind = conn.topic, conn.msgtype
    if topic.endswith(ACCEL_TOPIC) and kind == "sensor_msgs/msg/LaserScan":
        m = store.deserialize_cdr(raw, kind)
        out["block_t_ns"].append(_stamp_ns(m))
        out["blocks"].append(np.asarray(m.ranges, dtype=float))
        out["channels"].append("")
        out["block_rates"].append(1.0 / m.time_increment if m.time_increment > 0 else 0.0)
    elif topic.endswith(ACCEL_CHANNELS_TOPIC) and kind == "sensor_msgs/msg/PointCloud2":
        m = store.deserialize_cdr(raw, kind)
        try:
            fs, chans = decode_channels([(f.name, f.offset, f.datatype, f.count) for f in m.fields], m.width,
                                        m.height, m.point_step, m.is_bigendian, m.data)
        except ValueError:
            out["rejected_blocks"] += 1
            return
        for name, x in chans.items():
            out["block_t_ns"].append(_stamp_ns(m))
            out["blocks"].append(x)
            out["channels"].append(name)
            out["block_rates"].append(fs)
    elif topic.endswith(PRESSURE_TOPIC) and kind == "sensor_msgs/msg/FluidPressure":
        m = store.deserialize_cdr(raw, kind)
        if math.isfinite(m.fluid_pressure) and m.fluid_pressure > 0:
            out["level_t_ns"].append(_stamp_ns(m))
            out["level_db"].append(20.0 * math.log10(m.fluid_pressure / SOUND_LEVEL_REFERENCE_PA))
        else:
            out["rejected_levels"] += 1
    elif topic.endswith(LEVEL_DB_TOPIC) and kind in ("std_msgs/msg/Float64", "std_msgs/msg/Float32"):
        out["level_t_ns"].append(int(t_log))         # no header: the recording time
        out["level_db"].append(float(store.deserialize_cdr(raw, kind).data))
    elif topic.endswith(POSITION_TOPIC) and kind == "sensor_msgs/msg/JointState":
        m = store.deserialize_cdr(raw, kind)
        for name, x in zip(m.name, m.position):
            out["positions"].setdefault(name, ([], []))
            out["positions"][name][0].append(_stamp_ns(m))
            out["positions"][name][1].append(float(x))


def read_life_test_bag(path) -> dict:
    """Blocks, sound levels and axis positions of a life-test bag: ``guide/acceleration`` sensor_msgs/LaserScan
    (one channel) and/or ``guide/acceleration_channels`` sensor_msgs/PointCloud2 (io/accel_channels.py), each
    block with its own rate; ``guide/sound_pressure`` sensor_msgs/FluidPressure [Pa] and/or
    ``guide/sound_level_db`` std_msgs/Float64 or Float32 [dB(A)], stamped by the recording time;
    ``joint_states`` positions per joint name. Pressures <= 0 and malformed channel blocks are counted
    (``rejected_levels``, ``rejected_blocks``). InputError on a missing bag or no block."""
    from rosbags.rosbag2 import Reader

    store = typestore()
    out = {"block_t_ns": [], "blocks": [], "channels": [], "block_rates": [], "level_t_ns": [], "level_db": [],
           "positions": {}, "rejected_blocks": 0, "rejected_levels": 0}
    check_bag_file_paths(Path(path))        # no storage file outside the bag folder
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - any unreadable bag is one line
        raise InputError(f"cannot open life-test bag {path}: {str(exc).splitlines()[0] if str(exc) else exc}") from None
    try:
        for conn, t_log, raw in reader.messages():
            _add_message(out, store, conn, t_log, raw)
    finally:
        reader.close()
    if not out["blocks"]:
        raise InputError(f"{path}: no {ACCEL_TOPIC} (sensor_msgs/msg/LaserScan) or {ACCEL_CHANNELS_TOPIC} "
                         "(sensor_msgs/msg/PointCloud2) blocks")
    out["sample_rate_hz"] = out["block_rates"][-1]
    return out


def life_test_from_bag(path, p: Any, travel_offset_km: float | None = None, start_ns: int | None = None) -> dict:
    """The seed's chain from a bag: failure travel from the recorded signs -> C_test / C (seed 004 Eq. 5)."""
    return life_test_from_data(path, read_life_test_bag(path), p, travel_offset_km, start_ns)


def life_test_from_data(path, d: dict, p: Any, travel_offset_km: float | None = None,
                        start_ns: int | None = None) -> dict:
    """:func:`life_test_from_bag` on data already read by :func:`read_life_test_bag` (``path`` names it)."""
    pos_t, pos_x = d.get("positions", {}).get(p.joint_name, ([], []))
    try:
        feed = feed_life_test(p, np.array(d["block_t_ns"]), d["blocks"], np.array(d["level_t_ns"]),
                              np.array(d["level_db"]), start_ns, position_t_ns=pos_t, position_m=pos_x,
                              channels=d.get("channels"), block_rates=d.get("block_rates"),
                              travel_offset_km=travel_offset_km)
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from None
    if not any(c.blocks for c in feed.channels.values()):
        rates = sorted({f"{r:g}" for r in d.get("block_rates", [])})
        raise InputError(f"{path}: no block accepted (blocks at {', '.join(rates)} Hz, sample_rate_hz is "
                         f"{p.sample_rate_hz:g})")
    signs = feed.signs
    return signs.summary() | {"c_ratio": c_ratio_of(signs, p), "load_fraction": p.load_fraction,
                              "channel": feed.worst_channel, "travel_source": feed.clock.source(),
                              "rejected_blocks": feed.rejected_blocks + d.get("rejected_blocks", 0),
                              "rejected_levels": feed.rejected_levels + d.get("rejected_levels", 0),
                              "rejected_positions": feed.rejected_positions}


def specimen_interval_km(summary: dict) -> tuple[float, float]:
    """A specimen's interval-censored life [km]: (previous block, failure block] when it failed, (last travel,
    inf) when it survived the recorded test (seed 004 Sec. 3.2)."""
    if summary.get("failure_interval_km"):
        lower, upper = summary["failure_interval_km"]
        return float(lower), float(upper)
    return float(summary["last_travel_km"]), math.inf
