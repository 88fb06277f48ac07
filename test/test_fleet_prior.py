"""The fleet prior (models/fleet.py, `guide-health fleet prior`): on generated fleets (K lognormal), a new
machine's 90 % remaining-life interval after its first 3 measurements is narrower with the fleet prior
than with the default one and covers the truth in >= 9 of 10 machines."""
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.special import stdtrit

from guide_health.models.fleet import (
    combine_estimates,
    likelihood_from_posterior,
    random_effects_fit,
    wear_coefficient_prior,
)
from guide_health.models.wear.calibration import WearCoefficientEstimator, remaining_life_s
from guide_health.params.typed import wear_axis_params

K_CONFIGURED = 4.42e-6                    # seed 000 K: the default prior's mean (rel sd 0.5)
LOG_K_MEAN = math.log(1.5 * K_CONFIGURED)  # the type wears 1.5x the configured K (median) ...
LOG_K_TAU = 0.2                           # ... with a 20 % spread between machines
LOSS_RATE_PER_K_M_S = 0.68 / 3600.0       # straightness loss per unit K: ~3 um/h at K = 4.42e-6 (seed 000 bench)
A0_M, LIMIT_M, NOISE_M = 15e-6, 100e-6, 0.5e-6
MEASUREMENT_S = 0.1 * 3600.0


def measured(k, n, rng, prior_k, prior_rel_sd):
    """The wear_monitor's K estimator after n measurements (every 0.1 h) of a machine with true K = k."""
    est = WearCoefficientEstimator(prior_k, prior_rel_sd, NOISE_M, A0_M)
    for j in range(1, n + 1):
        g = LOSS_RATE_PER_K_M_S * MEASUREMENT_S * j
        est.add(j, A0_M + k * g + rng.normal(0.0, NOISE_M), g, 0.0)
    return est


def life_interval_h(est, n):
    """The 90 % remaining-life interval [h] after n measurements (PrecisionMonitor.report's rule)."""
    lo, _, hi = est.interval90()
    g = LOSS_RATE_PER_K_M_S * MEASUREMENT_S * n
    life = lambda k: remaining_life_s(LIMIT_M, A0_M, g, LOSS_RATE_PER_K_M_S, k) / 3600.0  # noqa: E731
    return life(hi), life(lo) if lo > 0 else math.inf, life


def generated_fleet(seed, machines=20, measurements=60):
    """Old machines of the type, replayed with the default prior: their data-only log K and s.e."""
    rng = np.random.default_rng(seed)
    y, s = [], []
    for _ in range(machines):
        est = measured(math.exp(rng.normal(LOG_K_MEAN, LOG_K_TAU)), measurements, rng, K_CONFIGURED, 0.5)
        lo, k, hi = est.interval90()
        sd = (hi - lo) / (2 * float(stdtrit(est.count - 1, 0.95)))
        k_data, sd_data = likelihood_from_posterior(k, sd, K_CONFIGURED, 0.5 * K_CONFIGURED)
        y.append(math.log(k_data))
        s.append(sd_data / k_data)
    return rng, random_effects_fit(y, s)


@pytest.mark.parametrize("seed", range(5))
def test_fleet_prior_narrows_a_new_machines_life_interval_and_covers_the_truth(seed):
    rng, fit = generated_fleet(seed)
    assert abs(fit.mean - LOG_K_MEAN) < 3 * fit.mean_std_error
    assert 0.1 < fit.tau < 0.3
    k0, rel_sd = wear_coefficient_prior(fit)
    covered, narrower = 0, 0
    for _ in range(10):
        k_true = math.exp(rng.normal(LOG_K_MEAN, LOG_K_TAU))
        state = rng.bit_generator.state
        default = life_interval_h(measured(k_true, 3, rng, K_CONFIGURED, 0.5), 3)
        rng.bit_generator.state = state                       # the same 3 measurements with the fleet prior
        low, high, life = life_interval_h(measured(k_true, 3, rng, k0, rel_sd), 3)
        covered += low <= life(k_true) <= high
        narrower += (high - low) < (default[1] - default[0])
    assert covered >= 9 and narrower == 10


