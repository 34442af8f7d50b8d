# Bootstrap, run and test affine_joint_sim in a Python 3.12 virtual environment.
# `make venv` is idempotent: it reinstalls only when setup.py or the constraints change, and
# builds the interface packages without a wheel only when their definitions change.

# DDS discovery stays on loopback for every process started from here.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST

VENV := .venv
PY := $(VENV)/bin/python
CONSTRAINTS := constraints.txt
STAMP := $(VENV)/.installed
LOCK_VENV := .venv-lock

# Prints the first interpreter that really is Python 3.12: `python3.12` on PATH (a pyenv shim
# there may still fail to resolve, so each candidate is run), else the newest
# ~/.pyenv/versions/3.12.x.
FIND_PY312 = for p in python3.12 $$(ls -d $$HOME/.pyenv/versions/3.12.*/bin/python3.12 \
	2>/dev/null | sort -rV); do \
	  $$p -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' 2>/dev/null \
	    && { echo $$p; exit 0; }; \
	done; \
	echo 'error: Python 3.12 not found; install it (pyenv install 3.12, or a system python3.12)' >&2; \
	exit 1

# setuptools comes from the constraints and builds in the venv (no isolated build environment),
# so every tool that touches the install is pinned.
define install_project
	$(1) -m pip install -q $(2) setuptools
	$(1) -m pip install -q --no-build-isolation $(2) -e '.[test,interfaces]'
endef

.PHONY: venv run lint test bench bags replay gallery gpu-prep lock clean

# tf2_msgs and simulation_interfaces have no wheel: tools/build_interfaces.py builds them from
# interfaces/ into the venv, once (it returns at once when they are built from the same files).
venv: $(STAMP)
	@$(PY) tools/build_interfaces.py

$(STAMP): setup.py $(CONSTRAINTS)
	@test -x $(PY) || { py=$$($(FIND_PY312)) && echo "Creating $(VENV) with $$py" \
	  && $$py -m venv $(VENV); }
	@echo 'Installing affine_joint_sim[test,interfaces] into $(VENV) under $(CONSTRAINTS)'
	$(call install_project,$(PY),-c $(CONSTRAINTS))
	@touch $@

# The node and the demo PD controller, closed loop over DDS; records a bag under results/.
run: venv
	$(VENV)/bin/affine-joint-sim demo --record results/demo-$$(date +%Y%m%d-%H%M%S)

# Regenerates the sample bags in bags/ with the project's own recorder: the demo (lockstep PD
# loop) and a torque step response (2 N·m on the pendulum's shoulder, sent while it runs). The
# torque tool starts 1 s after the node (which is up after ~1.1 s here): the tool waits for the
# node's subscriber itself, and one started later than ~1.5 s found the 2.5 s run already over.
bags: venv
	rm -rf bags/demo_pd bags/torque_step
	$(VENV)/bin/affine-joint-sim demo --duration 3 --record bags/demo_pd
	$(VENV)/bin/affine-joint-sim run --mode realtime --duration 2.5 --record bags/torque_step & \
	  sleep 1 && $(VENV)/bin/affine-joint-sim torque shoulder 2.0; wait

# Re-simulates a bag and compares it with its recorded joint states: make replay BAG=DIR
# (default: the demo sample bag).
replay: venv
	$(VENV)/bin/affine-joint-sim replay $(or $(BAG),bags/demo_pd)

