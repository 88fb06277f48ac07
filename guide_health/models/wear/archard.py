"""Sliding-guide wear and precision retention (seed 000).

Closed forms (seed 000):
    Eq. 7   V = A b (l_max + l_min) / 2           wear volume <-> straightness loss A
    Eq. 10  V = K W v t / H                       Archard wear volume
    Eq. 11  A = 2 K W v t / ((l_max + l_min) b H) straightness loss after sliding time t
    Eq. 12  t = A_max (l_max + l_min) b H / (2 K W v)   precision life

The integrator (:class:`WearIntegrator`) accumulates the K-free *Archard work* ``sum W |dx|`` [N m] from
axis position and load samples (Eq. 10 in differential form, dV = K W ds / H), so the wear coefficient
K can be updated from measurements afterwards without re-integrating (every wear quantity is linear in K).
It serves the live node sample by sample (``advance``) and offline replay over whole arrays
(``advance_many``), with identical arithmetic: the offline path is the same formulas vectorised.
Callers pass only samples accepted by :mod:`guide_health.models.wear.input_rules`.

Two straightness models:
- ``eq7``: seed 000 Eq. 7 with l_min / l_max from parameters or from the observed strokes.
- ``profile``: the wear depth along the rail under a slider of length L_s with uniform pressure
  W / (b L_s): h(u) = K / (H b) * w(u), where w(u) is the slider-averaged load-weighted traversal,
  w(u) = (1 / L_s) * integral rho(s) 1{|s - u| < L_s / 2} ds, and rho(s) = sum_i W_i 1{s in segment i}.
  The straightness is the minimum-zone width of the worn profile (two parallel lines enclosing it).
  For a symmetric stroke distribution both models agree (the seed's j = 1/2 step in Eq. 5 is exact for a
  symmetric distribution); for a skewed one Eq. 7 is biased (see test_wear_model.py).

The minimum-zone width and the stroke tracking are in :mod:`guide_health.models.wear.straightness`.

The straightness reported is A0 + A_wear: the initial form error and the wear dip are added, which is
the seed's convention (its Fig. 9 curve starts at A0 = 15 um) and an upper bound for the minimum zone.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from guide_health.models.wear.running_time import RunningClock
from guide_health.models.wear.straightness import StrokeTracker, minimum_zone_straightness_m

# ---------------------------------------------------------------------------------------------
# Closed forms
# ---------------------------------------------------------------------------------------------


def archard_wear_volume_m3(wear_coefficient: float, load_n: float, sliding_distance_m: float,
                           hardness_pa: float) -> float:
    """Archard wear volume V = K W s / H [m^3], s = v t.  # seed 000 Eq. 10"""
    return wear_coefficient * load_n * sliding_distance_m / hardness_pa


def straightness_from_wear_volume_m(wear_volume_m3: float, contact_width_m: float,
                                    stroke_min_m: float, stroke_max_m: float) -> float:
    """Straightness loss A = 2 V / (b (l_max + l_min)) [m].  # seed 000 Eq. 7"""
    return 2.0 * wear_volume_m3 / (contact_width_m * (stroke_max_m + stroke_min_m))


def straightness_loss_eq11_m(wear_coefficient: float, load_n: float, speed_m_s: float, time_s: float,
                             stroke_min_m: float, stroke_max_m: float, contact_width_m: float,
                             hardness_pa: float) -> float:
    """A = 2 K W v t / ((l_max + l_min) b H) [m].  # seed 000 Eq. 11"""
    return (2.0 * wear_coefficient * load_n * speed_m_s * time_s
            / ((stroke_max_m + stroke_min_m) * contact_width_m * hardness_pa))


def precision_life_eq12_s(straightness_allowed_m: float, stroke_min_m: float, stroke_max_m: float,
                          contact_width_m: float, hardness_pa: float, wear_coefficient: float,
                          load_n: float, speed_m_s: float) -> float:
    """t = A_max (l_max + l_min) b H / (2 K W v) [s].  # seed 000 Eq. 12"""
    return (straightness_allowed_m * (stroke_max_m + stroke_min_m) * contact_width_m * hardness_pa
            / (2.0 * wear_coefficient * load_n * speed_m_s))


