# weldtwin: the two commands of the README, plus benchmarks. Every target installs what is missing first.
BUILD ?= build
JOBS  ?= $(shell nproc)
OUT   ?= out
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release
# ccache: paths relative to the checkout, so that clones elsewhere share the cache.
export CCACHE_BASEDIR := $(CURDIR)

.PHONY: install setup configure build run test test-sanitize test-without-options bench random-bench coverage localize-survey fuzz-build fuzz format clean

setup:
	@bash scripts/setup

configure: setup
	@cmake -S . -B $(BUILD) $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD) -j$(JOBS)

# The main job on the default cell: sweep -> localize -> plan -> replay in MuJoCo -> report.
run: build
	@mkdir -p $(OUT)
	@$(BUILD)/app/weldtwin run scenes/cells/default.yaml --out $(OUT)/run; \
	  status=$$?; echo "make run: report in $(OUT)/run/report.html"; exit $$status

# weldtwin and its scenes under PREFIX (bin/weldtwin, share/weldtwin/scenes); it runs from there on its own.
PREFIX ?= /usr/local
install: build
	@cmake --install $(BUILD) --prefix $(PREFIX) --strip

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

# The test suite built with AddressSanitizer and UndefinedBehaviorSanitizer (gcc, -O1, line tables) and run
# with every report fatal (leaks too, but for the third-party ones tests/sanitize/lsan.supp names; a SEGV is
# left to kill the process, as bench's injected crash must). Trimmed of what only repeats the end-to-end runs
# at ten times the cost (run_<cell>: ten weldtwin runs each; the examples; the browser test; the cluster
# tests; the install tree's run and run-against-bench agreement, whose stages weld_pipeline_test runs in
# process) and of the instrumentation of the three files that instantiate PCL's templates
# (perception/CMakeLists.txt); every reader's test runs. intercept_tls_get_addr=0: the runtime of gcc 12 (and
# of LLVM up to 16) takes a thread-local block that malloc happened to place 16 bytes past a 4 kB boundary for
# a pre-2.25 glibc header and reads the words before it; the leak check's thread-stopping tracer then dies
# ("Tracer caught signal 11") on the way out of a process that had no leak, about one run in a few hundred.
SANITIZE_SKIP ?= ^(run_|example_|report_browser_test|cluster_bench_|install_test|pipeline_agreement_test)
test-sanitize: setup
	@cmake -S . -B $(BUILD)-sanitize -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
	  -DCMAKE_C_FLAGS_DEBUG="-O1 -g1" -DWELDTWIN_SANITIZE=ON -DWELDTWIN_BUILD_BENCHMARKS=OFF >/dev/null
	@CCACHE_NOHASHDIR=1 cmake --build $(BUILD)-sanitize -j$(JOBS)
	@cd $(BUILD)-sanitize && ASAN_OPTIONS=detect_leaks=1:handle_segv=0:detect_stack_use_after_return=0:intercept_tls_get_addr=0 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/sanitize/lsan.supp:print_suppressions=0 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ctest --output-on-failure -j$(JOBS) -E '$(SANITIZE_SKIP)'

# weldtwin built without its optional parts (ROS bags, OMPL, OSMesa: WELDTWIN_WITH_*=OFF): it links none of
# them, welds (the default cell, or says a transit there needs the left-out search), and says "built without ..."
# where one is asked for.
test-without-options: setup
	@cmake -S . -B $(BUILD)-minimal $(CMAKE_FLAGS) -DWELDTWIN_WITH_ROSBAG=OFF -DWELDTWIN_WITH_OMPL=OFF \
	  -DWELDTWIN_WITH_OSMESA=OFF -DWELDTWIN_BUILD_TESTS=OFF -DWELDTWIN_BUILD_BENCHMARKS=OFF >/dev/null
	@cmake --build $(BUILD)-minimal -j$(JOBS) --target weldtwin
	@bash tests/app/without_options_test.sh $(BUILD)-minimal/app/weldtwin

bench: build
	$(BUILD)/benchmarks/weldtwin_bench --benchmark_min_time=0.5

# The randomized-pose benchmark: TRIALS random cells end to end, ours and the paper's method side by side, and
# its report (out/bench/report.html). About 7 minutes for 1000 trials on 2 cores (up to 10 on slower hosts).
TRIALS ?= 1000
random-bench: build
	@mkdir -p $(OUT)/bench
	$(BUILD)/app/weldtwin bench --trials $(TRIALS) --seed 1 --jobs $(JOBS) --out $(OUT)/bench/results.jsonl
	$(BUILD)/app/weldtwin bench-report $(OUT)/bench/results.jsonl --out $(OUT)/bench