# The README's pictures, drawn from bags recorded here (results/gallery/): the make-run demo,
# the URDF arm with its gripper under the demo PD controller, the quadruped standing on the
# ground under it, a box sliding down a ramp onto the ground, 27 boxes tumbling into a bin and
# the arm grasping a cube on a table under the demo controller's grasp script.
GALLERY_RENDER := --fps 12 --width 640 --height 360
gallery: venv
	rm -rf results/gallery && mkdir -p results/gallery docs
	$(VENV)/bin/affine-joint-sim demo --duration 3 --record results/gallery/demo
	$(VENV)/bin/affine-joint-sim render results/gallery/demo --out docs/demo.gif $(GALLERY_RENDER)
	$(VENV)/bin/affine-joint-sim demo --scene arm6_gripper --target shoulder_pan=1.2 \
	  --target shoulder_lift=0.5 --target elbow=1.2 --kp 150 --kd 15 --duration 3 \
	  --record results/gallery/arm6
	$(VENV)/bin/affine-joint-sim render results/gallery/arm6 --out docs/arm6.gif $(GALLERY_RENDER) \
	  --view=-50,25
	$(VENV)/bin/affine-joint-sim demo --scene quadruped --duration 1.5 --record results/gallery/quadruped
	$(VENV)/bin/affine-joint-sim render results/gallery/quadruped --out docs/quadruped.gif \
	  $(GALLERY_RENDER) --view=-35,15
	$(VENV)/bin/affine-joint-sim run --scene ramp --mode fast --duration 2 --record results/gallery/ramp
	$(VENV)/bin/affine-joint-sim render results/gallery/ramp --out docs/ramp.gif $(GALLERY_RENDER) \
	  --view=-80,15
	$(VENV)/bin/affine-joint-sim run --scene pile --mode fast --duration 2 --record results/gallery/pile
	$(VENV)/bin/affine-joint-sim render results/gallery/pile --out docs/pile.gif $(GALLERY_RENDER) \
	  --view=-60,65
	$(VENV)/bin/affine-joint-sim demo --scene grasp --duration 3 --record results/gallery/grasp
	$(VENV)/bin/affine-joint-sim render results/gallery/grasp --out docs/grasp.gif $(GALLERY_RENDER) \
	  --view=-70,12

# The linter (rules in ruff.toml) first: it takes well under a second.
lint: venv
	$(VENV)/bin/ruff check .

test: lint
	$(PY) -m pytest -q test

bench: venv
	$(VENV)/bin/affine-joint-sim bench

# Prepares the GPU check (affine_joint_sim/bench/device_check.py) for a lent GPU machine that has
# no compiler time to spare and no package index: the workplace's gpu-prep hook packs Warp and
# compiles every step kernel variant of both precisions for sm_90 ahead of time (0.5–2 min each
# on 2 cores: README, "Compiling for a GPU"). Then the cubins move to where Warp 1.19 reads its
# cache (<WARP_CACHE_PATH>/<version>/; the hook writes one level up), NVRTC's compile-time traces
# (10 MB no run reads) go, the URDF scenes' readers join the wheels (pure Python; the device's
# Python has lxml, numpy and six) and the CPU float64 reference trajectories are written beside
# them. The hook prints the two device calls; the second runs
#   python3 -m affine_joint_sim.bench.device_check run --reference .gpu-extra/reference.npz
GPU_PREP ?= ../shared/hooks/gpu-prep
WARP_VERSION = $(shell grep -i '^warp-lang==' constraints.txt | cut -d= -f3)
gpu-prep: venv
	$(GPU_PREP) --register 'from affine_joint_sim.bench.device_check import register; register()' \
	    $$($(PY) -m affine_joint_sim.bench.device_check modules)
	cd .gpu-extra/kernels && mkdir -p $(WARP_VERSION) && mv wp_* $(WARP_VERSION)/ \
	    && rm -f */*/*compile-time-trace*
	$(PY) -m pip download -q --no-deps -d .gpu-extra/wheels \
	    $$(grep -i '^yourdfpy==\|^trimesh==' constraints.txt)
	$(PY) -m affine_joint_sim.bench.device_check reference .gpu-extra/reference.npz

# Re-resolves every dependency to its newest allowed version in a scratch venv and pins the
# result; `make venv` then brings $(VENV) to it.
lock:
	rm -rf $(LOCK_VENV)
	py=$$($(FIND_PY312)) && $$py -m venv $(LOCK_VENV)
	$(call install_project,$(LOCK_VENV)/bin/python,)
	{ echo '# Known-good versions of every distribution in the venv; regenerate with `make lock`.'; \
	  echo '# The unprefixed ROS names (rclpy, std_msgs, ...) are metadata inside the ros-* wheels.'; \
	  $(LOCK_VENV)/bin/python -m pip freeze --all --exclude-editable --exclude pip; \
	} > $(CONSTRAINTS)
	rm -rf $(LOCK_VENV)

# Leaves the Warp kernel cache (~/.cache/warp) alone: rebuilding it costs minutes.
clean:
	rm -rf $(VENV) $(LOCK_VENV) .pytest_cache build *.egg-info
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
