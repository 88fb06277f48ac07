"""What guide_health writes for people and other programs: report files, strict JSON, the progress bar and
the fleet history (see guide_health/io/__init__.py)."""
