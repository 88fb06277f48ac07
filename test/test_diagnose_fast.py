"""The fast paths of diagnose give exactly the result of the plain path (issue 14).

- the cell keys by a count over the chunk's key box (duty._cell_keys) = np.unique(keys, return_inverse=True),
  and whole duty cells with it = with np.unique, bit for bit;
- the cells read in a child process (duty_process.start_duty_cells, background=True) = read_duty_cells in
  the test process, bit for bit; an InputError in the child is the same one-line error in the caller;
- the PNG drawn by the reader child after the read (PendingCells.plot) = the PNG drawn here, byte for byte;
- the candidate fits of each selection round in 2 processes (fit_pool.FitPool) = in turn: the whole result
  (every candidate's fit, the named effects, the model file, the forecast) identical.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy import duty
from guide_health.analysis.discrepancy.duty_process import start_duty_cells
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.errors import InputError
from guide_health.io.bag.writer import write_machine_bag
from guide_health.models.wear.input_rules import InputLimits
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.sim.machine import simulate_machine

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"
BENCH = ROOT / "config" / "bench_000.yaml"


def assert_cells_identical(a: duty.DutyCells, b: duty.DutyCells) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, f.name
            assert np.array_equal(x, y, equal_nan=True), f.name
        else:
            assert x == y, f.name


def unique_keys(block, retract, v_bin, w_bin):
    keys = ((block * 2 + retract) * duty._BINS + v_bin) * duty._BINS + w_bin
    return np.unique(keys, return_inverse=True)


@pytest.mark.parametrize("spread", [(300, 40, 30), (5000, 4000, 4000)])   # a small box; one too large: np.unique
def test_cell_keys_equal_np_unique(spread):
    rng = np.random.default_rng(4)
    n = 20_000
    block = np.sort(rng.integers(0, spread[0], n)) - 3
    retract = rng.random(n) < 0.4
    v_bin = rng.integers(2000, 2000 + spread[1], n)
    w_bin = rng.integers(1990, 1990 + spread[2], n)
    uniq, inverse = duty._cell_keys(block, retract, v_bin, w_bin)
    ref_uniq, ref_inverse = unique_keys(block, retract, v_bin, w_bin)
    assert np.array_equal(uniq, ref_uniq) and np.array_equal(inverse, ref_inverse)


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(duration_h=4.0, joint_state_rate_hz=10.0, load_rate_hz=5.0)
    path = tmp_path_factory.mktemp("duty") / "bag"
    write_machine_bag(simulate_machine(params, sim, seed=3, effects={"running_in": 2.0}), path)
    return path, params


@pytest.fixture(scope="module")
def serial_read(bag):
    """(cells, messages) of the bag read in the test process with the fast cell keys."""
    path, params = bag
    return duty.read_duty_cells(path, params)


def test_fast_cell_keys_give_the_cells_of_np_unique(bag, serial_read, monkeypatch):
    path, params = bag
    fast, messages = serial_read
    monkeypatch.setattr(duty, "_cell_keys", unique_keys)
    plain, messages_plain = duty.read_duty_cells(path, params)
    assert messages == messages_plain > 100_000
    assert fast.cells > 100 and fast.segments > 50_000
    assert_cells_identical(fast, plain)


def test_cells_read_in_a_child_process_equal_the_serial_read(bag, serial_read):
    path, params = bag
    serial = serial_read
    pending = start_duty_cells(path, params, background=True)
    assert pending.background
    child = pending.result()
    assert child[1] == serial[1]
    assert_cells_identical(child[0], serial[0])
    # small bags are read in the caller unless asked
    assert not start_duty_cells(path, params).background


def test_error_in_the_child_is_the_callers_one_line_error(tmp_path, bag):
    _, params = bag
    with pytest.raises(InputError) as serial:
        duty.read_duty_cells(tmp_path / "missing", params)
    with pytest.raises(InputError) as child:
        start_duty_cells(tmp_path / "missing", params, background=True).result()
    assert str(child.value) == str(serial.value) and "\n" not in str(child.value)


def test_candidate_fits_in_two_processes_equal_the_fits_in_turn():
    # seed 000's bench, 10 h at 5 Hz with running-in hidden: named, so the search runs a second round
    params = wear_monitor_params(BENCH)
    sim = simulation_params(BENCH)
    sim.update(duration_h=10.0, joint_state_rate_hz=5.0)
    run = simulate_machine(params, sim, seed=3, effects={"running_in": 2.5})
    cells = duty.duty_cells_from_runs(run, params["slider_length_m"],
        limits=InputLimits.from_params(wear_axis_params(params)),
        sliding_deadband_m=params["sliding_deadband_m"])
    serial = diagnose_cells(cells, params, workers=1)
    pooled = diagnose_cells(cells, params, workers=2)
    assert serial["named_effects"] == ["running_in"]
    assert max(c["round"] for c in serial["candidates"]) == 2 and len(serial["candidates"]) >= 15

    def body(result):
        return json.dumps({k: v for k, v in result.items() if k not in ("fit_s", "series")}, default=float,
                          sort_keys=True)

    assert body(pooled) == body(serial)
    for key, values in serial["series"].items():
        assert np.array_equal(pooled["series"][key], values)


def test_png_drawn_by_the_reader_child_equals_the_png_drawn_here(bag, tmp_path):
    path, params = bag
    pending = start_duty_cells(path, params, background=True, plot=True)
    try:
        cells, _ = pending.result()
        result = diagnose_cells(cells, params)
        pending.plot(result, tmp_path / "child.png")
    finally:
        pending.close()
    from guide_health.analysis.discrepancy.report import plot

    plot(result, tmp_path / "here.png")
    assert (tmp_path / "child.png").read_bytes() == (tmp_path / "here.png").read_bytes()
    assert (tmp_path / "here.png").stat().st_size > 10_000
