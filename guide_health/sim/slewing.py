"""Generated slewing-bearing load histories (crane / excavator duty) for bags and tests.

A work cycle: hoist a payload (axial load and tilting moment rise as the load leaves the ground),
slew with it (the moment oscillates with the boom's dynamic sway, an inertial radial load acts while
the slew accelerates and brakes), lower it, and slew back empty. Every cycle draws its payload and
boom radius, so the roller loads vary over the whole run. Loads are in the bearing frame of
INTERFACES.md: axial F_a (force.z), radial F_r, tilting moment M_T, all >= 0 here.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from guide_health.errors import InputError
from guide_health.params import SLEWING_MONITOR_SCHEMA, SLEWING_SIMULATION_SCHEMA, slewing_simulation_params
from guide_health.params.typed import slewing_monitor_params, typed_params
from guide_health.runs import SlewingLoadRun
from guide_health.sim.machine import START_TIME_NS
from guide_health.sim.slewing_duty import simulate_oscillating_duty


def _smoothstep(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def simulate_slewing(sim: dict[str, Any], seed: int = 0, bearing: Any = None) -> SlewingLoadRun:
    """Load samples at `load_rate_hz` for `duration_h` (see the module doc for the cycle); duty yaw or pitch:
    sim/slewing_duty.py on ``bearing`` (typed slewing_monitor parameters; None = the seed-003 bearing)."""
    values = slewing_simulation_params(sim)            # validated; the run's metadata keeps the dict
    p = typed_params(SLEWING_SIMULATION_SCHEMA.section, values, validate=False)
    if p.duty != "crane":
        if bearing is None:
            bearing = slewing_monitor_params(SLEWING_MONITOR_SCHEMA.defaults())
        return simulate_oscillating_duty(p, bearing, seed, {"simulation": values})
    rng = np.random.default_rng(seed)
    n = int(round(p.duration_h * 3600.0 * p.load_rate_hz))
    if n < 1:
        raise InputError("slewing simulation: fewer than one sample")
    t_s = np.arange(n) / p.load_rate_hz
    cycle = p.cycle_s
    k = (t_s // cycle).astype(int)
    u = (t_s % cycle) / cycle                                   # phase in the cycle
    n_cycles = int(k[-1]) + 1
    payload = rng.uniform(0.2, 1.0, n_cycles) * p.payload_max_n
    radius = rng.uniform(p.boom_radius_min_m, p.boom_radius_max_m, n_cycles)
    # share of the payload hanging on the hook: 0 -> 1 while hoisting, 1 while slewing, 1 -> 0 lowering
    hook = np.where(u < 0.2, _smoothstep(u / 0.2),
                    np.where(u < 0.5, 1.0, np.where(u < 0.7, 1.0 - _smoothstep((u - 0.5) / 0.2), 0.0)))
    slewing = ((u >= 0.2) & (u < 0.5)) | (u >= 0.7)
    slew_u = np.where(u < 0.5, (u - 0.2) / 0.3, (u - 0.7) / 0.3)
    sway = np.where(slewing, p.sway_fraction * np.sin(2 * np.pi * 3.0 * slew_u), 0.0)
    static_moment = p.dead_moment_nm + hook * payload[k] * radius[k]
    moment = static_moment * (1.0 + sway)
    axial = p.dead_weight_n + hook * payload[k]
    # inertial radial load: accelerate in the first, brake in the last tenth of each slew
    ramp = np.where(slewing & ((slew_u < 0.1) | (slew_u > 0.9)), 1.0, 0.0)
    radial = ramp * p.slew_radial_n * (0.5 + 0.5 * hook) + 0.02 * axial
    t_ns = START_TIME_NS + np.round(t_s * 1e9).astype(np.int64)
    return SlewingLoadRun(t_ns=t_ns, axial_n=axial, radial_n=radial, moment_nm=moment,
                          metadata={"scenario": "crane duty", "seed": seed, "simulation": values})
