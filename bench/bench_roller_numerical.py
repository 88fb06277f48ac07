"""Benchmark of the numerical finite-roller contact solver.

Prints the direct solve time vs grid size (seed-003 roller: d = 32 mm, L = 31.3 mm, Q = 103.4 kN,
E = 210 GPa, nu = 0.3, straight with end radius r), then builds the load lookup table used by a
live node and prints its interpolation error, the direct solve time per load and the table lookup
time (timeit) with their ratio.

Run: .venv/bin/python bench/bench_roller_numerical.py [--end-radius-mm 2] [--loads 24] [--nx 64 --ny 512]
"""
from __future__ import annotations

import argparse
import sys
import timeit
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from guide_health.models.contact.elastic import effective_modulus_pa  # noqa: E402
from guide_health.models.slewing import numerical_roller as rn  # noqa: E402
from guide_health.params.typed import SlewingMonitorParams  # noqa: E402

SEED = {"roller_diameter_m": 0.032, "roller_length_m": 0.0313, "youngs_modulus_pa": 210.0e9, "poisson": 0.3,
        "roller_profile": "straight", "crown_drop_m": 0.0, "log_profile_coeff_m": 0.0}
SEED_Q = 103_400.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--end-radius-mm", type=float, default=2.0)
    ap.add_argument("--loads", type=int, default=24)
    ap.add_argument("--nx", type=int, default=64)
    ap.add_argument("--ny", type=int, default=512)
    args = ap.parse_args()
    params = dict(SEED, roller_end_radius_m=args.end_radius_mm * 1e-3)
    e_star = effective_modulus_pa(params["youngs_modulus_pa"], params["poisson"])

    print(f"seed-003 roller, straight, r = {args.end_radius_mm} mm, Q = {SEED_Q:.0f} N")
    print(f"{'grid':>10} {'solve_s':>8} {'iters':>6} {'p_max_MPa':>10} {'p0_c_MPa':>9} {'ratio':>7} {'dp_max':>8}")
    prev = None
    for nx, ny in [(32, 128), (64, 256), (64, 512), (128, 512), (128, 1024)]:
        def solve(nx=nx, ny=ny):
            return rn.solve_finite_roller_contact(params["roller_diameter_m"], params["roller_length_m"], SEED_Q,
                                                  e_star, "straight", end_radius_m=params["roller_end_radius_m"],
                                                  nx=nx, ny=ny)
        res = solve()  # warm-up (kernel FFT cached per grid)
        t = min(timeit.repeat(solve, number=1, repeat=3))
        change = "" if prev is None else f"{res.max_pressure_pa / prev - 1:+.2%}"
        prev = res.max_pressure_pa
        print(f"{nx:>4}x{ny:<5} {t:8.3f} {res.iterations:6d} {res.max_pressure_pa / 1e6:10.1f} "
              f"{res.p0_center_pa / 1e6:9.1f} {res.end_stress_ratio:7.3f} {change:>8}")

    typed = SlewingMonitorParams(**params)

    def direct():
        return rn.numerical_contact_report(typed, SEED_Q, nx=args.nx, ny=args.ny)

    t_direct = min(timeit.repeat(direct, number=1, repeat=3))
    table = rn.build_roller_contact_table(typed, 10e3, 200e3, n_loads=args.loads, nx=args.nx, ny=args.ny)
    t_lookup = rn.time_table_lookup(table, SEED_Q)
    print(f"\nlookup table: {args.loads} loads 10-200 kN, grid {args.nx}x{args.ny}, "
          f"mean solve while building {table.solve_time_per_load_s:.3f} s/load")
    print("max relative interpolation error at the geometric mid-points (position: relative to L/2):")
    for k, v in table.interpolation_error.items():
        print(f"  {k:30s} {v:.2e}")
    print(f"direct solve (timeit, best of 3): {t_direct * 1e3:.1f} ms")
    print(f"table lookup (timeit):            {t_lookup * 1e6:.1f} us")
    print(f"ratio direct/lookup:              {t_direct / t_lookup:.0f}")
    d, lk = direct(), table.lookup(SEED_Q)
    print(f"at Q = {SEED_Q:.0f} N: direct p_max {d['p_max_MPa']:.1f} MPa ratio {d['end_stress_ratio']:.4f}; "
          f"table p_max {lk['p_max_MPa']:.1f} MPa ratio {lk['end_stress_ratio']:.4f}")


if __name__ == "__main__":
    main()