def test_population_fit_closed_forms():
    # equal standard errors: REML tau^2 = sample variance - s^2 (when positive), mu = the plain mean
    y = np.array([0.0, 1.0, 2.0, 3.0])
    fit = random_effects_fit(y, np.full(4, 0.5))
    assert fit.mean == pytest.approx(1.5)
    assert fit.tau ** 2 == pytest.approx(np.var(y, ddof=1) - 0.25, rel=1e-4)
    assert fit.mean_std_error == pytest.approx(math.sqrt((fit.tau ** 2 + 0.25) / 4))
    # estimates closer than their errors: no spread between machines
    assert random_effects_fit([1.0, 1.01, 0.99], [0.5, 0.5, 0.5]).tau == 0.0
    with pytest.raises(ValueError, match="at least 2 machines"):
        random_effects_fit([1.0], [0.1])
    # the Gaussian division inverts the conjugate update: prior N(2, 1), data N(4, 1) -> posterior N(3, 1/2)
    assert likelihood_from_posterior(3.0, math.sqrt(0.5), 2.0, 1.0) == pytest.approx((4.0, 1.0))
    assert math.isinf(likelihood_from_posterior(2.0, 1.0, 2.0, 1.0)[1])
    # lognormal moments
    k0, rel = wear_coefficient_prior(random_effects_fit([0.0, 0.0], [0.3, 0.3]))
    v = 0.0 + 0.3 ** 2 / 2
    assert (k0, rel) == pytest.approx((math.exp(v / 2), math.sqrt(math.exp(v) - 1)))
    assert combine_estimates([1.0, 3.0], [1.0, 1.0]) == pytest.approx((2.0, math.sqrt(0.5)))


def test_fleet_prior_command_from_a_fleet_replay(tmp_path, capsys):
    """fleet replay of 4 machines of one type, then `fleet prior`: a params file the wear_monitor loads."""
    from guide_health.cli.app import main
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.models.wear.precision import PrecisionMonitor
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    cfg = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
    type_file = tmp_path / "type.yaml"              # a second params file: only the machine type
    type_file.write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {"machine_type": "bench45"}}}))
    params = wear_monitor_params([cfg, type_file])
    factors = (1.4, 1.6, 1.5, 1.7)
    for i, factor in enumerate(factors):
        sim = dict(simulation_params(cfg), duration_h=2.0, joint_state_rate_hz=5.0, measurement_interval_h=0.25,
                   wear_coefficient_factor=factor)
        write_machine_bag(simulate_machine(params, sim, seed=10 + i), tmp_path / "bags" / f"b{i}",
                          namespace=f"/m{i}")
    assert main(["fleet", "replay", str(tmp_path / "bags"), "--params", str(cfg), "--params", str(type_file),
                 "--workers", "0",
                 "--no-plot", "--out", str(tmp_path / "fleet")]) == 0
    capsys.readouterr()
    new_machine = tmp_path / "m9.yaml"             # a new machine of the type: its own identity and geometry
    new_machine.write_text(yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": {
        "machine_id": "m9", "joint": "z", "rail_length_m": 0.8, "machine_type": "bench45"}}}))
    out = tmp_path / "prior.yaml"
    assert main(["fleet", "prior", str(tmp_path / "fleet"), "--params", str(new_machine), "--out", str(out),
                 "--json"]) == 0
    prior = json.loads(capsys.readouterr().out)
    assert prior["machine_type"] == "bench45" and prior["machines"] == 4
    # the population median is near the machines' true K (1.4 .. 1.7 x configured), far from the configured K
    assert 1.3 < prior["wear_coefficient_median"] / K_CONFIGURED < 1.8
    written = yaml.safe_load(out.read_text())
    assert list(written) == ["/**/wear_monitor"]                              # applied in any namespace
    assert set(written["/**/wear_monitor"]["ros__parameters"]) == {            # the prior keys, nothing else
        "machine_type", "wear_coefficient", "wear_coefficient_prior_rel_sd"}
    new = wear_monitor_params([new_machine, out])                              # loaded after the machine's file
    assert (new["machine_id"], new["joint"], new["rail_length_m"]) == ("m9", "z", 0.8)   # identity kept
    assert new["machine_type"] == "bench45"
    assert new["wear_coefficient"] == pytest.approx(prior["wear_coefficient"], rel=1e-5)
    assert new["wear_coefficient_prior_rel_sd"] < 0.5                          # tighter than the default
    est = PrecisionMonitor(wear_axis_params(new)).estimator               # what a new machine's node uses
    assert (est.prior_wear_coefficient, est.prior_rel_sd) == (new["wear_coefficient"],
                                                              new["wear_coefficient_prior_rel_sd"])
    other_type = tmp_path / "other.yaml"            # a machine of another type: not its prior
    other_type.write_text(yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": {"machine_type": "lathe20"}}}))
    assert main(["fleet", "prior", str(tmp_path / "fleet"), "--params", str(other_type), "--out",
                 str(tmp_path / "y.yaml")]) == 2
    assert "machine_type 'lathe20', but the prior is of machine type 'bench45'" in capsys.readouterr().err
    assert main(["fleet", "prior", str(tmp_path / "fleet"), "--machine-type", "other", "--out",
                 str(tmp_path / "x.yaml")]) == 2
    assert "0 machines with a K estimate" in capsys.readouterr().err


def test_fleet_prior_bad_input_is_one_line(tmp_path, capsys):
    from guide_health.cli.app import main

    old = tmp_path / "fleet.json"
    old.write_text(json.dumps({"summary": {"command": "replay"}, "bags": []}))
    assert main(["fleet", "prior", str(old), "--out", str(tmp_path / "p.yaml")]) == 2
    assert "summary without machine_type, prior" in capsys.readouterr().err
    assert main(["fleet", "prior", str(tmp_path / "none.json"), "--out", str(tmp_path / "p.yaml")]) == 2
    assert "fleet results not found" in capsys.readouterr().err
    typeless = tmp_path / "typeless.json"          # machines replayed without machine_type
    typeless.write_text(json.dumps({"summary": {"command": "replay", "machine_type": "", "prior": {}},
                                    "bags": [{"ok": True, "machine": "m1", "result": {}}]}))
    for extra in ([], ["--machine-type", ""]):
        assert main(["fleet", "prior", str(typeless), *extra, "--out", str(tmp_path / "p.yaml")]) == 2
        err = capsys.readouterr().err
        assert "machine type is empty" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "p.yaml").exists()


