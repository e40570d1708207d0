# rrslam: user-facing targets. Everything installs what it needs first.
#
#   make            build everything into build/ (executables in build/bin/)
#   make test       build, then run every test (CTest)
#   make demo       run the main job on built-in synthetic data
#   make vocab DATASET=<name>   train a vocabulary (pipelines/vocab.mk)
#   make eval-all   evaluate every sequence (pipelines/eval.mk)
#   make bench      benchmarks, results in bench/results/
#   make fuzz       build the libFuzzer targets (build-fuzz/)
#   make format     clang-format every source file
#   make deps       install missing Debian packages only

SHELL := /bin/bash
.DELETE_ON_ERROR:

BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc)
CTEST_ARGS ?=
DATA_ROOT ?= data
SHARED_DATA ?= $(abspath ../shared/data)
BIN := $(BUILD_DIR)/bin

.PHONY: all build deps configure test demo bench fuzz format clean help

all: build

help:
	@sed -n '2,13p' Makefile | sed 's/^# \{0,1\}//'

deps:
	@scripts/install-deps.sh

$(BUILD_DIR)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DRRSLAM_DATA_DIR=$(SHARED_DATA)

configure: deps $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) $(CTEST_ARGS)

format:
	find common stages tests bench -name '*.cc' -o -name '*.h' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) build-fuzz

include pipelines/demo.mk
-include pipelines/vocab.mk
-include pipelines/eval.mk
-include bench/bench.mk
-include pipelines/fuzz.mk
