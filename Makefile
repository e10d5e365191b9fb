# hapticcal quick start: `make run` and `make test` on a fresh Debian machine.
# Both install missing Debian packages (apt-get), configure a Release build
# with CMake and build with -j$(JOBS).
BUILD ?= build
# One instrumented tree (clang, ASan + UBSan + libFuzzer's coverage) for both the
# tests labelled "sanitize" (make test) and the fuzz targets (make fuzz). A new
# name: CMake switching an old gcc build-sanitize to clang would drop its -D options.
ASAN_BUILD ?= build-asan
FUZZ_SECONDS ?= 60
JOBS ?= 2
DEB_PACKAGES := cmake g++ make pkg-config libeigen3-dev libceres-dev libyaml-cpp-dev \
  nlohmann-json3-dev libcli11-dev libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev \
  liborocos-kdl-dev liburdfdom-dev gnuplot-nox \
  python3-dev python3-pybind11 python3-numpy python3-pytest \
  libzstd-dev liblz4-dev libbz2-dev libsqlite3-dev \
  python3-rosbag python3-roslz4 python3-sensor-msgs python3-geometry-msgs python3-tf2-msgs
# Node and npm for the recording tests' writers (tests/writers: npm ci of the
# MCAP and CDR writers), installed from Debian unless an npm is already there (a
# node from elsewhere ships its own npm, which Debian's npm package conflicts with).
NODE_PACKAGES := nodejs npm
# Debian's clang and its compiler-rt (libclang_rt.fuzzer, ASan, UBSan) for the
# instrumented tree of `make test` and `make fuzz`.
FUZZ_PACKAGES := clang libclang-rt-dev

.PHONY: all deps configure build run test asan-configure bench generalise fuzz clean

all: build

deps:
	@missing=""; \
	for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$(NODE_PACKAGES)" ] && ! command -v npm >/dev/null 2>&1; then missing="$$missing $(NODE_PACKAGES)"; fi; \
	if [ -n "$$missing" ]; then \
	  echo "hapticcal: installing Debian packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then sudo=""; else sudo="sudo"; fi; \
	  $$sudo apt-get update && \
	  DEBIAN_FRONTEND=noninteractive $$sudo apt-get install -y --no-install-recommends $$missing; \
	fi

configure: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release

build: configure
	cmake --build $(BUILD) -j$(JOBS)

# The main job: the paper's simulation study on the built-in 7-DOF device.
# Builds what it runs (the command line) and the C runtime a controller links,
# not the tests and benchmarks.
run: configure
	cmake --build $(BUILD) -j$(JOBS) --target hapticcal_cli hapticcal_runtime
	./$(BUILD)/hapticcal simulate

# The instrumented tree $(ASAN_BUILD): clang at -O1 -gline-tables-only (file and
# line in every sanitizer report, with a fraction of -g's debug info to build and
# link) with assertions (no -DNDEBUG, C and C++), everything under AddressSanitizer and UBSan
# (-fno-sanitize-recover=undefined: a finding fails) and libFuzzer's coverage
# (-fsanitize=fuzzer-no-link); only fuzz/ links libFuzzer, the tests keep
# GoogleTest's main. -DHAPTICCAL_FUZZ=ON implies HAPTICCAL_SANITIZE. `make test`
# builds the sanitize tests and the fuzz targets in it, so that `make fuzz`
# afterwards compiles nothing; `make fuzz` alone builds only the fuzz targets.
asan-configure: deps
	@$(MAKE) --no-print-directory deps DEB_PACKAGES="$(FUZZ_PACKAGES)"
	cmake -S . -B $(ASAN_BUILD) -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only" \
	  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only" -DHAPTICCAL_FUZZ=ON \
	  -DHAPTICCAL_BUILD_BENCHMARKS=OFF

# Every test in Release (the Python module's pytest among them: python_test),
# then the input-handling tests again under AddressSanitizer and UBSan (and the
# fuzz targets built, for `make fuzz`).
test: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS)
	@$(MAKE) --no-print-directory asan-configure
	cmake --build $(ASAN_BUILD) -j$(JOBS) --target sanitize_targets fuzz_targets
	cd $(ASAN_BUILD) && ctest --output-on-failure -j$(JOBS) -L sanitize

bench: build
	./$(BUILD)/bench/fk_jacobian_bench --benchmark_repetitions=7 --benchmark_report_aggregates_only=true
	./$(BUILD)/bench/calibrate_bench --benchmark_repetitions=7 --benchmark_report_aggregates_only=true
	./$(BUILD)/bench/plan_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
	./$(BUILD)/bench/recording_bench

# The generalisation benchmark (docs/calibrate.md, "The model search"): the model search
# on 48 simulated robots and the shared real sets against an oracle, a table.
generalise: configure
	cmake --build $(BUILD) -j$(JOBS) --target generalise
	./$(BUILD)/bench/generalise --threads $(JOBS)

# libFuzzer targets of fuzz/ in the instrumented tree (see asan-configure), each
# run for FUZZ_SECONDS on a scratch copy of the seed corpus in $(ASAN_BUILD)/corpus;
# fails if any finds a crash. After `make test` nothing is compiled.
fuzz: asan-configure
	cmake --build $(ASAN_BUILD) -j$(JOBS) --target fuzz_targets
	fuzz/run.sh $(ASAN_BUILD) $(FUZZ_SECONDS)

# build-sanitize and build-fuzz: the two trees build-asan replaced.
clean:
	rm -rf $(BUILD) $(ASAN_BUILD) build-sanitize build-fuzz
