"""`guide-health` command line: argparse and formatting only; the physics and analysis they call live in
guide_health.models, guide_health.analysis and guide_health.sim.

app.py holds the argparse tree and :func:`main`; one module per sub-command group (simulate, replay,
diagnose, calibrate, contact, life), each defining its
:class:`~guide_health.cli.command.Command` objects.
"""
from guide_health.cli.app import main

__all__ = ["main"]
