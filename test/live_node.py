"""The live tests' start-up block and the fit-reload scenario, written once.

:class:`LiveWearNode` (fixture ``live_wear_node`` in conftest.py): a wear_monitor process and a /diagnostics
collector in the test's isolated domain (ros_test_env: its own domain, UDP only), started in the order every
live test needs (collector first, so that no status is missed; the node; its first status, a graph event, as
the sign that it is up), bag_player into it once its subscriptions have matched, and everything stopped at
the end of the test whatever happened (node SIGINT, collector, stale Fast DDS segments).

:func:`reload_scenario`: the bench run of test_fit_watch_reload's live load and test_model_restart's restart
(seed 7, 3.1 h, +6 um on the straightness after 1 h: the fit test fires; split at 2 h into two bags; the
model anchored at 1 h; the offline replays of the first bag and of both with the file loaded at 2 h). Joint
states at 2 Hz: the fit fires on the first bag and the loaded file clears it as at 10 Hz (both asserted on
the offline replays), with a fifth of the messages to play."""
from __future__ import annotations

import os
import signal
from pathlib import Path
from types import SimpleNamespace

import yaml

from guide_health.nodes.session import (
    PLAYER_WAIT_TIMEOUT_S,
    DiagnosticsCollector,
    clean_fastdds_shm,
    play_bag,
    start_node,
    stop_node,
)

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
WEAR_MONITOR = "guide_health.nodes.wear_monitor"
BENCH_STATUS = "bench_000/wear_monitor: x precision"
#: bag_player into a started node: once every played topic has a subscriber, uncapped (reliable KEEP_ALL
#: back-pressure: nothing lost)
PLAY_INTO_NODE = ["--wait-subscribers", "1", "--max-rate", "0"]
HOUR_NS = 3600 * 10**9


class LiveWearNode:
    """One wear_monitor (or another node module) at a time, with a collector, in the environment ``env``."""

    def __init__(self, env: dict[str, str], tmp_path: Path):
        self.env, self.tmp_path = env, tmp_path
        self.collector: DiagnosticsCollector | None = None
        self.proc = None
        self.log_path: Path | None = None
        self._starts = 0

    def start(self, params_file, overrides: dict | None, status: str = BENCH_STATUS,
              module: str = WEAR_MONITOR, up=lambda s: True) -> dict:
        """Start the node (a collector first if none runs) and return its first status that satisfies
        ``up``; an assertion with the node's log when none comes within PLAYER_WAIT_TIMEOUT_S."""
        self._starts += 1
        if self.collector is None:
            self.collector = DiagnosticsCollector(f"live_collector_{os.getpid()}_{self._starts}")
        self.log_path = self.tmp_path / f"node{self._starts}.log"
        self.proc = start_node(module, params_file, overrides, self.env, log_path=self.log_path)
        first = self.collector.wait_for(status, up, timeout=PLAYER_WAIT_TIMEOUT_S)
        assert first is not None, f"{status!r} never published:\n{self.log_path.read_text()}"
        return first

    def play(self, bag, extra: list[str] | None = None, returncode: int | None = 0):
        """bag_player of ``bag`` into the node (PLAY_INTO_NODE, then ``extra``); its exit code checked unless
        ``returncode`` is None."""
        played = play_bag(bag, self.env, PLAY_INTO_NODE + list(extra or []))
        if returncode is not None:
            assert played.returncode == returncode, played.stderr
        return played

    def wait_counts(self, status: str, counts: dict[str, float], timeout: float = 300.0) -> dict:
        return self.collector.wait_counts(status, counts, timeout=timeout)

    def kill(self) -> None:
        """SIGKILL the node (no clean shutdown: only its last checkpoint survives) and drop the collector, so
        that the next :meth:`start` sees only the new process's statuses."""
        os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
        self.proc = None
        clean_fastdds_shm()
        self.collector.close()
        self.collector = None

    def close(self) -> None:
        if self.proc is not None:
            stop_node(self.proc)
            self.proc = None
        if self.collector is not None:
            self.collector.close()
            self.collector = None
        clean_fastdds_shm()


class TriggerClient:
    """~/load_model and set_parameters of a remote wear_monitor, from a private rclpy context."""

    def __init__(self, target: str = "wear_monitor"):
        import rclpy
        from rcl_interfaces.srv import SetParameters
        from rclpy.executors import SingleThreadedExecutor
        from std_srvs.srv import Trigger

        self.rclpy = rclpy
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("load_model_client", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.trigger = self.node.create_client(Trigger, f"/{target}/load_model")
        self.set_client = self.node.create_client(SetParameters, f"/{target}/set_parameters")
        assert self.trigger.wait_for_service(timeout_sec=PLAYER_WAIT_TIMEOUT_S)
        assert self.set_client.wait_for_service(timeout_sec=PLAYER_WAIT_TIMEOUT_S)

    def _call(self, client, request):
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=PLAYER_WAIT_TIMEOUT_S)
        assert future.done()
        return future.result()

    def load(self):
        from std_srvs.srv import Trigger

        return self._call(self.trigger, Trigger.Request())

    def set_model_file(self, path: str):
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request(parameters=[Parameter("model_file", value=path).to_parameter_msg()])
        return self._call(self.set_client, request).results[0]

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)


def reload_scenario(tmp_path: Path) -> SimpleNamespace:
    """The 3.1 h bench run (seed 7) with +6 um after 1 h, split at 2 h into bags ``b1``/``b2`` under
    ``tmp_path``, the model file anchored at 1 h (``model.yaml``: bench K, A0 = 30 um) and the offline
    replays: ``half`` (b1, the fit test fired) and ``whole`` (both bags, the file loaded at 2 h: replay
    --model-at's path)."""
    from guide_health.analysis.replay import analyse_bag
    from guide_health.io.bag.bag_set import resolve_bags
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.models.wear.axis import split_run
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.params.typed import wear_axis_params
    from guide_health.sim.machine import simulate_machine

    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=3.1, joint_state_rate_hz=2.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    run = simulate_machine(params, sim, seed=7)
    t0 = int(run.straightness_t_ns[0])
    run.straightness_m[run.straightness_t_ns > t0 + HOUR_NS] += 6e-6
    at = t0 + 2 * HOUR_NS
    first, second = split_run(run, at)
    b1, b2 = tmp_path / "b1", tmp_path / "b2"
    write_machine_bag(first, b1, storage="sqlite3")
    write_machine_bag(second, b2, storage="sqlite3")
    model = {"wear_coefficient": params["wear_coefficient"], "straightness_initial_m": 30e-6,
             "model_from_stamp_s": (t0 + HOUR_NS) * 1e-9}
    good = tmp_path / "model.yaml"
    good.write_text(yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": model}}))
    half = analyse_bag(b1, params)[1]
    whole = analyse_bag(resolve_bags([str(b1), str(b2)]), params, load=(at, wear_axis_params({**params, **model})))[1]
    return SimpleNamespace(params=params, bench_file=BENCH, t0=t0, at=at, b1=b1, b2=b2, model=model, good=good,
                           half=half, whole=whole)