# What the default sweep sees of each part at 50 random layouts, and how often each can be welded (minutes).
coverage: build
	$(BUILD)/benchmarks/sweep_coverage --layouts 50 scenes/cells/default.yaml scenes/cells/round_on_plate.yaml \
	  scenes/cells/tube_tee.yaml
	$(BUILD)/benchmarks/plan_survey --layouts 100 scenes/cells/default.yaml scenes/cells/round_on_plate.yaml \
	  scenes/cells/tube_tee.yaml

# Randomized localization benchmark: 200 seeded cells per part, ours and the paper's method on the same scans,
# absent/wrong-part cases (an hour or more on 2 cores). Data from elsewhere by path, when given:
#   make localize-survey SAMPLES=DIR REAL=DIR   (scans with truth.json; real scans with nominal.json)
SAMPLES ?=
REAL ?=
localize-survey: build
	@mkdir -p $(OUT)
	$(BUILD)/benchmarks/localize_survey $(if $(SAMPLES),--samples $(SAMPLES)) $(if $(REAL),--real $(REAL)) \
	  --layouts 200 --jobs 2 --impostor-layouts 40 --csv $(OUT)/localize_survey.csv \
	  scenes/cells/default.yaml scenes/cells/round_on_plate.yaml scenes/cells/tube_tee.yaml \
	  scenes/cells/offset_tube_on_plate.yaml scenes/cells/rect_tee_flat.yaml scenes/cells/paper_tee.yaml

# libFuzzer harnesses of the readers (clang, with AddressSanitizer and UndefinedBehaviorSanitizer): cloud (PCD,
# PLY), mesh (STL, PLY, OBJ), part and cell specs (YAML), ScanLog, pose and plan JSON, ROS 1 and ROS 2 bags, the
# RPLIDAR byte streams, the robot controller's messages. `make fuzz` runs each for FUZZ_SECONDS from seeds made by
# fuzz/make_seeds.py (and the corpus kept in $(BUILD)-fuzz/corpus); a finding stops it with the input saved.
# FUZZ_REAL=DIR adds real files (bags, RPLIDAR captures, controller messages) from DIR to the seeds.
FUZZ_SECONDS ?= 600
FUZZ_HARNESSES ?= cloud mesh part_spec cell_spec scan_log pose_plan ros_bag rplidar aubo_messages part_file
FUZZ_REAL ?=
# FUZZ_RUNS=N stops a harness after N executions (or FUZZ_SECONDS, whichever comes first; -1: no count).
FUZZ_RUNS ?= -1
fuzz-build: setup
	@cmake -S fuzz -B $(BUILD)-fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null
	@cmake --build $(BUILD)-fuzz -j$(JOBS)

fuzz: fuzz-build
	@python3 fuzz/make_seeds.py $(BUILD)-fuzz/seeds --seed-bags $(BUILD)-fuzz/seed_bags $(if $(FUZZ_REAL),--real $(FUZZ_REAL))
	@for h in $(FUZZ_HARNESSES); do \
	  mkdir -p $(BUILD)-fuzz/corpus/$$h $(BUILD)-fuzz/findings; \
	  echo "fuzz: $$h for $(FUZZ_SECONDS) s"; \
	  case $$h in ros_bag) len=16384;; aubo_messages) len=4096;; part_spec|cell_spec|pose_plan) len=8192;; \
	    *) len=65536;; esac; \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/sanitize/lsan.supp \
	  $(BUILD)-fuzz/fuzz_$$h -max_total_time=$(FUZZ_SECONDS) -runs=$(FUZZ_RUNS) -rss_limit_mb=2048 -max_len=$$len -timeout=10 \
	    -artifact_prefix=$(BUILD)-fuzz/findings/$$h- -print_final_stats=1 \
	    $(BUILD)-fuzz/corpus/$$h $(BUILD)-fuzz/seeds/$$h 2>$(BUILD)-fuzz/$$h.log || \
	    { tail -30 $(BUILD)-fuzz/$$h.log; exit 1; }; \
	  grep -E "stat::number_of_executed_units|Done" $(BUILD)-fuzz/$$h.log | tr '\n' ' '; echo; \
	done

format:
	@git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(OUT)
