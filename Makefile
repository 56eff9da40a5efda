# One-command set-up for newcomers: `make demo`, `make test`. Everything runs inside .venv.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip -q --disable-pip-version-check
DEMO_DIR ?= demo_output
# The exact versions a fresh machine installs (pip constraints, written by `make lock`); `make test-latest` empties it
# to test the newest versions in a venv of their own.
LOCK ?= requirements.lock
CONSTRAIN := $(if $(LOCK),-c $(LOCK))

# DDS traffic stays on 127.0.0.1 and rclpy logs go to a temporary folder (see README, "Network").
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_LOG_DIR ?= $(or $(TMPDIR),/tmp)/imu_noise_id_ros_log
# One BLAS thread per process: the numbers in docs/results were measured so, and on a small machine the Dask workers
# and the node's processes would otherwise each start a thread per core.
export OPENBLAS_NUM_THREADS ?= 1
# pytest-xdist workers for `make test` (one per core of the 2-core machines it runs on; 0 runs in this process). The
# tests marked `ros` (nodes fed and observed over DDS in real time) run at the same time in a process of their own, and
# the others at the lowest CPU priority (nice 19): beside another worker's fits at equal priority a starved node drops
# messages (7000 sent, 5500 received) and misses its timing checks, while at nice 19 the fits only take the CPU time
# the nodes leave (the ros-marked run uses about 0.7 of a core). Their output is shown when both runs are done.
# TEST_DDS_SHARES gives the ros-marked run DDS domains of its own (test/dds.py). Work stealing keeps both workers busy
# until the last test.
TEST_WORKERS ?= 2

.PHONY: setup demo test test-latest lock lint bench clean

$(VENV)/.installed: requirements.txt requirements-dev.txt $(LOCK) setup.py setup.cfg package.xml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip 2>&1 | grep -v '^WARNING: Location' || true
	set -o pipefail; $(PIP) install -r requirements-dev.txt $(CONSTRAIN) 2>&1 | { grep -v '^WARNING: Location' || true; }
	set -o pipefail; $(PIP) install -e . $(CONSTRAIN) 2>&1 | { grep -v '^WARNING: Location' || true; }
	@# Chromium (Debian's package) renders report.html in the browser test; without it that test is skipped.
	command -v chromium >/dev/null || { test "$$(id -u)" = 0 && command -v apt-get >/dev/null \
	  && { apt-get install -y -q chromium >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -q chromium >/dev/null; }; }; } \
	  || echo "note: chromium not installed; the browser test of report.html will be skipped"
	touch $@

setup: $(VENV)/.installed

demo: setup
	$(PY) -m imu_noise_id.demo --out $(DEMO_DIR)

lint: setup
	$(VENV)/bin/ruff check .

test: setup lint
	@start=$$(date +%s); ros_log=$$(mktemp); shares=$$(( $(TEST_WORKERS) > 0 ? $(TEST_WORKERS) + 1 : 2 )); \
	TEST_DDS_SHARES=$$shares TEST_DDS_SHARE=$$(( shares - 1 )) $(PY) -m pytest -q -p no:cacheprovider -m ros \
	  > $$ros_log 2>&1 & ros=$$!; \
	echo "tests marked ros: running beside the others (their output follows at the end)"; \
	TEST_DDS_SHARES=$$shares TEST_DDS_SHARE=0 nice -n 19 $(PY) -m pytest -q -n $(TEST_WORKERS) --dist worksteal \
	  --durations=25 -m "not ros"; others=$$?; \
	wait $$ros; ros_status=$$?; echo "-- tests marked ros:"; cat $$ros_log; rm -f $$ros_log; \
	echo "make test: $$(( $$(date +%s) - start )) s wall"; \
	test $$others = 0 -a $$ros_status = 0

# The newest versions of everything (not part of .ci/run): what breaks first when the lock is renewed.
test-latest:
	$(MAKE) test VENV=.venv-latest LOCK=

# Renew the lock: the newest versions, installed and tested in .venv-latest, become requirements.lock.
lock: test-latest
	.venv-latest/bin/python tools/write_lock.py > requirements.lock

bench: setup
	$(PY) bench/run_all.py

clean:
	rm -rf $(VENV) .venv-latest build install log $(DEMO_DIR) .pytest_cache .ruff_cache
