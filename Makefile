# Two commands do all set-up: `make run` (the simulated G1 and the mode manager) and `make test`.
# Each brings the venv up to date first and does nothing that has not changed.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMPS := $(VENV)/.stamps
# The robot's Cyclone DDS 0.10.2 with the Unitree SDK2 over it, for the robot-compatibility tests.
SIDE_VENV ?= .venv-cyclone010

MSG_SOURCES := $(shell find msg_defs -type f)

.PHONY: setup run test ros-build chaos-ci lint bench latency body-latency policy-faults flakes chaos exits soak clean

setup: $(STAMPS)/package $(STAMPS)/msgs $(STAMPS)/assets $(SIDE_VENV)/.stamp

$(SIDE_VENV)/.stamp: requirements-cyclone010.txt requirements-nodeps.txt scripts/build_cyclone010.sh scripts/check_system.sh
	scripts/check_system.sh
	scripts/build_cyclone010.sh $(PYTHON) $(SIDE_VENV)
	@touch $@

$(STAMPS)/deps: requirements.txt requirements-nodeps.txt constraints.txt scripts/check_system.sh
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "Python 3.11 is required, found " + sys.version'
	scripts/check_system.sh
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q -r requirements.txt -c constraints.txt
	$(BIN)/python -m pip install -q --no-deps -r requirements-nodeps.txt
	@mkdir -p $(STAMPS) && touch $@

$(STAMPS)/msgs: $(STAMPS)/deps $(MSG_SOURCES) scripts/build_msgs.sh
	scripts/build_msgs.sh $(VENV)
	@touch $@

$(STAMPS)/assets: $(STAMPS)/deps scripts/fetch_assets.py
	$(BIN)/python scripts/fetch_assets.py $(VENV)
	@touch $@

$(STAMPS)/package: $(STAMPS)/msgs setup.py setup.cfg package.xml
	$(BIN)/python -m pip install -q --no-deps --no-build-isolation -e .
	@touch $@

# ruff's lint rules only: no formatter runs, so the code carries no formatter markers; tables of data stay aligned
# by hand where that reads better.
lint: setup
	$(BIN)/ruff check .

# Four workers (pytest-xdist), each with DDS domains of its own: the tests mostly wait on real-time sims, and an
# idle sim computes nothing nobody reads, so two cores carry four at about 88 %. Not five: at about 95 % the sims'
# and readers' lag grows past what the tests allow for (figures in docs/figures.md). A test file stays in one
# worker, so its module fixtures (one sim for a file's tests) are made once.
# (--dist loadgroup does not group with pytest 9.2: xdist 3.8 renames the node id through an attribute pytest no
# longer reads.) Files go out in test/conftest.py's order, slowest first, not by their number of tests.
test: setup lint
	@# compiled ahead: a shell with PYTHONDONTWRITEBYTECODE set has each of the suite's hundreds of nodes and sims compile
	@# the product's sources again (compileall writes whatever that says)
	@$(BIN)/python -m compileall -q g1_mode_manager sim/g1_sim harness
	$(BIN)/python -m pytest -n 4 --dist loadfile --no-loadscope-reorder --durations=20 \
		-m "not policy_faults and not latency_only and not ros_build"

# Two checks CI runs after `make test`, alone, so that the suite's two loaded cores do not carry them (their cost in
# docs/figures.md): the ordinary ROS build of both packages with colcon, and the rest of CI's fixed chaos batch
# (`make test` runs its seeds 7000-7003, this the 26 after them: 30 of the 33 cells aimed).
ros-build: setup
	$(BIN)/python -m pytest -q -m ros_build test/packaging/test_colcon_build.py
chaos-ci: setup
	G1_CHAOS_N=26 G1_CHAOS_SEED=7004 G1_CHAOS_PARTS=1 $(BIN)/python -m pytest -q test/chaos/test_chaos.py

# A flake census (docs/testing.md): each file of make latency and make policy-faults run FLAKE_RUNS times alone as
# its target runs it, then make test SUITES times; a table of every failure with its first assertion line
# (artifacts/flakes.md). `make flakes FLAKE_RUNS=50 LATENCY_FILES=test/e2e/test_user_ctrl.py POLICY_FAULT_FILES=`
FLAKE_RUNS ?= 20
SUITES ?= 0
LATENCY_FILES ?= $(LATENCY_TESTS)
POLICY_FAULT_FILES ?= test/e2e/test_policy_faults.py
flakes: setup
	PYTHONPATH=test$${PYTHONPATH:+:$$PYTHONPATH} $(BIN)/python -m flakes --runs $(FLAKE_RUNS) --suites $(SUITES) \
		--latency $(LATENCY_FILES) --policy-faults $(POLICY_FAULT_FILES)

