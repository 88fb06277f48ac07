"""Offline analysis of recorded runs and tests with the models: what the CLI commands call."""
