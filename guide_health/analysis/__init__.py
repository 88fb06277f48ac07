"""Offline analyses of recorded runs (bags) with the live nodes' models, what the CLI commands call: replay,
life tests, slewing replay, the discrepancy workflow."""
