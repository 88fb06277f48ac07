"""Mutation check of the rule modules: does the test suite see a plausible one-line bug in each rule?

Each mutation is (module, the exact original source text, the mutated text, why it is plausible). One at a
time: the module's file is rewritten with the mutation, the module's tests run (pytest ``-x -q -p
no:randomly``, fail fast), the file is restored. A mutation is *caught* when pytest fails, *survived* when it
passes, *not applied* when its original text is not found exactly once in the module (the module was
refactored: re-anchor the text). ``EQUIVALENT`` lists the mutations known to change no behaviour, with the
reason; they are reported apart and not counted in the caught share.

Which tests run for a module (``MODULES``, the one place; fastest first, as pytest stops at the first
failure): the test files that import the module by its dotted name (``grep -l`` of ``guide_health.<module>``
in test/, listed with ``--list``) and take at most ~2 min each on the loaded 2-core machine, plus the test
files of the module's users that state its rule (test_readme_promises.py for the input rules and levels,
test_alarms.py for the slewing level), test_rule_guards.py wherever it checks the module's rule, and
test_mutation_guards.py (12 s, written for the survivors of the first run). Left out for time:
test_input_limits.py (3 min), test_physics_review.py (2.5 min; its Walther test is run alone), the
end-to-end files (live replay, discrepancy, model file) and the three 30-45 s end-to-end runs of
test_live_duty_effects.py (``-k``: an entry may be any pytest argument). A full run takes ~40 min.

    python bench/mutation_check.py               # every mutation: table per module, exit 1 below 90 % caught
    python bench/mutation_check.py --list        # the mutations, their modules' tests and the grep's importers
    python bench/mutation_check.py --check       # only: is every original text found exactly once?
    python bench/mutation_check.py -k levels     # the mutations of the modules whose key contains 'levels'
    python bench/mutation_check.py --match "ML instead"    # the mutations whose reason contains the text

The check refuses to start when a module file has uncommitted changes (``git status``), and restores every
file it touched on exit, Ctrl-C and SIGTERM included (try/finally, the original bytes kept in memory).
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GUARDS = "test/test_rule_guards.py"
MORE = "test/test_mutation_guards.py"
WALTHER_SEED_TEST = "test/test_physics_review.py::test_item6_walther_oil_puts_lambda_1_at_0p5_m_s_at_21_degc"

#: module key -> (source file, test files run for it)
MODULES: dict[str, tuple[str, tuple[str, ...]]] = {
    "input_rules": ("guide_health/models/wear/input_rules.py",
                    (MORE, "test/test_input_rules.py", "test/test_readme_promises.py")),
    "levels": ("guide_health/models/levels.py",
               (MORE, "test/test_alarms.py", GUARDS, "test/test_readme_promises.py")),
    "params_loader": ("guide_health/params/loader.py",
                      (MORE, "test/test_params.py", GUARDS, "test/test_params_strict.py")),
    "params_rcl_yaml": ("guide_health/params/rcl_yaml.py",
                        (MORE, "test/test_params.py", GUARDS, "test/test_params_strict.py",
                         "test/test_params_reliability.py")),
    "params_schema": ("guide_health/params/schema.py", (MORE, "test/test_params.py", "test/test_params_strict.py")),
    "life_interval": ("guide_health/models/wear/calibration.py",
                      (MORE, "test/test_fleet_prior.py", "test/test_readme_promises.py")),
    "effect_life": ("guide_health/models/wear/effect_life.py",       # without its three 30-45 s end-to-end runs
                    (MORE, "test/test_live_duty_effects.py", "-k", "not vectorised_path and not automatic_lubricator "
                                                              "and not matches_replay")),
    "maintenance": ("guide_health/models/wear/maintenance.py", (MORE, "test/test_maintenance.py")),
    "io_storage": ("guide_health/io/bag/protocol.py", (MORE, "test/test_bags.py", "test/test_bulk_read.py")),
    "io_packed": ("guide_health/io/bag/sqlite3_storage.py", (MORE, "test/test_bags.py", "test/test_bulk_read.py")),
    "io_mcap_chunks": ("guide_health/io/bag/mcap_storage.py", (MORE, "test/test_bags.py", "test/test_bulk_read.py",
                                                            "test/test_mcap_layouts.py")),
    "io_bag_reader": ("guide_health/io/bag/reader.py", (MORE, "test/test_bags.py", "test/test_bulk_read.py")),
    "slewing_row_loads": ("guide_health/models/slewing/row_loads.py",
                          ("test/test_roller_contact.py", "test/test_slewing_monitor.py")),
    "slewing_monitor": ("guide_health/models/slewing/monitor.py",
                        (GUARDS, "test/test_alarms.py", "test/test_slewing_monitor.py")),
    "rolling_lubrication": ("guide_health/models/rolling/lubrication.py",
                            (MORE, "test/test_rolling_contact.py", "test/test_rolling_guide.py")),
    "rolling_oil": ("guide_health/models/rolling/oil.py",
                    (GUARDS, WALTHER_SEED_TEST)),
    "rolling_vibration": ("guide_health/models/rolling/vibration.py", (GUARDS, "test/test_vibration.py")),
    "fleet_prior": ("guide_health/models/fleet.py", (MORE, GUARDS, "test/test_fleet_prior.py")),
}


@dataclass(frozen=True)
class Mutation:
    module: str          # key of MODULES
    original: str        # exact source text, found exactly once in the module
    mutated: str
    why: str             # the plausible bug it stands for


M = Mutation
MUTATIONS: tuple[Mutation, ...] = (
    # --- input rules ------------------------------------------------------------------------------------
    M("input_rules", 'position_min_m=p["rail_start_m"] - margin,', 'position_min_m=p["rail_start_m"] + margin,',
      "rail-travel margin with the wrong sign"),
    M("input_rules", "    if abs(load_n) > limits.load_max_n:", "    if load_n > limits.load_max_n:",
      "reverse loads never checked against the maximum (live path)"),
    M("input_rules", "above = finite & (np.abs(w) > limits.load_max_n)", "above = finite & (w > limits.load_max_n)",
      "reverse loads never checked against the maximum (vectorised path)"),
    M("input_rules", "    if straightness_m < 0:", "    if straightness_m <= 0:",
      "a zero straightness reading rejected as negative"),
    M("input_rules", "load_max = min(load_max, p[\"load_max_rating_multiple\"] * rating)",
      "load_max = max(load_max, p[\"load_max_rating_multiple\"] * rating)", "min/max confused for the rating cap"),
    M("input_rules", "    if len(run) >= limits.rebase_samples:", "    if len(run) > limits.rebase_samples:",
      "off by one in the samples that agree on a new time base"),
    M("input_rules", 'idx = np.searchsorted(lt, joint_t_ns, side="right") - 1',
      'idx = np.searchsorted(lt, joint_t_ns, side="left") - 1',
      "a load stamped at the joint sample's stamp not yet in force"),
    M("input_rules", "        return w if not w < 0.0 else 0.0", "        return abs(w)",
      "a reverse load counted as pressing on the main way (scalar path)"),
    # --- levels ------------------------------------------------------------------------------------------
    M("levels", "limit = threshold * (1.0 - margin)", "limit = threshold * (1.0 + margin)",
      "hysteresis on the wrong side of an 'above' threshold"),
    M("levels", "return value < threshold * (1.0 + margin)", "return value < threshold * (1.0 - margin)",
      "hysteresis on the wrong side of a 'below' threshold"),
    M("levels", "return value >= limit if inclusive else value > limit",
      "return value > limit if inclusive else value > limit", "inclusive flag ignored (ERROR at the limit)"),
    M("levels", "if self.level == Level.ERROR and previous != Level.ERROR:", "if self.level == Level.ERROR:",
      "an ERROR counted as a new event every period"),
    M("levels", "return Level(min(current, max(level_set, level_clear)))", "return Level(level_set)",
      "hysteresis dropped: the level falls at once"),
    M("levels", "if current is None or level_set >= current:", "if current is None or level_set > current:",
      "a level judged equal to the present one goes through the clearing branch"),
    # --- parameter loading ---------------------------------------------------------------------------------
    M("params_rcl_yaml", '"/" + re.escape(part)\n', '"/" + re.escape(part) + "[^/]*"\n',
      "node sections matched by prefix (wear_monitor_spare read by wear_monitor)"),
    M("params_loader", "    for one in paths:\n        p = load_node_params(",
      "    for one in reversed(paths):\n        p = load_node_params(",
      "several params files merged in the wrong order"),
    M("params_loader", "    return [(section.name, section.params) for section in chosen]",
      "    return [(section.name, section.params) for section in reversed(chosen)]",
      "sections applied against file order (an earlier section wins over a later one)"),
    M("params_loader", "    if strict:\n        generic = _generic(key)",
      "    if False:\n        generic = _generic(key)",
      "unknown parameter names no longer refused"),
    M("params_schema", "above = value > low if low_open else value >= low",
      "above = value >= low if low_open else value >= low", "open interval's low end accepted"),
    M("params_schema", "below = value < high if high_open else value <= high",
      "below = value <= high if high_open else value <= high", "open interval's high end accepted"),
    M("params_schema", "        if isinstance(value, bool) or not isinstance(value, int):",
      "        if not isinstance(value, int):", "true/false accepted for an integer parameter"),
    M("params_schema", "        if name not in known:\n", "        if name not in known and '_' not in name:\n",
      "unknown names with an underscore let through"),
    # --- life interval ------------------------------------------------------------------------------------
    M("life_interval", "Z90 = NormalDist().inv_cdf(0.95)", "Z90 = NormalDist().inv_cdf(0.90)",
      "an 80 % interval labelled 90 %"),
    M("life_interval", "z = float(stdtrit(n - 1, 0.95)) if n >= 3 else Z90",
      "z = float(stdtrit(n, 0.95)) if n >= 3 else Z90", "Student-t with n instead of n - 1 degrees of freedom"),
    # --- effect life ---------------------------------------------------------------------------------------
    M("effect_life", "math.exp(-s_now_m / distance_m)", "math.exp(s_now_m / distance_m)",
      "running-in decay with the wrong sign"),
    M("effect_life", "return (b - a) + growth_per_s * (b * b - a * a) / 2.0",
      "return (b - a) + growth_per_s * (b * b - a * a)", "the integral of a linear multiplier without its 1/2"),
    M("effect_life", "due = max(interval_s - tau_now_s, 0.0)", "due = interval_s",
      "the next relubrication a full interval away whatever the time since the last"),
    M("effect_life", "var += (dln(1e-2 * k_sd, None) * k_sd) ** 2", "var += dln(1e-2 * k_sd, None) * k_sd ** 2",
      "K's variance term missing its square on the sensitivity"),
    # --- maintenance ---------------------------------------------------------------------------------------
    M("maintenance", "    integ.archard_work_nm = 0.0\n", "    integ.archard_work_nm = integ.archard_work_nm\n",
      "a regrind that keeps the wear"),
    M("maintenance", 'RESETS_WEAR = ("regrind", "replace_rail")', 'RESETS_WEAR = ("regrind",)',
      "a rail replacement that keeps the wear"),
    M("maintenance", "    if event.guide and event.guide not in guides:", "    if event.guide not in guides:",
      "an event for every guide ('') refused"),
    M("maintenance", "prior_rel_sd=k_sd / k if k > 0 else", "prior_rel_sd=k_sd if k > 0 else",
      "an absolute sd used as the relative one after a regrind"),
    M("maintenance", "        monitor.rolling.boundary_travel_m = 0.0\n", "",
      "relubrication does not restart the recent boundary share"),
    # --- bag readers ---------------------------------------------------------------------------------------
    M("io_packed", '_RANGE = "FROM messages WHERE rowid >= ? AND rowid < ?"',
      '_RANGE = "FROM messages WHERE rowid > ? AND rowid < ?"', "a dropped row per sqlite range"),
    M("io_packed", "        if last_max is not None and t_min < last_max:",
      "        if last_max is not None and t_min < last_max and False:",
      "rowid order taken as log-time order without the check"),
    M("io_packed", "            sql += \" AND timestamp >= ?\"", "            sql += \" AND timestamp > ?\"",
      "a resumed read skips the messages at its start stamp"),
    M("io_storage", "        if count < chunk_messages:\n            return", "        if count <= chunk_messages:\n"
      "            return", "reading stops after the first full batch"),
    M("io_mcap_chunks", "            if group and seg.start_ns <= group_end:",
      "            if group and False:", "overlapping mcap chunks read in file order (log times out of order)"),
    M("io_mcap_chunks", "            if done < n:\n", "            if done < n - 1:\n",
      "the last message of a chunk dropped when it does not complete a batch"),
    M("io_bag_reader", "        if idx.size == got:", "        if idx.size >= 1:",
      "a mixed batch handed whole to one topic"),
    # --- slewing row loads and level -----------------------------------------------------------------------
    M("slewing_row_loads", "moment_term = 4.0 * moment / (roller_count * raceway_diameter_m)",
      "moment_term = 2.0 * moment / (roller_count * raceway_diameter_m)", "radius for diameter in Eq. 1"),
    M("slewing_row_loads", "RADIAL_ROW_LINE_CONTACT_FACTOR: float = 4.08",
      "RADIAL_ROW_LINE_CONTACT_FACTOR: float = 4.37", "Stribeck's point-contact factor for a line contact"),
    M("slewing_row_loads", "    opposite = moment_term - axial_term", "    opposite = moment_term + axial_term",
      "the axial load pressing on both rows"),
    M("slewing_monitor", "    return WARN if exceeds(p_max_pa, warn_fraction * allowable_pa, margin) else OK",
      "    return WARN if exceeds(p_max_pa, warn_fraction * allowable_pa) else OK",
      "the WARN threshold's clearing test without the margin"),
    M("slewing_monitor", 'if self.worst is None or report["p_max_MPa"] > self.worst["p_max_MPa"]:',
      "if True:", "the period's last roller reported instead of its worst"),
    # --- rolling guide: film, oil, defect frequencies -----------------------------------------------------
    M("rolling_lubrication", "    return 0.5 * abs(carriage_speed_m_s)", "    return abs(carriage_speed_m_s)",
      "the carriage speed as the entrainment speed"),
    M("rolling_lubrication", "e_prime = 2.0 * effective_modulus_pa                        # Hamrock & Dowson's E'",
      "e_prime = effective_modulus_pa",
      "E* for Hamrock's E' = 2 E*"),
    M("rolling_lubrication", "* (1.0 - math.exp(-0.68 * ellipticity_k)))",
      "* (1.0 - 0.61 * math.exp(-0.68 * ellipticity_k)))", "the central film's ellipticity factor in h_min"),
    M("rolling_oil", "WALTHER_OFFSET_MM2_S = 0.7", "WALTHER_OFFSET_MM2_S = 0.6", "Walther's offset"),
    M("rolling_oil", "KELVIN_OFFSET = 273.15", "KELVIN_OFFSET = 273.0", "a rounded absolute temperature"),
    M("rolling_oil", "(1.0 - DENSITY_EXPANSION_PER_K * (", "(1.0 + DENSITY_EXPANSION_PER_K * (",
      "oil density rising with temperature"),
    M("rolling_vibration", "f_race = 0.5 * v / kin.ball_pitch_m", "f_race = v / kin.ball_pitch_m",
      "the raceway frequency without the 1/2"),
    M("rolling_vibration", '"ball_defect_hz": 2.0 * f_spin,', '"ball_defect_hz": f_spin,',
      "one strike per ball turn instead of two"),
    M("rolling_vibration", "r_roll = 0.5 * kin.ball_diameter_m * math.cos(kin.contact_angle_rad)",
      "r_roll = 0.5 * kin.ball_diameter_m * math.sin(kin.contact_angle_rad)", "sin for cos of the contact angle"),
    # --- fleet prior ---------------------------------------------------------------------------------------
    M("fleet_prior", "np.sum(np.log(v)) + math.log(np.sum(w)) + np.sum(", "np.sum(np.log(v)) + np.sum(",
      "ML instead of REML"),
    M("fleet_prior", "return nll, mu, 1.0 / math.sqrt(float(np.sum(w)))", "return nll, mu, 1.0 / float(np.sum(w))",
      "the variance of mu as its standard error"),
    M("fleet_prior", "return math.exp(log_k_fit.mean + 0.5 * v), math.sqrt(math.expm1(v))",
      "return math.exp(log_k_fit.mean), math.sqrt(math.expm1(v))", "the lognormal median as its mean"),
    M("fleet_prior", "    w = [1.0 / (s * s) for _, s in pairs]", "    w = [1.0 / s for _, s in pairs]",
      "inverse sd for inverse variance weights"),
)

#: mutations that change no observable behaviour, with why (reported, not counted): empty when none is known
EQUIVALENT: dict[tuple[str, str], str] = {
    ("levels", "if current is None or level_set >= current:"):
        "with level_set == current the clearing branch returns min(current, max(current, level_clear)) = current, "
        "what the rising branch returns: the same level for every input",
}


def _dirty(paths: list[str]) -> list[str]:
    out = subprocess.run(["git", "status", "--porcelain", "--", *paths], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    return [line[3:] for line in out.splitlines() if line.strip()]


def _importers(source: str) -> list[str]:
    dotted = source[:-3].replace("/", ".")
    files = sorted(str(p) for p in (ROOT / "test").glob("test_*.py"))
    out = subprocess.run(["grep", "-l", "-E", rf"{dotted}\b", *files], capture_output=True, text=True)
    return [str(Path(p).relative_to(ROOT)) for p in out.stdout.split()]


def anchor(m: Mutation, text: str) -> str | None:
    """The mutated module text, or None when the original is not found exactly once."""
    return text.replace(m.original, m.mutated, 1) if text.count(m.original) == 1 else None


def run_tests(tests: tuple[str, ...], timeout_s: float) -> tuple[str, float, str]:
    """('caught' | 'survived' | 'timeout', seconds, the first failing test or '')."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               PYTHONDONTWRITEBYTECODE="1")
    start = time.monotonic()
    try:
        run = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:randomly", "-p",
                              "no:cacheprovider", "--no-header", "-rf", *tests], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return "timeout", time.monotonic() - start, ""
    failed = next((line.split(" ", 2)[1] for line in run.stdout.splitlines() if line.startswith("FAILED ")), "")
    if run.returncode == 0:
        return "survived", time.monotonic() - start, ""
    if run.returncode in (1, 2) and (failed or "error" in run.stdout.lower()):
        return "caught", time.monotonic() - start, failed or run.stdout.strip().splitlines()[-1]
    return "caught", time.monotonic() - start, f"pytest exit {run.returncode}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-k", default="", help="only modules whose key contains this")
    ap.add_argument("--match", default="",
                    help="only mutations whose reason ('why') contains one of these '|'-separated texts")
    ap.add_argument("--list", action="store_true", help="list the mutations and tests, run nothing")
    ap.add_argument("--check", action="store_true", help="only check that every original text is found once")
    ap.add_argument("--timeout", type=float, default=600.0, help="per mutation [s]; a timeout counts as caught")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTATIONS if args.k in m.module and any(t in m.why for t in args.match.split("|"))]
    sources = {key: ROOT / src for key, (src, _) in MODULES.items()}
    originals = {key: path.read_text() for key, path in sources.items() if any(m.module == key for m in chosen)}
    unanchored = [m for m in chosen if anchor(m, originals[m.module]) is None]
    for m in unanchored:
        print(f"NOT APPLIED: {m.module}: original text found {originals[m.module].count(m.original)} times "
              f"(must be 1): {m.original.strip()[:70]!r}", file=sys.stderr)
    if args.list:
        for key in originals:
            src, tests = MODULES[key]
            print(f"{key}: {src}\n  runs: {' '.join(tests)}\n  importers: {' '.join(_importers(src))}")
            for m in chosen:
                if m.module == key:
                    print(f"    - {m.why}")
        return 0
    if args.check:
        return 1 if unanchored else 0
    dirty = _dirty([str(p.relative_to(ROOT)) for p in sources.values() if p.read_text() is not None])
    if dirty:
        print(f"refusing to start: uncommitted changes in {', '.join(dirty)}", file=sys.stderr)
        return 2
    results: list[tuple[Mutation, str, float, str]] = [(m, "not applied", 0.0, "") for m in unanchored]
    touched: dict[Path, str] = {}

    def restore(*_):
        for path, text in touched.items():
            path.write_text(text)
        touched.clear()
        if _:
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, restore)
    baseline: dict[str, bool] = {}      # a module's tests must pass unmutated, or no failure of them means a catch
    try:
        for i, m in enumerate(chosen, 1):
            if m in unanchored:
                continue
            if m.module not in baseline:
                outcome, seconds, failed = run_tests(MODULES[m.module][1], args.timeout)
                baseline[m.module] = outcome == "survived"
                if not baseline[m.module]:
                    print(f"BASELINE FAILS: {m.module}: its tests fail unmutated ({failed or outcome}); its "
                          f"mutations are not judged", file=sys.stderr, flush=True)
            if not baseline[m.module]:
                results.append((m, "baseline fails", 0.0, ""))
                continue
            path = sources[m.module]
            touched[path] = originals[m.module]
            path.write_text(anchor(m, originals[m.module]))
            outcome, seconds, failed = run_tests(MODULES[m.module][1], args.timeout)
            restore()
            if outcome == "survived" and (m.module, m.original) in EQUIVALENT:
                outcome = "equivalent"
            results.append((m, outcome, seconds, failed))
            print(f"[{i}/{len(chosen)}] {m.module}: {outcome} in {seconds:.0f} s: {m.why}"
                  + (f" ({failed})" if failed else ""), flush=True)
    finally:
        restore()
        signal.signal(signal.SIGTERM, previous)
    return report(results)


