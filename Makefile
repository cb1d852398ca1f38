# Two commands on a fresh Debian 12 machine (as root):  `make run`  and  `make test`.
# Each installs what it needs (apt packages, the venv, the catkin build) and skips what is done.
SHELL := /bin/bash
.DEFAULT_GOAL := help
TOP    := $(abspath .)
VENV   := $(TOP)/.venv
WS     := $(shell tools/ws-path)
APT_STAMP  := build/.apt-stamp
VENV_STAMP := $(VENV)/.stamp
ENV    := source $(TOP)/tools/env.sh &&

# Options for run / wander / sim: WORLD ROBOT STRATEGY CONTROLLER PLANNER OCTOMAP MISSION SLAM RTF SEED BUDGET
# DURATION RVIZ SAVED_MAP are the launch files' arguments, passed only when the user sets them
# (make VAR=value, or the environment): their defaults live in the launch files and config/*.yaml.
# on purpose: make's own run directory, inside the checkout (the launch files' is under ROS_HOME)
OUTPUT   ?= output/run
# name:=$(VAR) when the user set VAR, else nothing: $(call arg,VAR,name)
arg = $(if $(filter command line environment,$(origin $(1))),$(2):=$($(1)))
RUN_ARGS = $(strip $(call arg,WORLD,world) $(call arg,ROBOT,robot) $(call arg,STRATEGY,strategy) \
  $(call arg,CONTROLLER,controller) $(call arg,PLANNER,planner) $(call arg,OCTOMAP,octomap) $(call arg,MISSION,mission) $(call arg,SLAM,slam) $(call arg,RTF,rtf) \
  $(call arg,SEED,seed) $(call arg,BUDGET,budget) $(call arg,RVIZ,rviz))
WANDER_ARGS = $(strip $(call arg,WORLD,world) $(call arg,ROBOT,robot) $(call arg,RTF,rtf) $(call arg,SEED,seed) \
  $(call arg,DURATION,duration) $(call arg,RVIZ,rviz))

.PHONY: help setup build test run wander sim bench-sim bench-map bench-tags bench-explore bench-slam bench-control bench-nav bench-plan bench-faults slam-log slam-eval worlds clean