# ---------------------------------------------------------------------------------------------
# Sliding deadband: standstill encoder noise is not sliding
# ---------------------------------------------------------------------------------------------


def _play_operator_m(position_m: np.ndarray, previous_m: float, half_width_m: float) -> np.ndarray:
    """Play (backlash) operator y_k = clamp(y_{k-1}, x_k - d, x_k + d), y_{-1} = ``previous_m``.

    Vectorised: a composition of clamps is a clamp, so the prefix compositions come from a Hillis-Steele
    scan of (lo, hi) pairs; an element leaves the scan once its composition is a constant (a step
    |dx| > 2 d: every sample of steady motion) or covers the whole prefix, so the scan only runs long over
    standstills.
    """
    lo = position_m - half_width_m
    hi = position_m + half_width_m
    open_ = np.arange(1, position_m.size)
    shift = 1
    while open_.size:
        j = open_ - shift
        lo_i, hi_i = lo[open_], hi[open_]
        new_lo = np.clip(lo[j], lo_i, hi_i)
        new_hi = np.clip(hi[j], lo_i, hi_i)
        lo[open_], hi[open_] = new_lo, new_hi
        shift *= 2
        open_ = open_[(open_ >= shift) & (new_lo < new_hi)]
    return np.clip(previous_m, lo, hi)


def sliding_positions_m(position_m: np.ndarray, previous_m: float, previous_direction: int,
                        deadband_m: float) -> tuple[np.ndarray, int]:
    """Positions that count as sliding, and the direction of motion at the last one.

    A reversal of the direction of motion counts only once the axis has gone back by more than
    ``deadband_m`` (h) from its extreme; then the whole way back counts. Jitter of less than h at a
    standstill or in a reversal is not sliding (encoder noise and resolution). Clean motion is unchanged:
    y = x whenever the axis moves on in its direction or has turned by more than h.

    It is the play operator of half-width h/2 (P) shifted by h/2 in its direction of motion:
    y_k = P_k + (h/2) dir_k, dir_k the sign of the last change of P. ``previous_m`` and
    ``previous_direction`` (+1, -1, 0 = none yet) are the state after the previous sample (y and dir).
    Every path that turns axis samples into sliding (the live integrator, replay, the duty cells of
    ``diagnose``) calls this function.
    """
    x = np.asarray(position_m, dtype=float)
    if deadband_m <= 0.0 or x.size == 0:
        return x, previous_direction
    half = 0.5 * deadband_m
    play = _play_operator_m(x, previous_m - half * previous_direction, half)
    step = np.sign(np.diff(np.concatenate(([previous_m - half * previous_direction], play))))
    moved = np.flatnonzero(step)
    last = np.full(x.size, -1)
    last[moved] = moved
    last = np.maximum.accumulate(last)
    direction = np.where(last >= 0, step[np.maximum(last, 0)], previous_direction)
    y = np.where(direction != 0, play + half * direction, previous_m)
    return y, int(direction[-1])


def sliding_position_m(position_m: float, previous_m: float, previous_direction: int,
                       deadband_m: float) -> tuple[float, int]:
    """:func:`sliding_positions_m` for one sample (the live path: no array per sample, same rule)."""
    if deadband_m <= 0.0:
        return position_m, previous_direction
    half = 0.5 * deadband_m
    play_before = previous_m - half * previous_direction
    play = min(max(play_before, position_m - half), position_m + half)
    direction = previous_direction if play == play_before else (1 if play > play_before else -1)
    return (play + half * direction if direction != 0 else previous_m), direction


# ---------------------------------------------------------------------------------------------
# Wear integrator
# ---------------------------------------------------------------------------------------------