def report(results) -> int:
    print("\n| module | mutations | caught | survived | equivalent | not applied | baseline fails |\n"
          "|---|---|---|---|---|---|---|")
    total = {"caught": 0, "survived": 0, "equivalent": 0, "not applied": 0, "baseline fails": 0, "timeout": 0}
    for key in MODULES:
        mine = [r for r in results if r[0].module == key]
        if not mine:
            continue
        n = {k: sum(r[1] == k for r in mine) for k in total}
        n["caught"] += n.pop("timeout")
        for k, v in n.items():
            total[k] += v
        print(f"| {key} | {len(mine)} | {n['caught']} | {n['survived']} | {n['equivalent']} | {n['not applied']} "
              f"| {n['baseline fails']} |")
    total["caught"] += total.pop("timeout")
    counted = total["caught"] + total["survived"]
    share = total["caught"] / counted if counted else 0.0
    print(f"| all | {len(results)} | {total['caught']} | {total['survived']} | {total['equivalent']} | "
          f"{total['not applied']} | {total['baseline fails']} |\n\n"
          f"caught {share:.0%} of {counted} applied non-equivalent mutations")
    for m, outcome, _, _ in results:
        if outcome in ("survived", "not applied", "baseline fails"):
            print(f"  {outcome.upper()}: {m.module}: {m.why}")
    return 0 if share >= 0.9 and not total["not applied"] and not total["baseline fails"] else 1


if __name__ == "__main__":
    sys.exit(main())
