# meshreduce: the two commands that matter are `make demo` and `make check`.
# Everything builds with CMake into build*/ directories.

JOBS      ?= $(shell nproc 2>/dev/null || echo 2)
BUILD     ?= build
CMAKE     ?= cmake
FUZZ_SECONDS ?= 60

# Debian packages each goal needs (installed by scripts/need-packages.sh).
BUILD_PKGS = cmake gcc libc6-dev make libpng-dev libjpeg62-turbo-dev libcjson-dev
TEST_PKGS  = $(BUILD_PKGS) libcmocka-dev pkg-config python3-dev python3-numpy python3-pytest \
             python3-matplotlib libopenmpi-dev openmpi-bin
# The report's plots (bench/plots.py): Debian's matplotlib, run by Debian's
# /usr/bin/python3 (the tests' report check draws them too).
REPORT_PKGS = python3-matplotlib
FUZZ_PKGS  = clang libclang-rt-14-dev
# ThreadSanitizer: clang's TSan runtime, LLVM's OpenMP runtime with its
# Archer tool (libomp-14-dev: libomp.so, omp.h, libarcher.so) and
# llvm-symbolizer (llvm) for the reports' stacks.
TSAN_PKGS  = clang libclang-rt-14-dev libomp-14-dev llvm

.PHONY: all build demo check asan tsan serial fuzz bench report clean deps-build deps-test deps-fuzz \
        deps-tsan pip-check

all: build

deps-build:
	@scripts/need-packages.sh $(BUILD_PKGS)
deps-test:
	@scripts/need-packages.sh $(TEST_PKGS)
deps-fuzz:
	@scripts/need-packages.sh $(FUZZ_PKGS)
deps-tsan:
	@scripts/need-packages.sh $(TSAN_PKGS)

$(BUILD)/CMakeCache.txt:
	$(CMAKE) -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release

build: deps-test $(BUILD)/CMakeCache.txt
	$(CMAKE) --build $(BUILD) -j $(JOBS)

# Build, then run the main job on the embedded generated default mesh.
demo: build
	./$(BUILD)/meshreduce demo

# Build and pass every test.
check: build
	@scripts/need-gltf-validator.sh $(BUILD)/gltf-validator
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer,
# with the largest cases shrunk (MR_TEST_QUICK: test_parallel_simplify's
# whole set, unoptimised and instrumented, took 214 s of the stage's 245).
asan: deps-test
	$(CMAKE) -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DMR_SANITIZE=ON -DMR_BUILD_BENCH=OFF
	$(CMAKE) --build build-asan -j $(JOBS)
	MR_TEST_QUICK=1 ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	    ctest --test-dir build-asan --output-on-failure -j $(JOBS)

# The tests of the parallel parts (CTest label "parallel") under
# ThreadSanitizer: clang, its OpenMP runtime libomp and LLVM's Archer
# (OMP_TOOL_LIBRARIES, set by CTest), which tells TSan about OpenMP's
# barriers, reductions, locks and tasks; GCC's libgomp is not instrumented
# and would read as races. The tests shrink their largest cases
# (MR_TEST_QUICK, set by CTest). Any report fails the test (halt_on_error).
# ignore_noninstrumented_modules=1, as Archer asks: accesses made inside
# the uninstrumented libraries (libomp itself, libpng, cmocka) are not
# checked; all of ours is instrumented. No suppression file.
TSAN_RUN_OPTIONS = halt_on_error=1 second_deadlock_stack=1 ignore_noninstrumented_modules=1
tsan: deps-test deps-tsan
	CC=clang $(CMAKE) -S . -B build-tsan -DCMAKE_BUILD_TYPE=Debug -DMR_TSAN=ON -DMR_BUILD_BENCH=OFF
	$(CMAKE) --build build-tsan -j $(JOBS) --target parallel_tests
	TSAN_OPTIONS="$(TSAN_RUN_OPTIONS)" ctest --test-dir build-tsan -L parallel --output-on-failure \
	    -j $(JOBS)

# The serial build (no OpenMP: -DMR_OPENMP=OFF) gives the OpenMP build's
# bytes: generate and simplify outputs compared by cmp (--threads 1 and 2);
# and its library passes the test suite (largest cases shrunk), whose calls
# ask for 2, 3 and 8 threads and get one.
serial: build
	$(CMAKE) -S . -B build-serial -DCMAKE_BUILD_TYPE=Release -DMR_OPENMP=OFF \
	    -DMR_BUILD_TESTS=ON -DMR_BUILD_BENCH=OFF
	$(CMAKE) --build build-serial -j $(JOBS)
	scripts/check-serial.sh $(BUILD)/meshreduce build-serial/meshreduce
	MR_TEST_QUICK=1 ctest --test-dir build-serial --output-on-failure -j $(JOBS)

# `pip install .` into a fresh virtualenv (--system-site-packages,
# --no-build-isolation: Debian's numpy, setuptools, wheel), then the Python
# tests against the installed module.
pip-check: build
	scripts/check-pip-install.sh

# Each reader's libFuzzer target, and the texture decoders' (image), for
# FUZZ_SECONDS under ASan + UBSan.
fuzz: deps-build deps-fuzz
	CC=clang $(CMAKE) -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Debug -DMR_FUZZ=ON \
	    -DMR_BUILD_TESTS=OFF -DMR_BUILD_BENCH=OFF
	$(CMAKE) --build build-fuzz -j $(JOBS)
	@for f in obj ply stl xyz gltf image; do \
	    mkdir -p build-fuzz/corpus/$$f; \
	    cp tests/fuzz/seeds/*.$$f build-fuzz/corpus/$$f/ 2>/dev/null || true; \
	    echo "fuzz_$$f: $(FUZZ_SECONDS) s"; \
	    ./build-fuzz/tests/fuzz/fuzz_$$f -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=2048 \
	        -max_len=65536 -print_final_stats=1 build-fuzz/corpus/$$f 2>build-fuzz/fuzz_$$f.log \
	        || { tail -60 build-fuzz/fuzz_$$f.log; exit 1; }; \
	    grep -E 'stat::number_of_executed_units|Done' build-fuzz/fuzz_$$f.log | tail -2; \
	done

# I/O throughput, then sequential simplification against the installed peers
# (a few minutes; bench_simplify --quick for a short subset).
bench: build
	$(CMAKE) --build $(BUILD) -j $(JOBS) --target bench_peers
	./$(BUILD)/bench/bench_io
	./$(BUILD)/bench/bench_simplify --csv $(BUILD)/bench/simplify.csv
	./$(BUILD)/bench/bench_queued --quick
	./$(BUILD)/bench/bench_partitioned --quick
	if [ -d $(BUILD)/python/meshreduce ]; then PYTHONPATH=$(BUILD)/python /usr/bin/python3 \
	    bench/bench_python.py --cli $(BUILD)/meshreduce; fi

# The benchmark sweep (meshes x targets x algorithms x threads, with the
# installed peers; several minutes), then its plots (bench/plots.py,
# matplotlib), then bench/REPORT.md with its comparison sheets in
# bench/report/.
report: build
	@scripts/need-packages.sh $(REPORT_PKGS)
	$(CMAKE) --build $(BUILD) -j $(JOBS) --target bench_peers
	./$(BUILD)/bench/sweep --csv bench/report/sweep.csv
	/usr/bin/python3 bench/plots.py bench/report/sweep.csv --out bench/report
	./$(BUILD)/bench/report bench/report/sweep.csv --out bench

clean:
	rm -rf build build-asan build-tsan build-serial build-fuzz build-python out python/*.egg-info
