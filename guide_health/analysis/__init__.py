"""Offline analyses of recorded runs (bags) with the live nodes' models: replay, life tests, slewing replay,
the discrepancy workflow."""
