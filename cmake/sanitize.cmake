# Initial cache (cmake -C) of the sanitizer build that `make asan` and `make fuzz` share (folder
# build-asan): one clang build serves both the test run and the libFuzzer targets, so CI compiles
# the tree twice (this and `make test`), not three times.
#   - ASan + UBSan on every visnav target (VISNAV_SANITIZE, cmake/VisnavHelpers.cmake), UB aborts;
#   - libFuzzer coverage instrumentation on every library (-fsanitize=fuzzer-no-link): the fuzz
#     targets link the same instrumented libraries the tests use; the tests only pay the counters;
#   - -O1 (the optimisation ASan recommends; compiles faster than -O3) with line tables only, so
#     reports name file:line without the cost of full debug info; no NDEBUG, asserts stay on.
# Needs clang and libclang-rt-14-dev (VISNAV_FUZZ=1 scripts/install-deps.sh).
set(CMAKE_C_COMPILER clang CACHE STRING "")
set(CMAKE_CXX_COMPILER clang++ CACHE STRING "")
set(CMAKE_CXX_FLAGS "-fsanitize=fuzzer-no-link -gline-tables-only" CACHE STRING "")
set(CMAKE_CXX_FLAGS_RELEASE "-O1" CACHE STRING "")
set(VISNAV_SANITIZE ON CACHE BOOL "")
set(VISNAV_BUILD_FUZZERS ON CACHE BOOL "")
set(VISNAV_BUILD_TESTS ON CACHE BOOL "")
set(VISNAV_BUILD_BENCHMARKS OFF CACHE BOOL "")
