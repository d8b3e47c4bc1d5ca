# palpate — the two set-up commands: `make demo` and `make test` (see README.md).
PRESET ?= release
BUILD  := build/$(PRESET)
CLI    := $(BUILD)/apps/palpate/palpate
SCENE  ?= data/scenes/cvc.yaml
DEMO_OUT ?= out/demo

.PHONY: all deps configure build test demo bench format tidy clean

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

# A scene with an ultrasound probe (cvc.yaml) also gives its images: 13, one every 1.07 s of its run.
demo: build
	$(CLI) run $(SCENE) --out $(DEMO_OUT) --frames 3 $(if $(shell grep -qs '^probe:' $(SCENE) && echo y),--ultrasound 13)

bench: build
	$(BUILD)/bench/palpate_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

format:
	clang-format -i $$(git ls-files '*.cpp' '*.h')

tidy: build
	clang-tidy -p $(BUILD) $$(git ls-files 'src/*.cpp' 'apps/*.cpp')

clean:
	rm -rf build out
