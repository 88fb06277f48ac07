"""Palmgren-Miner fatigue damage of the rows of a slewing bearing over the angle its axis travels, and the
static safety of the worst load sample.

The slewing axis angle (a JointState position, rad) is cut into strokes at its reversals (a reversal is
confirmed once the axis has come back by more than ``reversal_deadband_rad`` from the stroke's extreme; only
new ground beyond the extreme counts as travel, so encoder noise smaller than the deadband at standstill makes
neither strokes nor damage). A stroke of length s (turning point to turning point) is
half an oscillation cycle of amplitude theta = s / 2, i.e. of full swing phi = 2 theta. Counting follows NREL
DG03 (Harris, Rumbarger & Butterfield 2009): angle equivalence above the critical angle, the oscillating rating
of Rumbarger & Jones 1968 below it:

* theta >= theta_crit: angle equivalence, the oscillation life L_osc = L10 (90 deg / theta) cycles, i.e.
  every stroke counts the revolutions it travels: D += sum over the stroke's samples |d phi| / (2 pi L10(P)),
  L10 at the load in force during each step (Palmgren-Miner, ISO 281 Sec. 7).
* theta < theta_crit (adjacent rollers' tracks on the raceway do not overlap): the oscillating dynamic rating
  of a roller bearing C_osc = C (180 deg / phi)^(2/9) Z^0.028 (Z rollers in the row), used with the ISO life
  exponent p = 10/3 like C: L_osc = (C_osc / P)^p = L10 ((90 deg / theta)^(2/9) Z^0.028)^(10/3) cycles, so
  each half cycle adds D += 0.5 / (a_osc L10_mean), L10_mean the stroke's load-weighted mean life.
  The Z term is the signature of the stressed-volume argument (Lundberg-Palmgren) that only holds below
  theta_crit: the Z separate patches a roller stresses grow with theta while each point is stressed twice a
  cycle; with Lundberg-Palmgren's own p = 4 the form is L10 (90/theta)^(8/9) Z^0.112, within 4^(1/9) of
  continuous at theta_crit; with ISO's 10/3 the damage below theta_crit jumps (x 1.64 at Z = 170).
* theta_crit = 360 deg / (Z (1 + gamma)), gamma = D_we / D_pw (0 for the axial rows): over a stroke of 2 theta
  a roller moves theta (1 + gamma) along the raceway (cage at half the ring speed), and adjacent tracks
  touch when that equals the roller pitch 360 deg / Z. (Texts that quote 720 deg / (Z (1 +- gamma)) count
  theta as the full swing.)

The open stroke (no reversal yet) is reported by angle equivalence until its reversal decides its form.
Remaining life per row: the time (axis stamps) so far times (1 - D) / D: the duty seen so far, continued.

Pure physics: numpy/math, SI units (rad, s, N, N m); no ROS, no I/O.
"""
from __future__ import annotations

import math
from typing import Any

from guide_health.models.levels import ERROR, OK, Level
from guide_health.models.slewing.rating import (
    ROLLER_LIFE_EXPONENT,
    ROWS,
    SlewingRatings,
    damage_per_revolution,
    limiting_curve_safety,
    row_equivalent_loads,
    static_safety_factors,
)

#: the oscillating rating of a roller bearing below theta_crit, C_osc = C (180 deg / phi)^(2/9) Z^0.028
#: (Rumbarger & Jones 1968, NREL DG03; balls would take 3/10 and 0.033)
OSCILLATION_ANGLE_EXPONENT: float = 2.0 / 9.0
OSCILLATION_ROLLER_COUNT_EXPONENT: float = 0.028
QUARTER_TURN_RAD: float = 0.5 * math.pi     # 90 deg: 90 deg / theta = 180 deg / phi (phi = 2 theta)


def critical_amplitude_rad(roller_count: int, diameter_ratio: float = 0.0) -> float:
    """theta_crit = 2 pi / (Z (1 + gamma)) [rad], amplitude (half the swing) (see module doc)."""
    return 2.0 * math.pi / (roller_count * (1.0 + diameter_ratio))


