"""The node's per-message path for tests: a run's samples fed to a monitor's callbacks one at a time."""
from __future__ import annotations


def feed_per_sample(monitor, run) -> None:
    """Every joint, load and straightness sample of ``run`` to ``monitor.on_joint / on_load / on_straightness``
    in stamp order; at a tie: load, joint, measurement (what the live node sees from a bag)."""
    events = sorted([(int(t), 0, float(x)) for t, x in zip(run.joint_t_ns, run.joint_position_m)]
                    + [(int(t), 1, float(w)) for t, w in zip(run.load_t_ns, run.load_n)]
                    + [(int(t), 2, float(y)) for t, y in zip(run.straightness_t_ns, run.straightness_m)],
                    key=lambda e: (e[0], (1, 0, 2)[e[1]]))
    callbacks = (monitor.on_joint, monitor.on_load, monitor.on_straightness)
    for t, kind, value in events:
        callbacks[kind](t, value)