def test_named_effects_of_most_machines_go_into_the_prior_file(tmp_path):
    """Effect populations (diagnose) -> the live model's effect parameters and covariance diagonal."""
    from guide_health.analysis.fleet_prior import write_prior_params
    from guide_health.models.wear.effects import EffectParameters
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES
    from guide_health.params import wear_monitor_params

    cfg = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
    pop = {"running_in.running_in_ratio": {"mean": 0.8, "tau": 0.1, "predictive_sd": 0.2, "machines": 3, "of_bags": 4},
           "running_in.running_in_distance_m": {"mean": 250.0, "tau": 20.0, "predictive_sd": 30.0, "machines": 3,
                                                "of_bags": 4},
           "load_exponent.load_exponent": {"mean": 1.3, "tau": 0.1, "predictive_sd": 0.1, "machines": 1,
                                           "of_bags": 4}}                  # named by 1 of 4: left out
    prior = {"machine_type": "t", "machines": 4, "bags": 4, "wear_coefficient": 5e-6,
             "wear_coefficient_prior_rel_sd": 0.2, "wear_coefficient_median": 4.9e-6,
             "log_k": {"mean": -12.2, "tau": 0.2, "mean_std_error": 0.1, "predictive_sd": 0.22}, "effects": pop}
    out = tmp_path / "prior.yaml"
    write_prior_params(out, prior)
    p = wear_monitor_params([cfg, out])
    live = EffectParameters.from_params(wear_axis_params(p))
    assert live.effects == ("running_in",)
    assert (live.running_in_ratio, live.running_in_distance_m, live.load_exponent) == (0.8, 250.0, 1.0)
    cov = live.covariance_matrix()
    i, j = COVARIANCE_NAMES.index("running_in_ratio"), COVARIANCE_NAMES.index("running_in_distance_m")
    assert (cov[i, i], cov[j, j], cov[0, 0]) == (pytest.approx(0.04), pytest.approx(900.0), 0.0)
    assert "effect running_in.running_in_ratio: mean 0.8" in out.read_text()
