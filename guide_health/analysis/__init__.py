"""Offline analyses of recorded runs with the live nodes' models."""
