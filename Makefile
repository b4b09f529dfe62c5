# The two commands the README promises: `make demo` and `make test`.
# Both run the set-up first (apt-get for what is missing), then build.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: all setup configure build demo test bench load clean

all: build

setup:
	@bash scripts/setup.sh

configure: setup
	@cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS) > $(BUILD_DIR).configure.log 2>&1 || (cat $(BUILD_DIR).configure.log; exit 1)

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# A coordinator and two workers on localhost render the seed scene into out/ (scripts/demo.sh).
demo: build
	@BUILD_DIR=$(BUILD_DIR) bash scripts/demo.sh

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

bench: build
	$(BUILD_DIR)/bench/lensfarm-bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
	$(BUILD_DIR)/bench/lensfarm-ingest-bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
	BUILD_DIR=$(BUILD_DIR) bash bench/farm_efficiency.sh 3

# The bounded soak test of one coordinator: 64 simulated workers for 60 s.
load: build
	$(BUILD_DIR)/bench/lensfarm-load --workers 64 --seconds 60

clean:
	rm -rf $(BUILD_DIR) $(BUILD_DIR).configure.log out
