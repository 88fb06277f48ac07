"""Simulated runs for bags and tests: a machine axis on a sliding/rolling guide (machine.py, with its
motion in motion.py and guide temperature in thermal.py) and a slewing bearing's crane duty (slewing.py)."""
