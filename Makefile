# Thin wrapper over scripts/install-deps, CMake and CTest. The README's two commands:
#   make demo   install what is missing, build, write the report of the paper's system ($(BUILD)/report)
#   make test   install what is missing, build, run every test
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
PY := /usr/bin/python3
PORTHOLE := $(BUILD)/apps/porthole/porthole

.PHONY: all deps configure build demo test bench clean format

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

bench: build
	@bash scripts/install-deps --bench && cmake -S . -B $(BUILD) --log-level=WARNING && cmake --build $(BUILD) -j $(JOBS) --target porthole_bench
	@$(BUILD)/bench/porthole_bench --benchmark_counters_tabular=true

format:
	@git ls-files '*.h' '*.cc' | xargs clang-format -i

clean:
	rm -rf $(BUILD)