def oscillation_life_factor(amplitude_rad: float, critical_rad: float, roller_count: int) -> float:
    """a_osc = L_osc [cycles] / L10 [revolutions] of a row of `roller_count` rollers: 90 deg / theta at or above
    theta_crit (angle equivalence), ((90 deg / theta)^(2/9) Z^0.028)^(10/3) = (C_osc / C)^p below it
    (Rumbarger & Jones 1968 as NREL DG03 rates an oscillating roller bearing; see the module doc)."""
    if not amplitude_rad > 0.0:
        raise ValueError(f"oscillation amplitude must be > 0, got {amplitude_rad!r}")
    ratio = QUARTER_TURN_RAD / amplitude_rad
    if amplitude_rad >= critical_rad:
        return ratio
    rating_ratio = ratio ** OSCILLATION_ANGLE_EXPONENT * roller_count ** OSCILLATION_ROLLER_COUNT_EXPONENT
    return rating_ratio ** ROLLER_LIFE_EXPONENT


class SlewingFatigue:
    """Miner damage per row from interleaved load samples and axis angles; static safety of the worst sample.

    ``on_loads(F_a, F_r, M_T)`` sets the load in force (and judges its static safety); ``on_angle(phi, t_s)``
    adds the travel since the previous angle at that load. ``limiting_curve``: the manufacturer's static
    limiting load curve as (F_a values ascending [N], M_lim values [N m]) or None.
    """

    def __init__(self, ratings: SlewingRatings, reversal_deadband_rad: float = 1e-3,
                 limiting_curve: tuple[tuple[float, ...], tuple[float, ...]] | None = None) -> None:
        self.ratings = ratings
        self.deadband_rad = float(reversal_deadband_rad)
        self.limiting_curve = limiting_curve
        self.roller_count = {"upper_axial": ratings.roller_count, "lower_axial": ratings.roller_count,
                             "radial": ratings.radial_roller_count}
        self.critical_rad = {row: critical_amplitude_rad(z) for row, z in self.roller_count.items()}
        self.rate_per_rad = dict.fromkeys(ROWS, 0.0)   # 1 / (2 pi L10) at the load in force
        self.damage = dict.fromkeys(ROWS, 0.0)          # closed strokes
        self.stroke_weighted = dict.fromkeys(ROWS, 0.0)  # open stroke: sum of new ground x rate
        self.stroke_travel_rad = 0.0
        self.start_rad: float | None = None
        self.extreme_rad = 0.0
        self.direction = 0
        self.last_rad: float | None = None
        self.first_t_s: float | None = None
        self.last_t_s: float | None = None
        self.strokes = 0
        self.small_strokes = 0
        self.min_static_safety = math.inf
        self.worst_static: dict[str, Any] | None = None   # the worst sample since the start (the keys)
        self.period_static: dict[str, Any] | None = None  # the worst since the last report (the level)
        self.load_samples = 0

    # ---- loads ---------------------------------------------------------------------------------------
    def on_loads(self, axial_load_n: float, radial_load_n: float, tilting_moment_nm: float) -> None:
        """The load in force from now on (ValueError on a non-finite value)."""
        loads = row_equivalent_loads(self.ratings, axial_load_n, radial_load_n, tilting_moment_nm)
        per_rev = damage_per_revolution(self.ratings, loads)
        self.rate_per_rad = {row: per_rev[row] / (2.0 * math.pi) for row in ROWS}
        self.load_samples += 1
        safety = static_safety_factors(self.ratings, loads)
        row = min(safety, key=safety.get)
        curve = math.inf
        if self.limiting_curve is not None:
            curve = limiting_curve_safety(*self.limiting_curve, axial_load_n, tilting_moment_nm)
        sample = {"row": row, "static_safety": safety[row], "static_load_n": loads.static_n[row],
                  "static_capacity_n": self.ratings.static_n[row], "limiting_curve_safety": curve,
                  "axial_load_n": float(axial_load_n), "radial_load_n": float(radial_load_n),
                  "tilting_moment_nm": float(tilting_moment_nm)}
        if min(safety[row], curve) < self.min_static_safety:
            self.min_static_safety, self.worst_static = min(safety[row], curve), sample
        if self.period_static is None or min(safety[row], curve) < min(
                self.period_static["static_safety"], self.period_static["limiting_curve_safety"]):
            self.period_static = sample

    # ---- angle ---------------------------------------------------------------------------------------
    def on_angle(self, angle_rad: float, t_s: float | None = None) -> None:
        """One axis angle [rad] (and its stamp [s]); ValueError when not finite."""
        angle = float(angle_rad)
        if not math.isfinite(angle):
            raise ValueError(f"axis angle must be finite, got {angle_rad!r}")
        if t_s is not None:
            self.first_t_s = t_s if self.first_t_s is None else self.first_t_s
            self.last_t_s = t_s
        if self.last_rad is None:
            self.last_rad = self.start_rad = self.extreme_rad = angle
            return
        step = angle - self.last_rad
        self.last_rad = angle
        if step == 0.0:
            return
        if self.direction == 0:
            self.direction = 1 if step > 0 else -1
        beyond = self.direction * (angle - self.extreme_rad)
        if beyond > 0.0:                       # new ground: the stroke goes on at the load in force
            self._add(beyond)
            self.extreme_rad = angle
        elif -beyond > self.deadband_rad:      # back by more than the deadband: a reversal
            self._close_stroke()
            self.direction = -self.direction
            self.start_rad, self.extreme_rad = self.extreme_rad, angle
            self._add(-beyond)

    def _add(self, travel_rad: float) -> None:
        self.stroke_travel_rad += travel_rad
        for row in ROWS:
            self.stroke_weighted[row] += travel_rad * self.rate_per_rad[row]

    def _close_stroke(self) -> None:
        """The stroke start -> extreme ends: its damage by the form its amplitude calls for."""
        amplitude = 0.5 * abs(self.extreme_rad - self.start_rad)
        small = False
        for row in ROWS:
            if amplitude >= self.critical_rad[row] or self.stroke_travel_rad == 0.0:
                self.damage[row] += self.stroke_weighted[row]
                continue
            small = True
            mean_per_rev = self.stroke_weighted[row] * 2.0 * math.pi / self.stroke_travel_rad
            self.damage[row] += 0.5 * mean_per_rev / oscillation_life_factor(
                amplitude, self.critical_rad[row], self.roller_count[row])
        self.strokes += 1
        self.small_strokes += int(small)
        self.stroke_weighted = dict.fromkeys(ROWS, 0.0)
        self.stroke_travel_rad = 0.0

    # ---- persistence ---------------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """The damage per row and the angle-counting state (the stroke in progress, the load in force): a
        restored instance continues exactly as the uninterrupted one. The per-period worst is not kept."""
        return {name: (dict(getattr(self, name)) if name in ROW_FIELDS else getattr(self, name))
                for name in STATE_FIELDS}

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state`` (of :meth:`state`); ValueError (one line) when it is malformed, and then
        nothing is changed."""
        check_fatigue_state(state)
        for name in STATE_FIELDS:
            value = state[name]
            setattr(self, name, {row: float(value[row]) for row in ROWS} if name in ROW_FIELDS else value)

    # ---- report --------------------------------------------------------------------------------------
    def row_damage(self) -> dict[str, float]:
        """Miner sum per row: closed strokes + the open one by angle equivalence."""
        return {row: self.damage[row] + self.stroke_weighted[row] for row in ROWS}

    def report(self) -> tuple[Level, str, dict[str, Any]]:
        """Level, message and the status keys (damage and remaining life per row, governing row, S_0).

        The keys hold the worst static sample since the start; the level judges the worst since the last
        report (a past overload stays visible through the alarm latch, not as a level for ever)."""
        damage = self.row_damage()
        governing = max(ROWS, key=lambda r: damage[r])
        elapsed = (self.last_t_s - self.first_t_s) if self.first_t_s is not None else 0.0
        values: dict[str, Any] = {}
        for row in ROWS:
            values[f"fatigue_damage_{row}"] = damage[row]
            values[f"dynamic_capacity_{row}_n"] = self.ratings.dynamic_n[row]
            values[f"static_capacity_{row}_n"] = self.ratings.static_n[row]
            life = math.inf if damage[row] <= 0.0 or elapsed <= 0.0 else elapsed * (1.0 - damage[row]) / damage[row]
            values[f"fatigue_remaining_life_{row}_h"] = life / 3600.0
        values.update(fatigue_governing_row=governing, oscillation_strokes=self.strokes,
                      oscillation_strokes_below_critical=self.small_strokes,
                      static_safety_factor=self.min_static_safety,
                      static_safety_row=(self.worst_static or {}).get("row", ""),
                      limiting_curve_safety=(self.worst_static or {}).get("limiting_curve_safety", math.inf))
        return self._level(damage[governing], governing, values)

    def _level(self, governing_damage: float, governing: str, values: dict[str, Any]) -> tuple[Level, str, dict]:
        worst, self.period_static = self.period_static, None
        if worst is not None and worst["static_safety"] < 1.0:
            return ERROR, (f"static overload of the {worst['row']} row: P0 = {worst['static_load_n']:.4g} N > "
                           f"C0 = {worst['static_capacity_n']:.4g} N (S0 = {worst['static_safety']:.3g})"), values
        if worst is not None and worst["limiting_curve_safety"] < 1.0:
            return ERROR, (f"load outside the limiting load curve (F_a = {worst['axial_load_n']:.4g} N, "
                           f"M_T = {worst['tilting_moment_nm']:.4g} N m, safety "
                           f"{worst['limiting_curve_safety']:.3g})"), values
        if governing_damage >= 1.0:
            return ERROR, f"fatigue damage of the {governing} row {governing_damage:.3g} >= 1 (L10 reached)", values
        return OK, f"fatigue damage {governing_damage:.3g} ({governing} row governs)", values