help:
	@echo "make test        install everything needed, build, run all tests (pytest + rostest)"
	@echo "make run         explore a world headless; map, plots and report in OUTPUT=$(OUTPUT)"
	@echo "                 (WORLD ROBOT STRATEGY CONTROLLER PLANNER OCTOMAP MISSION SLAM RTF SEED BUDGET RVIZ SAVED_MAP: the arguments"
	@echo "                 of launch/explore_sim.launch, which names the choices; unset: its and config/*.yaml's defaults)"
	@echo "make wander      the simulator with a scripted wander and the mapper (no exploration; WORLD ROBOT RTF SEED"
	@echo "                 DURATION RVIZ: launch/run_sim.launch's arguments)"
	@echo "make sim         the simulator with rviz, for interactive use (drive it with /cmd_vel; WORLD ROBOT SEED)"
	@echo "make slam-log LOG=FILE OUTPUT=DIR   SLAM over a rosbag or CARMEN log: trajectory.tum, odometry.tum, map, graph.g2o"
	@echo "                 (MAP=map.yaml [INITIAL_POSE='x y yaw']: track the log in that saved map instead)"
	@echo "make slam-eval TRAJ=FILE GT=FILE [RELATIONS=FILE] [ALIGN=1]   ATE and the relations metric (TUM files)"
	@echo "make bench-slam  SLAM: recorded drives at 4 drifts, city10000, explorations with SLAM, tag missions"
	@echo "                 with SLAM, tags landmarks in the graph or not -> output/bench/slam.json"
	@echo "                 (LIVE=0 offline parts only, SEEDS=N SLAM explorations per world (3), TAG_WORLDS=a,b (house),"
	@echo "                 TAG_SEEDS=N tag missions per world (1), RESUME=1, DRIVE_S=sim s per recorded drive)"
	@echo "make bench-sim   simulator benchmark -> output/bench/sim.json"
	@echo "make bench-map   mapping/planning core benchmark -> output/bench/map.json"
	@echo "make bench-control  seed 000's noisy unicycle and racetrack (MPPI vs Tube MPPI) and the controllers'"
	@echo "                 cycle times -> output/bench/control.json, figures in output/bench/control/ (RUNS=N)"
	@echo "make bench-nav   every controller over 30 start/goal pairs per world (house, office, maze) in the"
	@echo "                 simulator, drifting odometry + localisation -> output/bench/nav.json (POSE=truth, PAIRS=N)"
	@echo "make bench-plan  global planners (lattice, A* + shortcut, seed 003's RRT, OMPL at 0.05 and 0.2 s, 1 s on the real"
	@echo "                 maps) over 30 reachable start/goal pairs per world and robot, every shipped world, depot and"
	@echo "                 tb3_sandbox -> output/bench/plan.json"
	@echo "                 (WORLDS=house,../shared/worlds/depot.yaml PAIRS=N PLANNERS=lattice,astar_shortcut,rrt_seed003,ompl"
	@echo "                 ROBOTS=turtlebot3_burger,... SEED=N; EXPLORE_3D=0: without the 3-D check, a TurtleBot 2 exploring"
	@echo "                 the house with low furniture, OctoMap layer on and off)"
	@echo "make bench-faults  faults injected during short explorations (each node killed, scans stalled/dropped, TF"
	@echo "                 delayed, the clock jumped back, a full disk), two runs side by side, the bad-input catalogue"
	@echo "                 -> output/bench/faults.json, a copy in docs/results/ (CASES=a,b SOAK=N SEED=N)"
	@echo "make bench-explore  recon and the oracle x worlds x 3 seeds, 2 at a time (<= 1 h) -> output/bench/explore.json,"
	@echo "                 plots in output/bench/explore/, a copy in docs/results/ to commit; held-out rows (garden, doors,"
	@echo "                 cluttered with the burger and the waffle_pi: 1 seed) reported apart (heldout_*)"
	@echo "                 (FULL=1 3 seeds on the held-out rows and the warehouse, beyond the hour; BASELINES=1 adds the"
	@echo "                 five baselines; QUICK=1 its small subset; STRATEGIES=recon,nearest WORLDS=house SEEDS=N"
	@echo "                 JOBS=N ROBOT= ROBOTS=maze=...,cluttered=a+b BUDGET=sim s for all | BUDGETS=house=600,..."
	@echo "                 RESUME=1 reuses finished runs, REPORT=1 runs nothing: table and explore.json from the runs on disk,"
	@echo "                 DRY_RUN=1 prints the plan and its estimated wall time, SWEEP=name writes output/bench/name/ and"
	@echo "                 name.json instead, LAUNCH_ARGS='controller:=dwa slam:=false' more explore_sim.launch arguments"
	@echo "                 for every run; TABLE=1 runs nothing: docs/benchmarks.md's table from the newest committed sweep)"

