"""Offline analyses of recorded runs (bags): replay, life tests, the discrepancy workflow."""
