# The two commands the README promises: `make demo` and `make test`. Each runs the set-up first
# (scripts/setup.sh: apt-get for what is missing, nothing else), then builds: the demo only the
# three binaries and the packages they need, the tests everything. `make build` only builds (run
# `make setup` once on a new machine); a build directory is configured once, after which CMake
# re-configures itself when a CMakeLists.txt changes. Configure logs stay in the build directory.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: bench-goals all setup setup-build build build-demo demo test unit bench load load-quick soak fuzz format format-check clean

all: build

setup:
	@bash scripts/setup.sh test

setup-build:
	@bash scripts/setup.sh build

# Configures a new build directory with the tests; prints the log (and the hint) when CMake fails.
$(BUILD_DIR)/CMakeCache.txt:
	@mkdir -p $(BUILD_DIR)
	@cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS) -DLENSFARM_BUILD_TESTS=ON > $(BUILD_DIR)/configure.log 2>&1 || \
	  (cat $(BUILD_DIR)/configure.log; rm -f $(BUILD_DIR)/CMakeCache.txt; echo "missing packages? run: make setup"; exit 1)

build: $(BUILD_DIR)/CMakeCache.txt
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# The demo's build: a new build directory without the tests and benchmarks; an existing one keeps
# its setting (a developer's build with tests goes on building them with `make test`).
build-demo: setup-build
	@mkdir -p $(BUILD_DIR)
	@if [ ! -f $(BUILD_DIR)/CMakeCache.txt ]; then \
	  cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS) -DLENSFARM_BUILD_TESTS=OFF > $(BUILD_DIR)/configure.log 2>&1 || \
	    (cat $(BUILD_DIR)/configure.log; rm -f $(BUILD_DIR)/CMakeCache.txt; exit 1); fi
	@cmake --build $(BUILD_DIR) -j $(JOBS) --target lensfarm lensfarm-coordinator lensfarm-worker

# A coordinator and two workers on localhost render the seed scene into out/ (scripts/demo.sh).
demo: build-demo
	@BUILD_DIR=$(BUILD_DIR) bash scripts/demo.sh

# A build directory the demo made without tests is switched to build them.
test: setup
	@if grep -qs '^LENSFARM_BUILD_TESTS:BOOL=OFF' $(BUILD_DIR)/CMakeCache.txt; then \
	  cmake -S . -B $(BUILD_DIR) -DLENSFARM_BUILD_TESTS=ON > $(BUILD_DIR)/configure.log 2>&1 || (cat $(BUILD_DIR)/configure.log; exit 1); fi
	@$(MAKE) --no-print-directory build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

# The unit tests alone (CTest label unit: no process, network or browser; about a minute).
unit: build
	cd $(BUILD_DIR) && ctest -L unit -j $(JOBS)

bench: build
	$(BUILD_DIR)/bench/lensfarm-bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
	$(BUILD_DIR)/bench/lensfarm-ingest-bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
	BUILD_DIR=$(BUILD_DIR) bash bench/farm_efficiency.sh 3
	$(BUILD_DIR)/bench/lensfarm-ray-limit --repeat 5
	BUILD_DIR=$(BUILD_DIR) bash bench/whole_process.sh 7

# The accuracy-per-second goals of docs/performance.md (references are rendered once and cached in
# $(BUILD_DIR)/accuracy-goals-cache: about 7 minutes the first time on 2 cores, then about 6).
bench-goals: build
	$(BUILD_DIR)/bench/lensfarm-accuracy-goals --repeat 5

# libFuzzer targets for the scene parser, the glTF and USD importers, the upload path and lens files, built with clang in build-fuzz,
# each run for FUZZ_SECONDS. A finding stops the run with the crashing input in build-fuzz/.
FUZZ_SECONDS ?= 60
fuzz:
	@bash scripts/setup.sh fuzz
	@mkdir -p build-fuzz
	@cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DLENSFARM_FUZZ=ON -DLENSFARM_WERROR=OFF -DLENSFARM_BUILD_TESTS=OFF > build-fuzz/configure.log 2>&1 || (cat build-fuzz/configure.log; exit 1)
	@cmake --build build-fuzz -j $(JOBS) --target scene_parser_fuzz gltf_import_fuzz upload_fuzz lens_fuzz usd_import_fuzz
	@mkdir -p build-fuzz/scene-corpus && cp scenes/*.json build-fuzz/scene-corpus/
	cd build-fuzz && ./tests/fuzz/scene_parser_fuzz -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 \
	  -artifact_prefix=scene- scene-corpus
	cd build-fuzz && ./tests/fuzz/gltf_import_fuzz -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 -artifact_prefix=gltf-
	cd build-fuzz && ./tests/fuzz/upload_fuzz -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 -artifact_prefix=upload-
	@mkdir -p build-fuzz/lens-corpus && cp scenes/lenses/*.dat build-fuzz/lens-corpus/
	cd build-fuzz && ./tests/fuzz/lens_fuzz -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 -artifact_prefix=lens- lens-corpus
	@mkdir -p build-fuzz/usd-corpus && cp scenes/usd/*.usda build-fuzz/usd-corpus/
	cd build-fuzz && ./tests/fuzz/usd_import_fuzz -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 -artifact_prefix=usd- usd-corpus

# The farm at scale (docs/performance.md "The farm at scale"): 1,000 simulated workers
# against one lensfarm-coordinator process over gRPC, a 3840x2160 still and a 240-frame 1920x1080
# animation, each on a fresh coordinator. Prints the table and writes $(BUILD_DIR)/scale.json.
# LOAD_FLAGS adds or overrides flags (docs/performance.md's figures: LOAD_FLAGS=--audit-fraction 0).
LOAD_FLAGS ?=
load: build
	$(BUILD_DIR)/bench/lensfarm-scale --workers 1000 --json $(BUILD_DIR)/scale.json $(LOAD_FLAGS)
# The same at 200 workers on small frames (15 s); the test suite runs it too.
load-quick: build
	$(BUILD_DIR)/bench/lensfarm-scale --workers 200 --still 960x540 --animation 480x270 --frames 24 --tile-size 64 \
	  $(LOAD_FLAGS)

# The bounded soak test of one coordinator: 64 simulated workers for 60 s, some killed mid-unit.
soak: build
	$(BUILD_DIR)/bench/lensfarm-load --workers 64 --seconds 60

clean:
	rm -rf $(BUILD_DIR) build-fuzz out

# The style (.clang-format) applied to every source; `make test` checks it (Style.*).
FORMAT_SOURCES = find common coordinator worker client proto tests bench \( -name '*.h' -o -name '*.cpp' \) -not -path '*/node_modules/*' -print0
format:
	@$(FORMAT_SOURCES) | xargs -0 clang-format -i
format-check:
	@$(FORMAT_SOURCES) | xargs -0 clang-format --dry-run --Werror
