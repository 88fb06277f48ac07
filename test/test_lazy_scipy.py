"""models/lazy_scipy.py: the node's start-up path imports no scipy.optimize or scipy.special, and each wrapper is
scipy's function (published values)."""
from __future__ import annotations

import math
import subprocess
import sys

import pytest

from guide_health.models import lazy_scipy


def test_a_wear_monitor_start_imports_neither_scipy_optimize_nor_special():
    """Both cost ~0.9 s of CPU at every node start, and a node that never calls them
    must not pay it: import the node module (all it loads before spinning) in a fresh interpreter."""
    code = ("import sys, guide_health.nodes.wear_monitor, guide_health.cli.app; "
            "print(sorted(m for m in ('scipy.optimize', 'scipy.special', 'scipy.stats') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_each_wrapper_is_scipys_function():
    # the t quantile's closed forms: 1 dof (Cauchy) tan(pi (p - 1/2)), 2 dof (2p - 1) / sqrt(2 p (1 - p))
    assert lazy_scipy.stdtrit(1, 0.95) == pytest.approx(math.tan(0.45 * math.pi), rel=1e-12)
    assert lazy_scipy.stdtrit(2, 0.95) == pytest.approx(0.9 / math.sqrt(2 * 0.95 * 0.05), rel=1e-12)
    assert lazy_scipy.ndtr(1.6448536269514722) == pytest.approx(0.95, rel=1e-14)
    assert lazy_scipy.ellipk(0.0) == pytest.approx(math.pi / 2, rel=1e-15)
    assert lazy_scipy.ellipe(1.0) == pytest.approx(1.0, rel=1e-15)
    assert lazy_scipy.ellipk(0.5) == pytest.approx(1.8540746773013719, rel=1e-14)       # K(m = 1/2)
    assert lazy_scipy.brentq(lambda x: x * x - 2.0, 0.0, 2.0, xtol=1e-14) == pytest.approx(math.sqrt(2), rel=1e-13)
