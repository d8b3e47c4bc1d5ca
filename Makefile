# palpate — the two set-up commands: `make demo` and `make test` (see README.md).
PRESET ?= release
BUILD  := build/$(PRESET)
CLI    := $(BUILD)/apps/palpate/palpate
SCENE  ?= data/scenes/cvc.yaml
DEMO_OUT ?= out/demo

.PHONY: all deps configure build test golden demo bench bench-python python-shell fuzz fuzz-build asan-test tsan-test minimal-test format tidy clean

all: build

deps:
	@bash scripts/install-deps

$(BUILD)/CMakeCache.txt:
	cmake --preset $(PRESET)

configure: deps $(BUILD)/CMakeCache.txt

build: configure
	cmake --build --preset $(PRESET)

test: build
	ctest --preset $(PRESET)

# Re-record the golden force traces of every shipped scene (tests/golden/README.md): only on
# purpose, when a change is meant to change what the hand feels; say why in the commit.
golden: build
	$(BUILD)/tests/palpate_golden_record tests/golden data/scenes $(GOLDEN_SCENES)

# A scene with an ultrasound probe (cvc.yaml) also gives its images: 13, one every 1.07 s of its run.
demo: build
	$(CLI) run $(SCENE) --out $(DEMO_OUT) --frames 3 $(if $(shell grep -qs '^probe:' $(SCENE) && echo y),--ultrasound 13)

# Fuzzing (fuzz/README.md): every libFuzzer target for FUZZ_SECONDS each, one after the other, in
# the fuzz preset's build (clang, ASan + UBSan); fails on any crash, sanitizer report, hang or leak.
FUZZ_SECONDS ?= 300
fuzz: fuzz-build
	bash fuzz/run.sh build/fuzz $(FUZZ_SECONDS)

fuzz-build: deps
	test -f build/fuzz/CMakeCache.txt || cmake --preset fuzz
	cmake --build --preset fuzz --target fuzz_targets

# The whole suite under AddressSanitizer + UndefinedBehaviorSanitizer (clang: the fuzz preset's
# build, which the fuzz targets share), and the threaded tests under ThreadSanitizer (the tsan
# preset builds only their files: tests/CMakeLists.txt).
asan-test: deps
	test -f build/fuzz/CMakeCache.txt || cmake --preset fuzz
	cmake --build --preset fuzz
	ctest --preset fuzz

tsan-test: deps
	test -f build/tsan/CMakeCache.txt || cmake --preset tsan
	cmake --build --preset tsan --target palpate_tests
	ctest --preset tsan -E '^(embed_example|tissue_only_example)|^(Layers|Schema)\.'

# palpate without its optional components (OSMesa, Gmsh, CGAL: README, Building by hand): the minimal
# preset's library, tests and examples (no command, no benchmarks). The tests that need a component
# skip, naming it; Components.* and Without*.* check the clear error each such call gives instead.
# The 54k-vertex organ's golden trace is left to the release suite: recorded at -O3, it differs by
# 1e-7 N at the preset's -O1 (its solve sums in another order), past the traces' 1e-9 N. The static
# subproject test builds a palpate of its own (with every component): the release suite runs it.
minimal-test: deps
	test -f build/minimal/CMakeCache.txt || cmake --preset minimal
	cmake --build --preset minimal
	ctest --preset minimal -E 'GoldenTraces.*large_organ|^Package\.AStaticSubproject'

bench: build
	$(BUILD)/bench/palpate_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

# Python (docs/python.md): Debian's python3 with the build tree's `palpate` importable; after
# `cmake --install` plain `python3` imports it with no environment variable.
PYTHON := /usr/bin/python3
python-shell: build
	PYTHONPATH=$(CURDIR)/$(BUILD)/python $(PYTHON) $(ARGS)

# step_many against the same loop in C++ (docs/BENCHMARKS.md, "Python"): fails over 10 %.
bench-python: build
	PYTHONPATH=$(CURDIR)/$(BUILD)/python $(PYTHON) bench/python_step_many.py $(BUILD)/bench/palpate_bench

format:
	clang-format -i $$(git ls-files '*.cpp' '*.h')

tidy: build
	clang-tidy -p $(BUILD) $$(git ls-files 'src/*.cpp' 'apps/*.cpp')

clean:
	rm -rf build out
