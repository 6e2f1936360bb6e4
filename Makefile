# Thin wrapper over scripts/install-deps, CMake and CTest. The README's two commands:
#   make demo   install what is missing, build, write the report of the paper's system ($(BUILD)/report)
#   make test   install what is missing, build, run every test
#   make install [PREFIX=/usr/local]   the CLI into PREFIX/bin and the Python package where python3 finds it
# and, for robustness (docs/robustness.md): make test-sanitize (g++, ASan + UBSan), make test-sanitize-clang
# (the same with clang, whose UBSan adds float-cast-overflow), make fuzz (libFuzzer, clang).
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
PY := /usr/bin/python3
PORTHOLE := $(BUILD)/apps/porthole/porthole

SANITIZE_BUILD ?= build-sanitize
SANITIZE_CLANG_BUILD ?= build-sanitize-clang
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 600
# Any sanitizer report fails the test that triggered it (exit code 86; docs/robustness.md).
SANITIZER_ENV := ASAN_OPTIONS=exitcode=86:detect_leaks=1:strict_string_checks=1 \
                 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:exitcode=86 \
                 LSAN_OPTIONS=suppressions=$(CURDIR)/tests/fuzz/lsan.supp:print_suppressions=0

.PHONY: all deps configure build demo test install test-sanitize test-sanitize-clang fuzz bench clean format

all: build

deps:
	@bash scripts/install-deps

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=$(PY) --log-level=WARNING

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

demo: build
	@$(PORTHOLE) report --out $(BUILD)/report --force

test: build
	@ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# PREFIX/bin/porthole and the Python package `porthole` in the site directory /usr/bin/python3 searches
# for PREFIX (/usr/local: /usr/local/lib/python3.X/dist-packages; ~/.local: the user site; other
# prefixes: PREFIX/lib/python3.X/site-packages, to put on PYTHONPATH). PYTHON_DIR=... overrides it.
PREFIX ?= /usr/local
install: build
	@PORTHOLE_PYTHON_DIR=$(PYTHON_DIR) cmake --install $(BUILD) --prefix $(PREFIX)

# The whole suite built with AddressSanitizer + UndefinedBehaviorSanitizer in its own directory
# (no Python module: it would need the sanitizer runtime preloaded into python3).
test-sanitize: deps
	@cmake -S . -B $(SANITIZE_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS="-O1" -DPORTHOLE_SANITIZE=ON \
	  -DPORTHOLE_PYTHON=OFF -DPORTHOLE_BENCH=OFF -DPython3_EXECUTABLE=$(PY) --log-level=WARNING
	@cmake --build $(SANITIZE_BUILD) -j $(JOBS)
	@$(SANITIZER_ENV) ctest --test-dir $(SANITIZE_BUILD) --output-on-failure -j $(JOBS)

# The same suite built with clang (scripts/install-deps --fuzz: Debian's clang 14): clang's UBSan adds
# what g++'s lacks, float-cast-overflow (a double out of an integer's range), named explicitly in CMakeLists.txt.
test-sanitize-clang:
	@bash scripts/install-deps --fuzz
	@CXX=clang++ cmake -S . -B $(SANITIZE_CLANG_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS="-O1" -DPORTHOLE_SANITIZE=ON \
	  -DPORTHOLE_PYTHON=OFF -DPORTHOLE_BENCH=OFF -DPython3_EXECUTABLE=$(PY) --log-level=WARNING
	@cmake --build $(SANITIZE_CLANG_BUILD) -j $(JOBS)
	@$(SANITIZER_ENV) ctest --test-dir $(SANITIZE_CLANG_BUILD) --output-on-failure -j $(JOBS)

# libFuzzer harnesses (clang), each run for FUZZ_SECONDS (default 600) in turn: make fuzz FUZZ_SECONDS=60
fuzz:
	@bash scripts/install-deps --fuzz
	@CXX=clang++ cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPORTHOLE_FUZZ=ON -DPORTHOLE_APP=OFF \
	  -DPORTHOLE_PYTHON=OFF -DPORTHOLE_BENCH=OFF -DPORTHOLE_UNIT_TESTS=OFF --log-level=WARNING
	@cmake --build $(FUZZ_BUILD) -j $(JOBS)
	@$(SANITIZER_ENV) bash tests/fuzz/run_fuzzers.sh $(FUZZ_BUILD) $(FUZZ_SECONDS)

bench: build
	@bash scripts/install-deps --bench && cmake -S . -B $(BUILD) --log-level=WARNING && cmake --build $(BUILD) -j $(JOBS) --target porthole_bench
	@$(BUILD)/bench/porthole_bench --benchmark_counters_tabular=true

format:
	@git ls-files '*.h' '*.cc' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(SANITIZE_BUILD) $(SANITIZE_CLANG_BUILD) $(FUZZ_BUILD)
