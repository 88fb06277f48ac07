# Two commands on a fresh machine:  `make demo`  (bench demo ending in a health report)  and  `make test`.
# Both create .venv, install ROS 2 Jazzy from PyPI (rclpy with Fast DDS, common_interfaces), rosbags,
# numpy, scipy, matplotlib and this package (editable), then run.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.guide_health-installed
PYTEST_ARGS ?=
# the suite on three pytest-xdist workers on CI's two cores (a third worker computes while the live tests wait on
# DDS); each file's tests stay on one worker, so a module fixture is built once. `make test XDIST=`: one process.
XDIST  ?= -n 3 --dist loadfile
# bytecode: pip's one-process compile of every installed module took 37 of the install's 80 s; compileall on both
# cores takes 27 s (a file it cannot compile, e.g. a package's Python 2 test data, is only imported uncompiled).
# PYTHONDONTWRITEBYTECODE (set on some CI hosts) is dropped so that guide_health and the test files are compiled
# once, not again in every test worker and in every node or CLI subprocess (14 % of one node-heavy test file's CPU).
unexport PYTHONDONTWRITEBYTECODE
PIP    := $(PY) -m pip install --quiet --disable-pip-version-check --no-compile

.PHONY: venv demo test test-all bench clean

$(STAMP): setup.py setup.cfg package.xml requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PIP) --upgrade pip setuptools wheel
	$(PIP) -r requirements.txt
	$(PIP) --no-deps --no-build-isolation -e .
	$(PY) -m compileall -q -j 0 $(VENV)/lib guide_health > /dev/null || true
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(PY) -m guide_health.demo --out out/demo

test: $(STAMP)
	$(PY) -m pytest -q $(XDIST) $(PYTEST_ARGS)

test-all: $(STAMP)
	$(PY) -m pytest -q -m "" $(XDIST) $(PYTEST_ARGS)

clean:
	rm -rf out build install log *.egg-info