# Policies made to fail mid-walk on the sim (non-finite, slow, a frozen state stream with every default), each judged
# on the record: three more sims' worth of walking that the suite's four workers on two cores do not carry (figures in
# docs/). CI runs this after make test.
policy-faults: setup
	$(BIN)/python -m pytest -q -s -m policy_faults $(POLICY_FAULT_FILES)

# `make run VIEW=1` opens MuJoCo's viewer on the sim (where a display exists).
run: setup
	$(BIN)/g1_demo $(if $(VIEW),--viewer) $(TOUR)

bench: setup
	$(BIN)/python -m bench.run

# The reaction goals of test/support/timing.py (LOW_LEVEL damping frames within 50 ms of a body check's condition on
# the robot, the remote's L2+B within 100 ms, answers that do not wait for a held Move...), asserted alone on the
# machine: the suite, which loads both cores, prints them and asserts order and outcome. The tests marked
# latency_only run here only (the dances: a stretch of each, a flail and an e-stop mid-dance; the keep-alive's
# intervals): more sims' worth of dancing than the suite's load carries. CI runs this after make test.
LATENCY_TESTS := test/e2e/test_body.py test/e2e/test_held_move.py test/e2e/test_windows.py test/e2e/test_loco_outcome.py \
	test/e2e/test_user_ctrl.py test/e2e/test_drivers.py test/e2e/test_policy.py test/e2e/test_policy_dance.py
latency: setup
	G1_TIMING=strict $(BIN)/python -m pytest -q -s $(LATENCY_TESTS)
body-latency: setup
	G1_TIMING=strict $(BIN)/python -m pytest -q -s test/e2e/test_body.py

# The chaos suite on a longer randomized batch of every scenario length: `make chaos N=500 SEED=1`. It prints
# its coverage table, then `chaos: N scenarios, V violations, U unclean exits`; each violation names its seed
# (replay: N=1 SEED=<seed>), an unclean exit's output is kept in .venv/chaos_unclean/.
N ?= 100
SEED ?= $(shell date +%s)
chaos: setup
	@rm -rf .venv/chaos_summary.txt .venv/chaos_unclean
	-G1_CHAOS_N=$(N) G1_CHAOS_PARTS=1 G1_CHAOS_SEED=$(SEED) G1_CHAOS_LENGTHS=short,medium,long \
		G1_CHAOS_SUMMARY=.venv/chaos_summary.txt $(BIN)/python -m pytest -q test/chaos
	@cat .venv/chaos_summary.txt
	@tail -n 1 .venv/chaos_summary.txt | grep -q ' 0 violations, 0 unclean exits$$'
	@! grep -q '^coverage shortfall' .venv/chaos_summary.txt

# Start, operate and SIGINT the node N times (`make exits N=1000`); its last line is `exits: N cycles, U unclean`.
exits: setup
	PYTHONPATH=test$${PYTHONPATH:+:$$PYTHONPATH} $(BIN)/python -m exits --cycles $(N) --seed $(SEED)

# A long run of the real node and sim under a steady random load: `make soak MINUTES=30 SEED=1`. Node lifetimes
# of about LIFETIME s, each ended by an e-stop and judged by the chaos invariants; the node's RSS, threads, fds and
# DDS entities sampled every SAMPLE s and judged for growth (docs/soak.md). Its last line is
# `soak: M minutes, V violations, growth: none|<what grew>`; samples.csv, soak.svg and report.md go to OUT.
MINUTES ?= 30
LIFETIME ?= 300
SAMPLE ?= 30
OUT ?= artifacts/soak
soak: setup
	PYTHONPATH=test$${PYTHONPATH:+:$$PYTHONPATH} $(BIN)/python -m soak --minutes $(MINUTES) --seed $(SEED) \
		--lifetime-s $(LIFETIME) --sample-s $(SAMPLE) --out $(OUT)

clean:
	rm -rf $(VENV) $(SIDE_VENV) build *.egg-info
