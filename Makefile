# rrslam: user-facing targets. Everything installs what it needs first.
#
#   make            build everything into build/ (executables in build/bin/)
#   make test       build, then run every test (CTest)
#   make demo       run the main job on built-in synthetic data
#   make vocab DATASET=<name>   train a vocabulary (pipelines/vocab.mk)
#   make eval-all   evaluate every sequence (pipelines/eval.mk)
#   make paper      the seed paper's tables and figures (pipelines/paper.mk)
#   make bench      benchmarks, results in bench/results/
#   make fuzz       build the libFuzzer targets (build-fuzz/)
#   make test-tsan  the track tests under ThreadSanitizer (build-tsan/)
#   make test-asan  the track tests under AddressSanitizer (build-asan/)
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

.PHONY: all build deps configure test test-tsan test-asan demo bench fuzz format clean help

all: build

help:
	@sed -n '2,14p' Makefile | sed 's/^# \{0,1\}//'

deps:
	@scripts/install-deps.sh

$(BUILD_DIR)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DRRSLAM_DATA_DIR=$(SHARED_DATA)

configure: deps $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) $(CTEST_ARGS)

# --- Sanitizer builds of the track tests --------------------------------------
# The track stage's tests (CTest track/*) and its end-to-end tests (e2e/track,
# which runs rrslam-track --mode realtime, with local mapping in its own
# thread; e2e/map, which also maps on a loaded map in realtime mode), built
# with -DRRSLAM_SANITIZE=thread / address in a tree of their own (build/ is
# not touched) and run there; the tests run the tools of that tree's bin/, so
# every rrslam-* they start is instrumented too. The e2e tests also run
# rrslam-synth, -extract, -cluster, -vocab, -eval and -mapstore. Each report goes to
# build-<x>san/sanitizer-logs/ (a test that checks only an exit code would
# swallow it), is printed at the end, and fails the target. tests/tsan.supp
# lists the third-party reports TSan may ignore, each with its reason.
SANITIZER_TARGETS := track-tests e2e_track e2e_map rrslam-synth rrslam-extract rrslam-cluster \
                     rrslam-vocab rrslam-eval rrslam-mapstore
SANITIZER_TESTS := ^(track/|e2e/track$$|e2e/map$$)
TSAN_OPTIONS ?= halt_on_error=1 second_deadlock_stack=1
ASAN_OPTIONS ?= halt_on_error=1 detect_leaks=1

build-tsan/CMakeCache.txt build-asan/CMakeCache.txt: build-%/CMakeCache.txt: | deps
	cmake -S . -B build-$* -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DRRSLAM_DATA_DIR=$(SHARED_DATA) \
	  -DRRSLAM_SANITIZE=$(if $(filter tsan,$*),thread,address)

test-tsan test-asan: test-%: build-%/CMakeCache.txt
	cmake --build build-$* -j $(JOBS) --target $(SANITIZER_TARGETS)
	logs=$(CURDIR)/build-$*/sanitizer-logs; rm -rf $$logs; mkdir -p $$logs; \
	  cd build-$* || exit 1; status=0; \
	  TSAN_OPTIONS="$(TSAN_OPTIONS) suppressions=$(CURDIR)/tests/tsan.supp log_path=$$logs/tsan" ASAN_OPTIONS="$(ASAN_OPTIONS) log_path=$$logs/asan" \
	    ctest --output-on-failure -j $(JOBS) -R '$(SANITIZER_TESTS)' $(CTEST_ARGS) || status=$$?; \
	  for report in $$(ls $$logs); do echo "=== $$logs/$$report"; cat $$logs/$$report; status=1; done; \
	  exit $$status

format:
	find common stages tests bench -name '*.cc' -o -name '*.h' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) build-fuzz build-tsan build-asan

include pipelines/demo.mk
-include pipelines/vocab.mk
-include pipelines/eval.mk
-include pipelines/paper.mk
-include bench/bench.mk
-include pipelines/fuzz.mk