@dataclass
class WearGeometry:
    """Guide geometry and material of the worn surface (SI)."""

    contact_width_m: float            # b
    hardness_pa: float                # H
    stroke_min_m: float = 0.0         # l_min, 0 = estimate from strokes
    stroke_max_m: float = 0.0         # l_max, 0 = estimate from strokes
    slider_length_m: float = 0.100    # L_s (profile model)
    rail_start_m: float = -0.100
    rail_length_m: float = 0.500
    profile_bin_m: float = 0.001
    straightness_model: str = "eq7"   # eq7 | profile
    stroke_detect_min_m: float = 0.005
    duty_window_s: float = 3600.0     # of running time (models/wear/running_time.py)
    idle_after_s: float = 300.0       # a longer pause is idle, not running
    utilisation_window_days: float = 7.0
    sliding_deadband_m: float = 0.0   # reversals shorter than this are not sliding (sliding_positions_m)

    @classmethod
    def from_params(cls, params: Any) -> WearGeometry:
        """The geometry of a guide's frozen wear_monitor parameters (the fields of the same names)."""
        return cls(**{k: getattr(params, k) for k in cls.__dataclass_fields__ if hasattr(params, k)})

    def bin_centres_m(self) -> np.ndarray:
        n = max(1, int(round(self.rail_length_m / self.profile_bin_m)))
        return self.rail_start_m + (np.arange(n) + 0.5) * self.profile_bin_m


DUTY_BUCKETS = 60