#: per-row sums (non-negative) and the scalars of the counting state; persisted by SlewingFatigue.state()
ROW_FIELDS = ("damage", "stroke_weighted", "rate_per_rad")
_COUNTS = ("strokes", "small_strokes", "load_samples")
_OPTIONAL_ANGLES = ("start_rad", "last_rad", "first_t_s", "last_t_s")
STATE_FIELDS = (*ROW_FIELDS, "stroke_travel_rad", "extreme_rad", "direction", *_OPTIONAL_ANGLES, *_COUNTS,
                "min_static_safety", "worst_static")


def _finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_fatigue_state(state: Any) -> None:
    """ValueError (one line naming the field) unless ``state`` is a complete SlewingFatigue state: every row's
    damage, open-stroke sum and rate finite and >= 0, counts non-negative integers, direction -1/0/+1, angles
    and stamps finite (or None before the first sample), the worst static safety > 0 (inf before any load)."""
    if not isinstance(state, dict):
        raise ValueError(f"slewing fatigue state must be a mapping, got {type(state).__name__}")
    missing = [name for name in STATE_FIELDS if name not in state]
    if missing:
        raise ValueError(f"slewing fatigue state lacks {', '.join(missing)}")
    for name in ROW_FIELDS:
        rows = state[name]
        if not isinstance(rows, dict) or set(rows) != set(ROWS):
            raise ValueError(f"{name} must hold the rows {', '.join(ROWS)}, got {rows!r}"[:200])
        bad = [row for row in ROWS if not (_finite_number(rows[row]) and rows[row] >= 0.0)]
        if bad:
            raise ValueError(f"{name} of the {bad[0]} row must be finite and >= 0, got {rows[bad[0]]!r}")
    if not (_finite_number(state["stroke_travel_rad"]) and state["stroke_travel_rad"] >= 0.0):
        raise ValueError(f"stroke_travel_rad must be finite and >= 0, got {state['stroke_travel_rad']!r}")
    if not _finite_number(state["extreme_rad"]):
        raise ValueError(f"extreme_rad must be finite, got {state['extreme_rad']!r}")
    if state["direction"] not in (-1, 0, 1) or isinstance(state["direction"], bool):
        raise ValueError(f"direction must be -1, 0 or 1, got {state['direction']!r}")
    for name in _OPTIONAL_ANGLES:
        if state[name] is not None and not _finite_number(state[name]):
            raise ValueError(f"{name} must be finite or null, got {state[name]!r}")
    for name in _COUNTS:
        value = state[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    safety = state["min_static_safety"]
    if isinstance(safety, bool) or not isinstance(safety, (int, float)) or not safety > 0.0:
        raise ValueError(f"min_static_safety must be > 0, got {safety!r}")
    if state["worst_static"] is not None and not isinstance(state["worst_static"], dict):
        raise ValueError(f"worst_static must be a mapping or null, got {type(state['worst_static']).__name__}")
