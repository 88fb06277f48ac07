"""`guide-health diagnose` as it behaved before issue 15, on today's code: the reference of issue 15's
"diagnose time does not grow by more than 20 %" (bench_diagnose.py runs it beside today's diagnose).

    .venv/bin/python bench/diagnose_pre15.py BAG --params FILE [diagnose options]

Same reader, same fit machinery, same report, with what issue 15 added to the work switched off:
  - candidates: the seven effects of the library before issue 15 (effects.EFFECT_IDS), not the three duty
    effects wear_rate_change, lubrication_interval, load_along_rail;
  - thermal_drift with its one drift parameter (no fitted reference temperature / offset);
  - no backward pass after the forward search;
  - no refit of the named effects on every measurement for the model file, no forecast (model.yaml is
    written from the selection's final fit);
  - no sliding deadband (sliding_deadband_m = 0: the play operator is not run over the positions).
The near-tie report and the verdict on the residuals after the fit (one more residual analysis) stay: they
are cheap. Only for timing: the named effects are not those of a real pre-issue-15 run.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def install() -> None:
    from guide_health.analysis.discrepancy import model, selection, workflow
    from guide_health.models.wear.effects import EFFECT_IDS
    from guide_health.params import loader

    def available_effects(self):
        ids = [e for e in EFFECT_IDS]
        if self.temperature_change_k is None:
            ids.remove("thermal_drift")
        if self.a0_free:
            ids.remove("initial_offset")
        return ids

    specs_now = model._effect_specs

    def effect_specs(problem):
        specs = specs_now(problem)
        specs["thermal_drift"] = [s for s in specs["thermal_drift"] if s.name != "thermal_offset_m"]
        return specs

    class Pre15Problem(model.WearProblem):
        def fit(self, effects=(), warm=None):
            if self.heldout_mask.any() or warm is None:
                return super().fit(effects, warm)
            return warm                          # the model-file refit on every measurement: not done

    model.WearProblem.available_effects = available_effects
    model._effect_specs = effect_specs
    selection.backward_pass = lambda fit, result, threshold: None
    workflow.WearProblem = Pre15Problem
    workflow.fit_forecast = lambda *a, **k: {}
    wear_monitor_params = loader.wear_monitor_params

    def params_without_deadband(*args, **kwargs):
        params = wear_monitor_params(*args, **kwargs)
        params["sliding_deadband_m"] = 0.0
        return params

    from guide_health.cli import diagnose

    diagnose.wear_monitor_params = params_without_deadband


def main() -> int:
    from guide_health.cli.app import main as cli_main

    install()
    return cli_main(["diagnose", *sys.argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
