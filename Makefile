# visnav — the two commands a fresh machine needs are `make demo` and `make test`.
# Both install missing Debian packages, configure, build in Release on all cores and run.
#
#   make demo        build, then run the main job on the simulated robot and print the result
#   make test        build, then run every test (ctest)
#   make bench       build, then run the benchmarks
#   make asan        build into build-asan with AddressSanitizer+UBSan and run the tests there
#   make fuzz        build the libFuzzer targets with clang into build-fuzz, run each FUZZ_S s (default 60)
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
EXTRA_CMAKE ?=
GENERATOR  := $(shell command -v ninja >/dev/null 2>&1 && echo "-G Ninja")

.PHONY: all deps configure build test demo bench asan fuzz install clean

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

asan:
	$(MAKE) test BUILD=build-asan WERROR=$(WERROR) EXTRA_CMAKE="-DVISNAV_SANITIZE=ON -DVISNAV_BUILD_BENCHMARKS=OFF"

# Separate from `make test` (needs clang: Debian clang + libclang-rt-14-dev, see install-deps.sh).
fuzz:
	@VISNAV_FUZZ=1 scripts/install-deps.sh
	cmake -S . -B build-fuzz $(GENERATOR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
	  -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link -DVISNAV_SANITIZE=ON \
	  -DVISNAV_BUILD_FUZZERS=ON -DVISNAV_BUILD_TESTS=OFF -DVISNAV_BUILD_BENCHMARKS=OFF
	cmake --build build-fuzz --target fuzzers -j $(JOBS)
	scripts/fuzz.sh build-fuzz $(FUZZ_S)

install: build
	cmake --install $(BUILD)

clean:
	rm -rf build build-asan build-fuzz