$(APT_STAMP): tools/apt-packages.txt
	@mkdir -p build
	@missing=$$(for p in $$(cat tools/apt-packages.txt); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q "ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "[setup] apt-get install:" $$missing; \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update -q && apt-get install -y -q --no-install-recommends $$missing; \
	fi
	@touch $@

$(VENV_STAMP): $(APT_STAMP) tools/requirements.txt
	@[ -x $(VENV)/bin/python ] || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(VENV)/bin/pip install -q --disable-pip-version-check -r tools/requirements.txt
	@touch $@

# roslaunch resolves "localhost" (its local machine) even with a loopback master; a system with
# no /etc/hosts (a bare chroot) gets Debian's standard loopback lines, once.
setup: $(VENV_STAMP)
	@getent hosts localhost >/dev/null || { echo "[setup] 'localhost' does not resolve: adding it to /etc/hosts (roslaunch needs it)"; \
	  printf '127.0.0.1\tlocalhost\n::1\tlocalhost ip6-localhost ip6-loopback\n' >> /etc/hosts; }

build: setup
	@mkdir -p $(WS)/src
	@ln -sfn $(TOP) $(WS)/src/turtlebot_recon
	@cd $(WS) && PATH=$(VENV)/bin:$$PATH catkin_make -DCMAKE_BUILD_TYPE=Release \
	  -DPYTHON_EXECUTABLE=$(VENV)/bin/python -DPython3_EXECUTABLE=$(VENV)/bin/python \
	  -DCATKIN_ENABLE_TESTING=OFF > $(TOP)/build/catkin_make.log 2>&1 \
	  || { tail -50 $(TOP)/build/catkin_make.log; exit 1; }
	@echo "[setup] catkin build ok (log: build/catkin_make.log)"

test: build
	$(ENV) python -m pytest test -q -p no:cacheprovider

run: build
	@echo "[run] exploring headless: explore_sim.launch $(or $(RUN_ARGS),with its defaults); output in $(OUTPUT)"
	@$(ENV) tools/launch --tag run --done evaluator --report $(abspath $(OUTPUT))/report.json explore_sim.launch \
	  $(RUN_ARGS) output:=$(abspath $(OUTPUT)) end_with_evaluator:=false \
	  $(if $(SAVED_MAP),saved_map:=$(abspath $(SAVED_MAP)))

wander: build
	@$(ENV) tools/launch --tag wander --done scripted_drive --report $(abspath $(OUTPUT))/report.json run_sim.launch \
	  $(WANDER_ARGS) output:=$(abspath $(OUTPUT)) end_with_driver:=false

sim: build
	@$(ENV) tools/launch --tag sim sim.launch $(call arg,WORLD,world) $(call arg,ROBOT,robot) $(call arg,SEED,seed) rviz:=true

bench-sim: build
	$(ENV) python test/benchmarks/bench_sim.py

bench-map: build
	$(ENV) python test/benchmarks/bench_map.py

# Seed 000's experiments (a noisy unicycle to a waypoint, a racetrack), outside ROS, and the
# cycle times of MPPI, its numpy twin, Tube MPPI (and DWA once bound); RUNS=N runs per controller in (a).
bench-control: build
	$(ENV) python test/benchmarks/bench_control.py $(if $(RUNS),--runs $(RUNS))

# Every controller over the same 30 start/goal pairs per world (house, office, maze), the
# navigator's core driving the simulator outside ROS, drifting odometry + map localisation
# (POSE=truth: the true pose); CONTROLLERS=a,b WORLDS=a,b PAIRS=N JOBS=N RESUME=1.
bench-nav: build
	@$(ENV) python test/benchmarks/bench_nav.py $(if $(CONTROLLERS),--controllers $(CONTROLLERS)) \
	  $(if $(WORLDS),--worlds $(WORLDS)) $(if $(PAIRS),--pairs $(PAIRS)) $(if $(JOBS),--jobs $(JOBS)) \
	  $(if $(POSE),--pose $(POSE)) $(if $(RESUME),--resume)

# Every global planner over the same seeded start/goal pairs (reachable by the lattice), both
# TurtleBot 3 footprints, one call at a time (OMPL's budgets are wall time); WORLDS=a,b PAIRS=N
# PLANNERS=a,b ROBOTS=a,b SEED=N.
bench-plan: build
	@$(ENV) python test/benchmarks/bench_plan.py $(if $(WORLDS),--worlds $(WORLDS)) $(if $(PAIRS),--pairs $(PAIRS)) \
	  $(if $(PLANNERS),--planners $(PLANNERS)) $(if $(ROBOTS),--robots $(ROBOTS)) $(if $(SEED),--seed $(SEED)) \
	  $(if $(EXPLORE_3D),--explore-3d $(EXPLORE_3D))

# Detection on the same frames for both back-ends, then the tag missions (QUICK=1: the
# detection table only; WORLDS=..., SEEDS=N, RESUME=1 for the missions).
bench-tags: build
	@$(ENV) python test/benchmarks/bench_tags.py $(if $(QUICK),--quick) $(if $(WORLDS),--worlds $(WORLDS)) \
	  $(if $(SEEDS),--seeds $(SEEDS)) $(if $(RESUME),--resume)

# Recorded drives at four drifts (offline SLAM vs odometry), city10000, then the full
# explorations with SLAM at the default drift (SEEDS per world, 3) and the tag missions
# (TAG_WORLDS, house; TAG_SEEDS, 1) (LIVE=0: the offline parts only).
bench-slam: build
	@$(ENV) python test/benchmarks/bench_slam.py $(if $(filter 0,$(LIVE)),,--live) $(if $(SEEDS),--seeds $(SEEDS)) \
	  $(if $(TAG_WORLDS),--tag-worlds $(TAG_WORLDS)) $(if $(TAG_SEEDS),--tag-seeds $(TAG_SEEDS)) \
	  $(if $(RESUME),--resume) $(if $(DRIVE_S),--drive-s $(DRIVE_S))

# The bench's own defaults (recon and the oracle, the shipped, real and held-out worlds, 3 seeds
# but 1 on the held-out rows, 2 at a time, the waffle_pi but both TurtleBot 3s on cluttered,
# budgets from the committed oracle times) apply unless a variable is given; QUICK=1 is its
# subset for iteration; ROBOT and BUDGET only when set by the user (ROBOTS=maze=...,house=... per
# world). Every sweep's json is copied to docs/results/ to be committed.
bench-explore: build
	@$(ENV) python test/benchmarks/bench_explore.py $(if $(QUICK),--quick) $(if $(STRATEGIES),--strategies $(STRATEGIES)) \
	  $(if $(WORLDS),--worlds $(WORLDS)) $(if $(SEEDS),--seeds $(SEEDS)) $(if $(JOBS),--jobs $(JOBS)) \
	  $(if $(filter command line environment,$(origin ROBOT)),--robot $(ROBOT)) \
	  $(if $(filter command line environment,$(origin BUDGET)),--budget $(BUDGET)) \
	  $(if $(BUDGETS),--budgets $(BUDGETS)) $(if $(ROBOTS),--robots $(ROBOTS)) $(if $(RESUME),--resume) $(if $(REPORT),--report) \
	  $(if $(DRY_RUN),--dry-run) $(if $(SWEEP),--name $(SWEEP)) $(if $(LAUNCH_ARGS),--launch-args "$(LAUNCH_ARGS)") \
	  $(if $(FULL),--full) $(if $(BASELINES),--baselines) $(if $(TABLE),--table) --copy-results

# Faults injected during short house explorations (docs/faults.md): each node killed, scans
# stalled / dropped, TF delayed, the clock jumped back, the run directory's disk full; two runs
# side by side; the bad-input catalogue -> output/bench/faults.json (12 min on 2 cores, 2026-12-06; CASES=a,b a subset,
# SOAK=N adds N short explorations of random worlds and seeds, counting crashes and leaks).
bench-faults: build
	@$(ENV) python test/benchmarks/bench_faults.py $(if $(CASES),--cases $(CASES)) $(if $(SOAK),--soak $(SOAK)) \
	  $(if $(filter command line environment,$(origin SEED)),--seed $(SEED)) --copy-results

slam-log: build
	@[ -n "$(LOG)" ] || { echo "slam-log: give LOG=FILE (a .bag or a CARMEN log) and OUTPUT=DIR"; exit 2; }
	@$(ENV) python tools/slam_log.py --log $(LOG) --output $(OUTPUT) $(if $(ROBOT),--robot $(ROBOT)) \
	  $(if $(MAP),--map $(MAP)) $(if $(INITIAL_POSE),--initial-pose $(INITIAL_POSE))

slam-eval: setup
	@[ -n "$(TRAJ)" ] && [ -n "$(GT)" ] || { echo "slam-eval: give TRAJ=FILE and GT=FILE (TUM)"; exit 2; }
	@$(ENV) python tools/slam_eval.py --traj $(TRAJ) --gt $(GT) $(if $(RELATIONS),--relations $(RELATIONS)) $(if $(ALIGN),--align)

worlds: build
	$(ENV) python -m turtlebot_recon.sim.worldgen worlds

clean:
	rm -rf build output
