# pfield — two commands matter: `make demo` and `make test`.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench anchor lint venv core core-test clean ros2-interfaces chromium egl

# The compiled core pfield._core (C++17 in src/core, nanobind, scikit-build-core) is built by an editable
# install without build isolation, so that its build tree (build/cp311-*) is kept and an edit of a C++ file
# rebuilds only what changed (`make core`, a few seconds). docs/core.md: options, debug and sanitizer builds.
# The build tools alone first (their own stamp): the core's sanitizer build (core-test) needs only these, so that
# `make test` compiles it while pip installs the dependencies on the other core. setuptools >= 70.1 is among
# them because, without build isolation, a dependency published only as an sdist (empy, for the ROS 2 wheels)
# is built with the venv's own setuptools, and a new venv's (65.5) has no bdist_wheel (70.1 has it built in). NumPy is
# among them for its headers (the core's hot bindings use its C API).
TOOLS_STAMP := $(VENV)/.build-tools
$(TOOLS_STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "pfield: installing the build tools into $(VENV) (first run only)"
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet 'scikit-build-core>=0.10' 'nanobind>=2.4' 'numpy>=2.0' cmake ninja 'setuptools>=70.1'
	@touch $@

$(STAMP): pyproject.toml CMakeLists.txt | $(TOOLS_STAMP)
	@echo "pfield: installing the dependencies and compiling the C++ core (first run only: 1-3 min on 2 cores)"
	$(PY) -m pip install --quiet --no-build-isolation -e '.[dev,ros2,viewer,ray,sim]'
	@touch $(STAMP)

venv: $(STAMP)

CORE_SOURCES := $(shell find src/core -name '*.cpp' -o -name '*.hpp')
CORE_STAMP   := $(VENV)/.core-built
$(CORE_STAMP): $(CORE_SOURCES) CMakeLists.txt | $(STAMP)
	@echo "pfield: compiling what changed in the C++ core"
	$(PY) -m pip install --quiet --no-build-isolation --no-deps -e .
	@touch $@

core: $(CORE_STAMP)

# The core's C++ tests (tests/core) under AddressSanitizer and UndefinedBehaviorSanitizer.
CORE_TEST_BUILD := build/core-sanitize
core-test: | $(TOOLS_STAMP)
	$(VENV)/bin/cmake -S . -B $(CORE_TEST_BUILD) -G Ninja -DCMAKE_MAKE_PROGRAM=$(abspath $(VENV))/bin/ninja \
		-DPFIELD_PYTHON=OFF -DPFIELD_CORE_TESTS=ON -DPFIELD_SANITIZE=ON > /dev/null
	$(VENV)/bin/cmake --build $(CORE_TEST_BUILD)
	$(VENV)/bin/ctest --test-dir $(CORE_TEST_BUILD) --output-on-failure

# ROS 2 interfaces (potential_fields_interfaces) built with plain CMake against the ros-jazzy-* wheels
# and installed into the venv; rebuilt only when an interface or build file changes (stamp file).
ROS2_PKG    := ros/potential_fields_interfaces
ROS2_BUILD  := build/ros2-interfaces
ROS2_STAMP  := $(VENV)/.ros2-interfaces
ROS2_PREFIX := $(abspath $(VENV))

$(ROS2_STAMP): $(ROS2_PKG)/CMakeLists.txt $(ROS2_PKG)/package.xml $(ROS2_PKG)/msg $(ROS2_PKG)/srv \
		$(wildcard $(ROS2_PKG)/msg/*.msg $(ROS2_PKG)/srv/*.srv) | $(STAMP)
	AMENT_PREFIX_PATH=$(ROS2_PREFIX) CMAKE_PREFIX_PATH=$(ROS2_PREFIX) cmake -S $(ROS2_PKG) -B $(ROS2_BUILD) \
		-DCMAKE_INSTALL_PREFIX=$(ROS2_PREFIX) -DBUILD_TESTING=OFF -DPython3_EXECUTABLE=$(abspath $(PY)) \
		-DCMAKE_INSTALL_MESSAGE=NEVER > /dev/null
	cmake --build $(ROS2_BUILD) -j2 > /dev/null
	cmake --install $(ROS2_BUILD) > /dev/null
	@touch $@

ros2-interfaces: $(ROS2_STAMP)

# control_msgs' FollowJointTrajectory and JointJog subset (ros/control_msgs, NOTICE.md there): the action a
# ros2_control joint_trajectory_controller serves, for pfield.transport.trajectory_client, and the servo's joint
# jog; built the same way.
CONTROL_MSGS_PKG   := ros/control_msgs
CONTROL_MSGS_BUILD := build/ros2-control-msgs
CONTROL_MSGS_STAMP := $(VENV)/.ros2-control-msgs

$(CONTROL_MSGS_STAMP): $(CONTROL_MSGS_PKG)/CMakeLists.txt $(CONTROL_MSGS_PKG)/package.xml \
		$(wildcard $(CONTROL_MSGS_PKG)/msg/*.msg $(CONTROL_MSGS_PKG)/action/*.action) | $(STAMP)
	AMENT_PREFIX_PATH=$(ROS2_PREFIX) CMAKE_PREFIX_PATH=$(ROS2_PREFIX) cmake -S $(CONTROL_MSGS_PKG) \
		-B $(CONTROL_MSGS_BUILD) -DCMAKE_INSTALL_PREFIX=$(ROS2_PREFIX) -DBUILD_TESTING=OFF \
		-DPython3_EXECUTABLE=$(abspath $(PY)) -DCMAKE_INSTALL_MESSAGE=NEVER > /dev/null
	cmake --build $(CONTROL_MSGS_BUILD) -j2 > /dev/null
	cmake --install $(CONTROL_MSGS_BUILD) > /dev/null
	@touch $@

ros2-interfaces: $(CONTROL_MSGS_STAMP)

# warmup first: a self-check of the install (about a second; the built-in robots' link models ship with pfield)
demo: $(STAMP) $(CORE_STAMP)
	$(VENV)/bin/pfield warmup
	$(VENV)/bin/pfield demo

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks examples
	$(VENV)/bin/mypy

# Debian's chromium for the 3D viewer's browser tests (tests/viz), installed when missing; elsewhere the
# browser tests fail with a message saying what to install.
chromium:
	@command -v chromium > /dev/null || ! command -v apt-get > /dev/null || \
		{ apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium > /dev/null; }

# MuJoCo's offscreen renderer (pfield.sim.render_frame, examples/sim) needs EGL with Mesa's drivers when headless
egl:
	@ls /usr/lib/*/libEGL_mesa.so.0 > /dev/null 2>&1 || ! command -v apt-get > /dev/null || \
		{ apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libegl1 libegl-mesa0 \
		libgl1-mesa-dri > /dev/null; }

# pytest on PYTEST_WORKERS processes (pytest-xdist; 2 = the CI machine's cores, 1 = no worker processes). Each test
# file runs whole on one worker, in its order (--dist loadfile): a module's server starts once, and tests that read
# what an earlier test of their file left (a server's log) see it. The files are handed out in collection order,
# the longest first (tests/conftest.py, LONGEST_FIRST; --no-loadscope-reorder keeps that order). Parallel-safe by
# construction: servers bind free 127.0.0.1 ports, ROS 2 and Ray sessions run in private network and /dev/shm
# namespaces, the fit cache writes each file under a temporary name and renames it, other files go to tmp_path.
PYTEST_WORKERS ?= 2
PYTEST_PARALLEL := $(if $(filter 1,$(PYTEST_WORKERS)),,-n $(PYTEST_WORKERS) --dist loadfile --no-loadscope-reorder)

# The setup steps run two at a time (make -j2, the CI machine's 2 cores; SETUP_JOBS=1: one at a time): pip and mypy
# use one core, so the sanitizer build of the core's tests overlaps the dependencies' install, and mypy the ROS 2
# interfaces' build. Their output is kept per step.
# compileall then: the tests start a few hundred `pfield` and Python processes, and with PYTHONDONTWRITEBYTECODE set
# (or a read-only tree) each would compile pfield's sources again (0.1-0.3 s of CPU per process); stale files are
# recompiled, fresh ones skipped (a second or two).
SETUP_JOBS ?= 2
test: chromium egl
	@$(MAKE) --no-print-directory -j$(SETUP_JOBS) --output-sync=target lint core core-test ros2-interfaces
	$(PY) -m compileall -q -j0 src/pfield tests > /dev/null
	$(VENV)/bin/pytest -q $(PYTEST_PARALLEL)

# the benchmarks' own peers (the `bench` extra: OMPL), installed on the first `make bench`
BENCH_STAMP := $(VENV)/.bench-installed
$(BENCH_STAMP): pyproject.toml | $(STAMP)
	$(PY) -m pip install --quiet --no-build-isolation -e '.[dev,ros2,viewer,ray,sim,bench]'
	@touch $@

# BENCH_ARGS: e.g. --no-old (no numba engine columns), --rounds 3, --quick, --only field task_space
bench: $(STAMP) $(CORE_STAMP) $(BENCH_STAMP) ros2-interfaces
	-@$(MAKE) --no-print-directory anchor
	$(if $(findstring --no-old,$(BENCH_ARGS)),@:,-@$(MAKE) --no-print-directory old-engine)
	$(PY) -m benchmarks.run $(BENCH_ARGS)

# The C++ original (argallab/potential_fields' library) and its timing program, built once into
# build/anchor-cpp (git-ignored) so that `make bench` times it side by side; ~2-6 min, needs cmake, g++
# and python3.11 (pinned cmeel wheels). Without it the benchmarks compare with REFERENCE.md's figures.
ANCHOR_CPP    ?= ../shared/benchmarks/anchor-cpp
ANCHOR_WORK   := build/anchor-cpp
ANCHOR_SOURCE ?= $(firstword $(wildcard ../.mirror/argallab+potential_fields/repo) build/anchor-src.git)
anchor: $(ANCHOR_WORK)/install/bin/pf_anchor_bench

$(ANCHOR_WORK)/install/bin/pf_anchor_bench:
	@mkdir -p build && test -d $(ANCHOR_CPP) || { echo "no $(ANCHOR_CPP): the C++ anchor is not built"; exit 1; }
	@test -e $(ANCHOR_SOURCE) || git clone --quiet --bare https://github.com/argallab/potential_fields $(ANCHOR_SOURCE)
	PYTHON=$(PYTHON) RUN_TESTS=0 $(ANCHOR_CPP)/build.sh $(ANCHOR_SOURCE) $(ANCHOR_WORK) > build/anchor-build.log 2>&1 \
		|| { echo "C++ anchor build failed, see build/anchor-build.log"; exit 1; }

# The numba engine: the last commit before the compiled core (ebecf3d, the parent of 8ee82a7 "The compiled core,
# stage 1") in its own git worktree and virtual environment, build/old-engine (git-ignored), installed by that
# commit's own Makefile (its venv and bench extras, its ROS 2 interfaces) and warmed up (`pfield warmup`, so that
# numba's compile is never timed). `make bench` runs each module there too, alternating old and new, and gives
# every row its new/old ratio (docs/core.md, "Comparing with the numba engine"). Once: ~10-20 min on 2 cores,
# log in build/old-engine.log; `make bench BENCH_ARGS=--no-old` runs without it.
OLD_ENGINE_COMMIT ?= ebecf3d37b3cf7703a6465eb818098e2756d745f
OLD_ENGINE        := build/old-engine
OLD_ENGINE_STAMP  := $(OLD_ENGINE)/.venv/.old-engine-ready
OLD_ENGINE_LOG    := build/old-engine.log
OLD_ENGINE_SHARED := build/shared
.PHONY: old-engine
old-engine: $(OLD_ENGINE_STAMP) $(OLD_ENGINE_SHARED)

# The worktree's benchmarks look for the MotionBenchMaker problems (bench_batch, bench_mbm) in ../shared from their
# project's root, which for build/old-engine is build/shared: a link to the same folder as ours, or those modules skip
# their old figures.
$(OLD_ENGINE_SHARED):
	@if test -d ../shared; then mkdir -p build && ln -sfn $(abspath ../shared) $@; fi

$(OLD_ENGINE_STAMP):
	@mkdir -p build && : > $(OLD_ENGINE_LOG)
	@test -e $(OLD_ENGINE)/.git || { git worktree prune && git worktree add --detach $(OLD_ENGINE) \
		$(OLD_ENGINE_COMMIT) >> $(OLD_ENGINE_LOG) 2>&1; } || { echo "numba engine: no git worktree of" \
		"$(OLD_ENGINE_COMMIT) in $(OLD_ENGINE) (see $(OLD_ENGINE_LOG)); make bench runs without old/new columns"; exit 1; }
	@echo "numba engine: installing $(OLD_ENGINE)/.venv (its Makefile's venv and bench extras), log in $(OLD_ENGINE_LOG)"
	@env -u PYTHONPATH -u VIRTUAL_ENV $(MAKE) --no-print-directory -C $(OLD_ENGINE) PYTHON=$(PYTHON) \
		.venv/.bench-installed >> $(OLD_ENGINE_LOG) 2>&1 || { echo "numba engine: its virtual environment did" \
		"not install (see $(OLD_ENGINE_LOG)); make bench runs without old/new columns"; exit 1; }
	@env -u PYTHONPATH -u VIRTUAL_ENV $(MAKE) --no-print-directory -C $(OLD_ENGINE) PYTHON=$(PYTHON) \
		ros2-interfaces >> $(OLD_ENGINE_LOG) 2>&1 || echo "numba engine: its ROS 2 interfaces did not build" \
		"(see $(OLD_ENGINE_LOG)); bench_ros2 will have no old figures"
	@echo "numba engine: pfield warmup (numba compiles every kernel once; minutes)"
	@cd $(OLD_ENGINE) && env -u PYTHONPATH -u VIRTUAL_ENV .venv/bin/pfield warmup >> $(abspath $(OLD_ENGINE_LOG)) 2>&1 \
		|| { echo "numba engine: pfield warmup failed (see $(OLD_ENGINE_LOG)); make bench runs without" \
		"old/new columns"; exit 1; }
	@git -C $(OLD_ENGINE) rev-parse HEAD > $@
	@echo "numba engine ready: $(OLD_ENGINE) at $$(cat $@)"

clean:
	rm -rf $(VENV) build demo_output .pytest_cache .mypy_cache .ruff_cache
