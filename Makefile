# Two entry points on a fresh Debian 12 machine with Python 3.11:
#   make demo   set up .venv and plan the bundled sample, printing the path
#   make test   set up .venv and run the whole test suite
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: setup demo test samples bench

setup: $(VENV)/.installed

# open3d's wheel links libusb-1.0, which a bare Debian lacks.
# Every Python package at the version in constraints.txt: a fresh machine plans as this one does.
$(VENV)/.installed: pyproject.toml constraints.txt
	@dpkg -s libusb-1.0-0 >/dev/null 2>&1 || { $(SUDO) apt-get update -qq && $(SUDO) apt-get install -y -qq libusb-1.0-0; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[test]"
	touch $@

demo: setup
	$(BIN)/weldseam plan samples/v_butt.ply --camera-pose samples/v_butt.pose.json -o - --format csv

# The report's browser test renders the page in Debian's chromium.
test: setup
	@command -v chromium >/dev/null 2>&1 || { $(SUDO) apt-get update -qq && $(SUDO) apt-get install -y -qq chromium; }
	$(BIN)/python -m pytest -q

samples: setup
	$(BIN)/python samples/make_samples.py

bench: setup
	$(BIN)/python benchmarks/speed.py
	$(BIN)/python benchmarks/accuracy.py
	$(BIN)/python benchmarks/smoothing.py
	$(BIN)/python benchmarks/merge.py
	$(BIN)/python benchmarks/foreign.py
