# visnav — the two commands a fresh machine needs are `make demo` and `make test`.
# Both install missing Debian packages, configure, build in Release on all cores and run.
#
#   make demo        build, then run the main job on the simulated robot and print the result
#   make test        build, then run every test (ctest)
#   make bench       build, then run the benchmarks
#   make asan        clang build with AddressSanitizer+UBSan into build-asan, run the tests there
#   make fuzz        build the libFuzzer targets (same build-asan), run each FUZZ_S s (default 60)
#   make ci          what CI runs (.ci/run): make test WERROR=ON, make asan, make fuzz FUZZ_S=20
#   make install     install runtime, SDK, plugins and CMake package (PREFIX=/usr/local)
#   make clean       remove the build folders
#
# Variables: BUILD (build folder), JOBS (parallel jobs), WERROR=ON (warnings are errors),
#            PREFIX (install prefix), CTEST_ARGS (extra ctest arguments).

BUILD      ?= build
JOBS       ?= $(shell nproc)
WERROR     ?= OFF
PREFIX     ?= /usr/local
CTEST_ARGS ?=
FUZZ_S     ?= 60
SAN_BUILD  ?= build-asan
EXTRA_CMAKE ?=
GENERATOR  := $(shell command -v ninja >/dev/null 2>&1 && echo "-G Ninja")

.PHONY: all deps configure build test demo bench san-configure asan fuzz ci install clean

all: build

deps:
	@scripts/install-deps.sh

# Re-run cmake only when the cache is missing or options changed.
configure: deps
	@if [ ! -f $(BUILD)/CMakeCache.txt ]; then \
	  cmake -S . -B $(BUILD) $(GENERATOR) -DCMAKE_BUILD_TYPE=Release -DVISNAV_WERROR=$(WERROR) -DCMAKE_INSTALL_PREFIX=$(PREFIX) $(EXTRA_CMAKE); \
	else \
	  cmake -S . -B $(BUILD) -DVISNAV_WERROR=$(WERROR) -DCMAKE_INSTALL_PREFIX=$(PREFIX) $(EXTRA_CMAKE) >/dev/null; \
	fi

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS) $(CTEST_ARGS)

demo: build
	@scripts/demo.sh $(BUILD)

bench: build
	@scripts/bench.sh $(BUILD)

# One clang build (cmake/sanitize.cmake: ASan+UBSan everywhere, libFuzzer instrumentation on every
# library, tests and fuzzers on) serves both `make asan` and `make fuzz`. Needs clang and
# libclang-rt-14-dev (VISNAV_FUZZ=1 install-deps.sh); `make test` never needs clang.
SAN_CMAKE := -C $(CURDIR)/cmake/sanitize.cmake

san-configure:
	@VISNAV_FUZZ=1 scripts/install-deps.sh
	@if [ -f $(SAN_BUILD)/CMakeCache.txt ] && ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang' $(SAN_BUILD)/CMakeCache.txt; then \
	  echo "$(SAN_BUILD) was configured with another compiler (make asan now builds with clang): rm -rf $(SAN_BUILD)"; exit 1; fi
	$(MAKE) configure BUILD=$(SAN_BUILD) WERROR=OFF EXTRA_CMAKE="$(SAN_CMAKE)"

asan: san-configure
	$(MAKE) test BUILD=$(SAN_BUILD) WERROR=OFF EXTRA_CMAKE="$(SAN_CMAKE)"

fuzz: san-configure
	cmake --build $(SAN_BUILD) --target fuzzers -j $(JOBS)
	scripts/fuzz.sh $(SAN_BUILD) $(FUZZ_S)

ci:
	.ci/run

install: build
	cmake --install $(BUILD)

clean:
	rm -rf build $(SAN_BUILD) build-fuzz
