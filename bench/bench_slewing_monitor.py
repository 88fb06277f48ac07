"""slewing_monitor per-load-message model cost at 200 Hz (issue 6.4 / issue 3).

    .venv/bin/python bench/bench_slewing_monitor.py [--messages 4000]

Feeds a crane-duty load history (simulate_slewing, 200 Hz) through SlewingMonitor.on_loads and reports
the model work per message for
  seed003 cached     SlewingContactModel (everything geometric computed once)   vs the baseline
  seed003 direct     slewing_contact_report from loads (McEwen maxima recomputed per call);
  numerical table    SlewingContactModel with stress_model numerical (RollerContactTable lookup) vs
  numerical direct   one DC-FFT solve per message (numerical_contact_report), timed on a few messages.
Target: < 50 us of model work per message (the load budget at 200 Hz is 5000 us).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def per_message_us(fn, loads) -> float:
    t0 = time.perf_counter()
    for fa, fr, mt in loads:
        fn(fa, fr, mt)
    return (time.perf_counter() - t0) / len(loads) * 1e6


def main() -> int:
    from guide_health.models.slewing.monitor import SlewingMonitor, _numerical_report, slewing_contact_report_from_loads
    from guide_health.params import SLEWING_MONITOR_DEFAULTS
    from guide_health.sim.slewing import simulate_slewing

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--messages", type=int, default=4000)
    args = ap.parse_args()
    run = simulate_slewing({"duration_h": args.messages / 200.0 / 3600.0, "load_rate_hz": 200.0}, seed=1)
    loads = list(zip(run.axial_n.tolist(), run.radial_n.tolist(), run.moment_nm.tolist()))
    params = dict(SLEWING_MONITOR_DEFAULTS)

    cached = SlewingMonitor(params)
    t_cached = per_message_us(cached.on_loads, loads)
    t_direct = per_message_us(lambda a, r, m: slewing_contact_report_from_loads(params, a, r, m), loads[:50])

    t0 = time.perf_counter()
    numerical = SlewingMonitor(dict(params, stress_model="numerical", roller_end_radius_m=2e-3))
    t_build = time.perf_counter() - t0
    t_table = per_message_us(numerical.on_loads, loads)
    q = [numerical.model.report_for_loads(*x)["roller_load_max_n"] for x in loads[:3]]
    t1 = time.perf_counter()
    for load in q:
        _numerical_report(numerical.params, load)
    t_solve = (time.perf_counter() - t1) / len(q) * 1e6

    print(f"{len(loads)} load messages (200 Hz crane duty), model work per message:")
    print(f"  seed003 cached      {t_cached:10.1f} us")
    print(f"  seed003 direct      {t_direct:10.1f} us   (ratio direct / cached {t_direct / t_cached:,.0f})")
    print(f"  numerical table     {t_table:10.1f} us   (table of {numerical.model.table.loads_n.size} loads "
          f"built once in {t_build:.1f} s; interpolation error "
          f"{max(numerical.model.table.interpolation_error.values()) * 100:.2f} %)")
    print(f"  numerical direct    {t_solve:10.1f} us   (ratio direct / table {t_solve / t_table:,.0f})")
    print(f"  budget at 200 Hz     {1e6 / 200:10.1f} us; target < 50 us: "
          f"{'met' if max(t_cached, t_table) < 50 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
