"""A model file loaded over a running axis monitor (pure: no ROS, no I/O): the live ``~/load_model`` service and
the offline ``replay --model-file --model-at`` hand over the same way (one function: the same numbers).

The guides' states (wear, measurements, duty, fit test) are handed to guides built with the new parameters,
exactly as a restart with the file would restore them (GuideWear.restore: the K prior, A0 and the measurement
noise from the parameters; a new model digest starts the fit test anew, which clears ``broken`` and its WARN);
the maintenance baselines are applied again, the input gate and its counts are kept.

``model_from_stamp_s`` > 0 (``diagnose --since``): the model describes the machine from that stamp on. Each
guide is re-anchored at its last measurement a at or before it: the straightness is A_a + K (g - g_a), with
A_a the file's ``straightness_initial_m`` and g Eq. 7's straightness per unit K, linear in the Archard work W
(seed 000 Eq. 7: g = 2 W / (H b (l_min + l_max))), so g - g_a is g of W - W_a: the work counts from W_a
(``archard_work_nm`` and each later measurement's work less W_a: the wear volume reported is then the volume
since the anchor), and the measurements up to a are folded into the file's K prior (they are what the file's
K was fitted on). Only the plain Eq. 7 model (no effects) can be re-anchored so; another is refused. The model
already in force (the same digest, fit_watch.model_key: K, its prior, A0, the noise and the effects) is not
anchored again: loading the same file twice changes nothing.
"""
from __future__ import annotations

from typing import Any

from guide_health.models.wear.calibration import WearCoefficientEstimator
from guide_health.models.wear.guide import GuideWear
from guide_health.models.wear.maintenance import apply_baseline


class ModelLoadError(ValueError):
    """A model that cannot be loaded over this monitor (one line: why)."""


def anchor_index(guide: GuideWear, from_t_ns: int) -> int:
    """The index of the guide's last measurement stamped at or before ``from_t_ns`` (ModelLoadError: none)."""
    times = guide.estimator.measurement_t_ns
    i = sum(1 for t in times if t <= from_t_ns) - 1
    if i < 0:
        raise ModelLoadError("model_from_stamp_s is before the guide's first straightness measurement: "
                             "nothing to anchor the model at")
    return i


def check_anchorable(params: Any) -> None:
    """A model with a start stamp must be the plain Eq. 7 model (module text)."""
    if params.model_from_stamp_s > 0 and (params.effects or params.straightness_model != "eq7"):
        raise ModelLoadError("a model with model_from_stamp_s is re-anchored on Eq. 7 without effects; this one "
                             f"has effects {params.effects!r}, straightness_model {params.straightness_model!r}")


def anchor(guide: GuideWear, from_t_ns: int) -> None:
    """Re-anchor ``guide`` (already carrying the new parameters) at its measurement at or before ``from_t_ns``."""
    i = anchor_index(guide, from_t_ns)
    old = guide.estimator
    work_a = old.measurement_work_nm[i]
    loss_a = old.measurement_loss_per_k_m[i]
    guide.integrator.archard_work_nm = max(guide.integrator.archard_work_nm - work_a, 0.0)
    p = guide.params
    est = WearCoefficientEstimator(prior_wear_coefficient=p.wear_coefficient,
                                   prior_rel_sd=p.wear_coefficient_prior_rel_sd, noise_sd_m=p.straightness_noise_m,
                                   straightness_initial_m=p.straightness_initial_m)
    for j in range(i + 1, old.count):
        est.add(old.measurement_t_ns[j], old.measurement_m[j], old.measurement_loss_per_k_m[j] - loss_a,
                old.measurement_work_nm[j] - work_a)
    guide.estimator = est


def loaded_guides(axis, params: Any) -> dict[str, GuideWear]:
    """New guides of ``axis`` with ``params`` and the present states (module text); the axis is not changed."""
    check_anchorable(params)
    guides = {}
    for name in axis.guides:
        guide = GuideWear(params)
        guide.restore(axis.guide_state(name))
        if name in axis.baselines:
            apply_baseline(guide, axis.baselines[name])
        # the same model again (its digest already the guide's): anchored when it was first loaded
        if params.model_from_stamp_s > 0 and guide.fit_watch.model_key != axis.guides[name].fit_watch.model_key:
            anchor(guide, int(round(params.model_from_stamp_s * 1e9)))
            guide.fit_watch.clear(guide.last_measurement_t_ns)
        guides[name] = guide
    return guides


def load_model(axis, params: Any) -> None:
    """Load the model of ``params`` (the axis's frozen parameters with the file merged) over ``axis``: all
    guides or none (ModelLoadError, the axis unchanged)."""
    guides = loaded_guides(axis, params)
    axis.params = params
    axis.guides = guides
