"""Strict JSON (io/json_text.py): every JSON the project writes parses under a parser that refuses NaN and
Infinity; a non-finite float is null ("unbounded or unknown"), a finite one is written exactly."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.fleet_prior import bag_log_k
from guide_health.cli.app import main
from guide_health.io.bag.metadata import run_metadata_json
from guide_health.io.outputs.json_text import json_text, number, plain
from guide_health.models.wear.calibration import Z90
from guide_health.params.typed import wear_axis_params

BENCH = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
REL_SD = 1.0            # prior sd of K relative to K: the 90 % interval's lower K bound K (1 - Z90) is < 0


def strict_loads(text: str):
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")
    return json.loads(text, parse_constant=refuse)


def test_json_text_writes_non_finite_floats_as_null_and_refuses_an_escape():
    value = {"a": math.inf, "b": -math.inf, "c": math.nan, "d": np.float32("nan"), "e": np.array([1.5, np.inf]),
             np.int64(3): (np.float64(0.1), 2), "f": "inf"}
    assert strict_loads(json_text(value)) == {"a": None, "b": None, "c": None, "d": None, "e": [1.5, None],
                                              "3": [0.1, 2], "f": "inf"}
    assert plain({"a": math.inf}, finite_only=False) == {"a": math.inf}           # text output keeps inf
    with pytest.raises(ValueError):                # a non-finite number past the rule is an error, not NaN text
        json_text({"x": object()}, default=lambda o: math.nan)
    assert run_metadata_json({"x": math.nan, "y": np.float64(2.0)}) == '{"x": null, "y": 2.0}'
    assert (number(None), number(None, math.inf), number(2)) == (pytest.approx(math.nan, nan_ok=True), math.inf, 2.0)


def test_replay_with_an_unbounded_remaining_life_writes_strict_json(tmp_path, capsys):
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.models.wear.precision import PrecisionMonitor
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    overlay = tmp_path / "wide_prior.yaml"
    overlay.write_text(f"wear_monitor:\n  ros__parameters:\n    wear_coefficient_prior_rel_sd: {REL_SD}\n")
    params = wear_monitor_params([BENCH, overlay])
    sim = dict(simulation_params(BENCH), duration_h=0.2, joint_state_rate_hz=5.0, load_rate_hz=2.0,
               measurement_interval_h=1.0)                                   # no measurement: the prior alone
    run = simulate_machine(params, sim, seed=1)
    write_machine_bag(run, tmp_path / "bag")
    monitor = PrecisionMonitor(wear_axis_params(params))
    monitor.process_run(run)
    truth = monitor.report()
    assert params["wear_coefficient"] * (1.0 - Z90 * REL_SD) < 0                # closed form: no upper life bound
    assert truth["remaining_life_h_high"] == math.inf and math.isfinite(truth["remaining_life_h"])
    argv = ["replay", str(tmp_path / "bag"), "--params", str(BENCH), "--params", str(overlay), "--no-plot"]
    assert main([*argv, "--out", str(tmp_path / "rep"), "--json"]) == 0
    printed = strict_loads(capsys.readouterr().out)
    saved = strict_loads((tmp_path / "rep" / "report.json").read_text())
    for out in (printed, saved):
        assert out["remaining_life_h_high"] is None
        for key, value in truth.items():                                     # the rule, key by key
            if isinstance(value, float):
                assert out[key] == (value if math.isfinite(value) else None), key
    assert main([*argv, "--out", str(tmp_path / "rep2")]) == 0
    assert ".. inf h)" in capsys.readouterr().out                          # the text report says inf


def test_fleet_prior_reads_null_as_no_information():
    prior = {"wear_coefficient": 4e-6, "wear_coefficient_prior_rel_sd": 0.5}
    replay = {"measurements": 5, "wear_coefficient": 4e-6, "wear_coefficient_low": None,
              "wear_coefficient_high": None}
    log_k, se = bag_log_k({"result": replay, "summary": {"command": "replay", "prior": prior}})
    assert math.isnan(log_k) and se == math.inf
    diagnosed = {"final": {"wear_coefficient": 4e-6, "wear_coefficient_std_error": None}}
    log_k, se = bag_log_k({"result": diagnosed, "summary": {"command": "diagnose", "prior": prior}})
    assert math.isnan(log_k) and se == math.inf
    diagnosed["final"]["wear_coefficient_std_error"] = 4e-7                    # a finite one: delta method
    assert bag_log_k({"result": diagnosed, "summary": {"command": "diagnose", "prior": prior}}) == \
        pytest.approx((math.log(4e-6), 0.1), rel=1e-12)