def _ramp_sum(points: np.ndarray, starts: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """sum_i w_i * max(p - s_i, 0) for every p in ``points`` (sorted-prefix sums, O((n+m) log n))."""
    return _ramp_sums(starts, weights, points)[0]


def _ramp_sums(starts: np.ndarray, weights: np.ndarray, *point_sets: np.ndarray) -> list[np.ndarray]:
    """:func:`_ramp_sum` at several point sets, sorting the starts once (the same arithmetic)."""
    order = np.argsort(starts, kind="stable")
    s = starts[order]
    w = weights[order]
    cw = np.concatenate(([0.0], np.cumsum(w)))
    cws = np.concatenate(([0.0], np.cumsum(w * s)))
    out = []
    for points in point_sets:
        k = np.searchsorted(s, points, side="right")
        out.append(cw[k] * points - cws[k])
    return out


@dataclass
class WearIntegrator:
    """K-free Archard integration of a guide's motion and load (seed 000 Eq. 10 in differential form).

    State (all persisted): last sample (t, x), sliding distance, Archard work sum W |dx| [N m],
    slider-averaged work along the rail w(u) [N] (profile model), strokes, duty buckets.
    """

    geometry: WearGeometry
    last_t_ns: int | None = None
    last_position_m: float = math.nan        # the last sliding position (sliding_positions_m)
    sliding_direction: int = 0               # +1 / -1 / 0 (none yet) after the last sample
    first_t_ns: int | None = None
    sliding_distance_m: float = 0.0
    archard_work_nm: float = 0.0             # sum W |dx|
    profile_work_n: np.ndarray = field(default=None)   # w(u) at bin centres [N]
    strokes: StrokeTracker = field(default=None)
    duty_bucket_index: list = field(default_factory=list)
    duty_bucket_work_nm: list = field(default_factory=list)
    samples: int = 0
    clock: RunningClock = field(default=None)          # running time: the duty buckets' time base
    # called with every sliding segment (t_start_ns, t_end_ns, xa, xb, load_n, s_start_m arrays) when set:
    # the live wear effects (models/wear/effect_wear.py); not persisted
    segment_sink: object = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.profile_work_n is None:
            self.profile_work_n = np.zeros(self.geometry.bin_centres_m().size)
        if self.strokes is None:
            self.strokes = StrokeTracker(self.geometry.stroke_detect_min_m)
        self._bins = self.geometry.bin_centres_m()
        if self.clock is None:
            self.clock = RunningClock(self.geometry.idle_after_s, self.geometry.utilisation_window_days)

    # --- integration -------------------------------------------------------------------------
    @property
    def duty_bucket_s(self) -> float:
        return self.geometry.duty_window_s / DUTY_BUCKETS

    @property
    def duty_buckets_kept(self) -> int:
        """Buckets kept: the window's, and those an idle axis still reports from (the dwell counted as
        running before a pause turned idle may add up to idle_after_s of empty buckets after its last motion)."""
        return DUTY_BUCKETS + int(math.ceil(self.geometry.idle_after_s / self.duty_bucket_s)) + 1

    def _add_duty(self, bucket: int, work_nm: float) -> None:
        if self.duty_bucket_index and self.duty_bucket_index[-1] == bucket:
            self.duty_bucket_work_nm[-1] += work_nm
        else:
            self.duty_bucket_index.append(bucket)
            self.duty_bucket_work_nm.append(work_nm)
            while self.duty_bucket_index and self.duty_bucket_index[0] <= bucket - self.duty_buckets_kept:
                self.duty_bucket_index.pop(0)
                self.duty_bucket_work_nm.pop(0)

    def advance(self, t_ns: int, position_m: float, load_n: float) -> None:
        """One axis sample: slide from the last position to ``position_m`` under ``load_n`` (latest load).

        ``load_n`` NaN means no load known yet: the distance counts, the wear does not.
        Callers validate input (finite position, time strictly increasing, load >= 0).
        """
        x = float(position_m)
        if self.last_t_ns is None:
            self.first_t_ns = int(t_ns)
            self.clock.advance(t_ns, False)
        else:
            x, self.sliding_direction = sliding_position_m(x, self.last_position_m, self.sliding_direction,
                                                           self.geometry.sliding_deadband_m)
            tau_ns = self.clock.advance(t_ns, x != self.last_position_m)
            self._segment(t_ns, tau_ns, self.last_position_m, x, load_n)
        self.strokes.update(x)
        self.last_t_ns = int(t_ns)
        self.last_position_m = x
        self.samples += 1

    def _segment(self, t_ns: int, tau_ns: int | None, xa: float, xb: float, load_n: float) -> None:
        """The slide from ``xa`` to ``xb`` ending at ``t_ns`` (running clock ``tau_ns``, None: idle)."""
        ds = abs(xb - xa)
        if self.segment_sink is not None and ds > 0.0:
            self.segment_sink(np.array([self.last_t_ns]), np.array([t_ns]), np.array([xa]), np.array([xb]),
                              np.array([load_n]), np.array([self.sliding_distance_m]))
        self.sliding_distance_m += ds
        if ds == 0.0 or not load_n > 0.0:
            if not math.isnan(load_n) and tau_ns is not None:
                self._add_duty(int(tau_ns * 1e-9 // self.duty_bucket_s), 0.0)
            return
        work = load_n * ds
        self.archard_work_nm += work
        self._add_duty(int(tau_ns * 1e-9 // self.duty_bucket_s), work)
        # profile: w(u) += W / L_s * |[a, b] ∩ [u - L_s/2, u + L_s/2]| on the bins it touches
        half = 0.5 * self.geometry.slider_length_m
        a, b = (xa, xb) if xa <= xb else (xb, xa)
        lo = np.searchsorted(self._bins, a - half, side="left")
        hi = np.searchsorted(self._bins, b + half, side="right")
        if hi > lo:
            u = self._bins[lo:hi]
            overlap = np.minimum(b, u + half) - np.maximum(a, u - half)
            self.profile_work_n[lo:hi] += (load_n / self.geometry.slider_length_m) * np.clip(overlap, 0.0, None)

    def advance_many(self, t_ns: np.ndarray, position_m: np.ndarray, load_n: np.ndarray) -> None:
        """Vectorised :meth:`advance` over arrays (same arithmetic, same results to rounding)."""
        t_ns = np.asarray(t_ns, dtype=np.int64)
        x = np.asarray(position_m, dtype=float)
        w = np.asarray(load_n, dtype=float)
        if x.size == 0:
            return
        deadband = self.geometry.sliding_deadband_m
        if self.last_t_ns is None:
            self.first_t_ns = int(t_ns[0])
            y, self.sliding_direction = sliding_positions_m(x[1:], float(x[0]), 0, deadband)
            x = xs = np.concatenate((x[:1], y))
            seg_t = t_ns[1:]
            seg_w = w[1:]
        else:
            x, self.sliding_direction = sliding_positions_m(x, self.last_position_m, self.sliding_direction,
                                                            deadband)
            xs = np.concatenate(([self.last_position_m], x))
            seg_t = t_ns
            seg_w = w
        xa, xb = xs[:-1], xs[1:]
        ds = np.abs(xb - xa)
        tau, running = self.clock.advance_many(t_ns, np.concatenate(([False] * (x.size - ds.size), ds > 0)))
        tau, running = tau[tau.size - ds.size:], running[running.size - ds.size:]
        if self.segment_sink is not None:
            moving = ds > 0
            t_start = t_ns[:-1] if self.last_t_ns is None else np.concatenate(([self.last_t_ns], seg_t[:-1]))
            s_start = self.sliding_distance_m + np.cumsum(ds) - ds
            self.segment_sink(t_start[moving], seg_t[moving], xa[moving], xb[moving], seg_w[moving], s_start[moving])
        self.sliding_distance_m += float(ds.sum())
        loaded = (ds > 0) & (seg_w > 0)
        work = np.where(loaded, np.nan_to_num(seg_w) * ds, 0.0)
        self.archard_work_nm += float(work.sum())
        # duty buckets
        counted = ~np.isnan(seg_w) & running
        if counted.any():
            buckets = (tau[counted] * 1e-9 // self.duty_bucket_s).astype(np.int64)
            first_kept = buckets[-1] - self.duty_buckets_kept + 1
            keep = buckets >= first_kept
            uniq, inverse = np.unique(buckets[keep], return_inverse=True)
            sums = np.bincount(inverse, weights=work[counted][keep], minlength=uniq.size)
            for bucket, s in zip(uniq.tolist(), sums.tolist()):
                self._add_duty(int(bucket), float(s))
        # profile: w(u) = (1/L_s) * sum_i W_i |[a_i, b_i] ∩ [u - L_s/2, u + L_s/2]|
        if loaded.any():
            a = np.minimum(xa, xb)[loaded]
            b = np.maximum(xa, xb)[loaded]
            wl = seg_w[loaded]
            half = 0.5 * self.geometry.slider_length_m
            up, down = self._bins + half, self._bins - half
            # |[a,b] ∩ (-inf, p]| summed with weights = ramp(p - a) - ramp(p - b)
            (a_up, a_down), (b_up, b_down) = _ramp_sums(a, wl, up, down), _ramp_sums(b, wl, up, down)
            cover_up = a_up - b_up
            cover_down = a_down - b_down
            self.profile_work_n += (cover_up - cover_down) / self.geometry.slider_length_m
            # w(u) >= 0: the ramp-sum differences leave rounding residues of either sign (-4e-10 N seen
            # where nothing was added), which a saved state must not carry
            np.maximum(self.profile_work_n, 0.0, out=self.profile_work_n)
        self.strokes.update_many(x)
        self.last_t_ns = int(t_ns[-1])
        self.last_position_m = float(x[-1])
        self.samples += int(x.size)

    # --- derived quantities (K-free, per unit K) ------------------------------------------------
    def stroke_range_m(self) -> tuple[float, float]:
        g = self.geometry
        if g.stroke_min_m > 0 and g.stroke_max_m > 0:
            return g.stroke_min_m, g.stroke_max_m
        return self.strokes.stroke_range_m()

    def wear_volume_per_k_m3(self) -> float:
        """V / K = sum W ds / H [m^3].  # seed 000 Eq. 10"""
        return self.archard_work_nm / self.geometry.hardness_pa

    def profile_depth_per_k_m(self) -> np.ndarray:
        """Wear depth along the rail per unit K: h(u) / K = w(u) / (H b) [m]."""
        return self.profile_work_n / (self.geometry.hardness_pa * self.geometry.contact_width_m)

    def straightness_loss_per_k_m(self) -> float:
        """Straightness loss A_wear / K [m] by the configured model (NaN when not yet defined)."""
        g = self.geometry
        if g.straightness_model == "profile":
            return minimum_zone_straightness_m(self._bins, -self.profile_depth_per_k_m())
        l_min, l_max = self.stroke_range_m()
        if not (l_min + l_max > 0):
            return math.nan
        return straightness_from_wear_volume_m(self.wear_volume_per_k_m3(), g.contact_width_m, l_min, l_max)

    def duty_work_rate_w(self) -> float:
        """Current duty W v averaged over the last ``duty_window_s`` of running time [N m/s = W] (Archard
        work rate; idle pauses do not count, models/wear/running_time.py)."""
        if self.last_t_ns is None or not self.duty_bucket_index:
            return math.nan
        t_now = self.clock.tau_now_ns * 1e-9
        bucket_now = int(t_now // self.duty_bucket_s)
        window_start = max(self.first_t_ns * 1e-9, (bucket_now - DUTY_BUCKETS + 1) * self.duty_bucket_s)
        span = t_now - window_start
        if span <= 0:
            return math.nan
        work = sum(w for i, w in zip(self.duty_bucket_index, self.duty_bucket_work_nm)
                   if i > bucket_now - DUTY_BUCKETS)
        return work / span

    def straightness_rate_per_k_m_s(self) -> float:
        """dA/dt per unit K at the current duty [m/s].

        dA/dt = (A_wear / V) dV/dt with dV/dt = K (W v) / H: exact for Eq. 7 (A/V = 2 / (b (l_max + l_min)))
        and, for the profile model, the growth of the present profile shape at the present duty.
        """
        volume = self.wear_volume_per_k_m3()
        rate = self.duty_work_rate_w()
        g = self.geometry
        if g.straightness_model == "eq7" or volume <= 0:
            l_min, l_max = self.stroke_range_m()
            if not (l_min + l_max > 0):
                return math.nan
            a_over_v = 2.0 / (g.contact_width_m * (l_min + l_max))
        else:
            a_over_v = self.straightness_loss_per_k_m() / volume
        return a_over_v * rate / g.hardness_pa

    # --- persistence ---------------------------------------------------------------------------
    def state(self) -> dict:
        return {
            "last_t_ns": self.last_t_ns,
            "last_position_m": self.last_position_m,
            "sliding_direction": self.sliding_direction,
            "first_t_ns": self.first_t_ns,
            "sliding_distance_m": self.sliding_distance_m,
            "archard_work_nm": self.archard_work_nm,
            "profile_work_n": self.profile_work_n.tolist(),
            "strokes": self.strokes.state(),
            "duty_bucket_index": list(self.duty_bucket_index),
            "duty_bucket_work_nm": list(self.duty_bucket_work_nm),
            "samples": self.samples,
            **self.clock.state(),
        }

    @classmethod
    def from_state(cls, geometry: WearGeometry, state: dict) -> WearIntegrator:
        profile = np.asarray(state["profile_work_n"], dtype=float)
        if profile.size != geometry.bin_centres_m().size:
            raise ValueError("saved wear profile does not match the rail bins of the parameters")
        clock = RunningClock(geometry.idle_after_s, geometry.utilisation_window_days)
        clock.restore(state, state["first_t_ns"], state["last_t_ns"])
        return cls(
            clock=clock,
            geometry=geometry,
            last_t_ns=state["last_t_ns"],
            last_position_m=state["last_position_m"],
            sliding_direction=int(state.get("sliding_direction", 0)),
            first_t_ns=state["first_t_ns"],
            sliding_distance_m=state["sliding_distance_m"],
            archard_work_nm=state["archard_work_nm"],
            profile_work_n=profile,
            strokes=StrokeTracker.from_state(state["strokes"]),
            duty_bucket_index=list(state["duty_bucket_index"]),
            duty_bucket_work_nm=list(state["duty_bucket_work_nm"]),
            samples=state["samples"],
        )
