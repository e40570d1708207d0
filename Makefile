# rrslam: user-facing targets. Everything installs what it needs first.
#
#   make            build everything into build/ (executables in build/bin/)
#   make test       build, then run every test (CTest)
#   make tools      build only the executables the pipelines run
#   make demo       run the main job on built-in synthetic data
#   make vocab DATASET=<name>   train a vocabulary (pipelines/vocab.mk)
#   make eval-all   evaluate every sequence (pipelines/eval.mk)
#   make paper      the seed paper's tables and figures (pipelines/paper.mk)
#   make bench      benchmarks, results in bench/results/
#   make fuzz       build the libFuzzer targets (build-fuzz/)
#   make test-tsan  the track tests under ThreadSanitizer (build-tsan/)
#   make test-asan  every test under ASan + UBSan (build-asan/)
#   make test-asan-readers  the reader stages' tests under ASan + UBSan (CI)
#   make format     clang-format every source file
#   make deps       install missing Debian packages only (deps-build: those the tools need)

SHELL := /bin/bash
.DELETE_ON_ERROR:

BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc)
CTEST_ARGS ?=
DATA_ROOT ?= data
SHARED_DATA ?= $(abspath ../shared/data)
BIN := $(BUILD_DIR)/bin

.PHONY: all build tools deps deps-build configure test test-tsan test-asan test-asan-readers demo bench fuzz format clean help

all: build

help:
	@awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' Makefile

# deps: every package (tests and fuzzers too); deps-build: what building and
# running the tools needs (`make demo`).
deps:
	@scripts/install-deps.sh all

deps-build:
	@scripts/install-deps.sh build

# Ninja (Debian's ninja-build, in the build packages) schedules the whole
# tree at once: a target's files compile while the libraries it links are
# still building, where Make's generator waits (bench/results/build-*.txt).
# A build tree keeps the generator it was configured with.
CMAKE_GENERATOR ?= $(if $(shell command -v ninja),Ninja,Unix Makefiles)
$(BUILD_DIR)/CMakeCache.txt: | deps-build
	cmake -S . -B $(BUILD_DIR) -G "$(CMAKE_GENERATOR)" -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	  -DRRSLAM_DATA_DIR=$(SHARED_DATA)

configure: deps-build $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

# The executables the pipelines run (build/bin/: the rrslam-* tools and the
# vocabulary benchmark's two), without the tests and fuzz targets: what
# `make eval-all` and `make paper` bring up to date first, which is quicker to
# check than `build` when nothing changed.
TOOLS := rrslam-synth rrslam-extract rrslam-cluster rrslam-vocab rrslam-track rrslam-eval \
         rrslam-render rrslam-mapstore vocab_bench vocab_bench_generate
tools: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(TOOLS)

test: deps build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) $(CTEST_ARGS)

# --- Sanitizer builds -----------------------------------------------------------
# Each in a tree of its own (build/ is not touched), configured with
# -DRRSLAM_SANITIZE=thread / address; the tests run the tools of that tree's
# bin/, so every rrslam-* they start is instrumented too. Each report goes to
# build-<x>san/sanitizer-logs/ (a test that checks only an exit code would
# swallow it), is printed at the end, and fails the target.
#
# make test-tsan: ThreadSanitizer on the track stage's tests (CTest track/*)
# and its end-to-end tests (e2e/track, which runs rrslam-track --mode
# realtime, with local mapping in its own thread; e2e/map, which also maps on
# a loaded map in realtime mode), which also run rrslam-synth, -extract,
# -cluster, -vocab, -eval and -mapstore. tests/tsan.supp lists the
# third-party reports TSan may ignore, each with its reason.
#
# make test-asan: AddressSanitizer + LeakSanitizer + UndefinedBehaviorSanitizer
# on every target and the whole CTest suite; undefined behaviour aborts like an
# ASan error. GCC's UBSan runtime (libubsan.so, apart from libasan.so) writes
# its own report to stderr whatever its log_path, where a test that runs a
# tool could swallow it; so UBSan aborts (abort_on_error=1) and ASan reports
# the SIGABRT (handle_abort=1) with the whole stack into the log, whose frames
# name the check (__ubsan_handle_<check>_abort) and the line. UBSAN_OPTIONS
# must carry ASan's log_path: libubsan sets the report path through the
# function libasan exports, so its default (stderr) would redirect ASan's
# reports too. The fuzz tests (<module>/fuzz_<name>) run clang
# libFuzzer programs with their own ASan+UBSan, as in `make test`.
# tests/lsan.supp and tests/ubsan.supp list the third-party reports to
# ignore, each with its reason.
# CTEST_ARGS narrows either run, e.g. make test-asan CTEST_ARGS='-R ^track/'.
SANITIZER_TARGETS_tsan := track-tests e2e_track e2e_map rrslam-synth rrslam-extract rrslam-cluster \
                          rrslam-vocab rrslam-eval rrslam-mapstore
SANITIZER_TARGETS_asan := all
SANITIZER_TESTS_tsan := ^(track/|e2e/track$$|e2e/map$$)
SANITIZER_TESTS_asan := .
TSAN_OPTIONS ?= halt_on_error=1 second_deadlock_stack=1
ASAN_OPTIONS ?= halt_on_error=1 detect_leaks=1 check_initialization_order=1 strict_init_order=1
UBSAN_OPTIONS ?= halt_on_error=1 print_stacktrace=1
LSAN_OPTIONS ?= print_suppressions=0

# make test-asan-readers: the same, on the tests of the stages that read
# users' files (common, extract, cluster, vocab, mapstore, eval) and the tools
# they run; what CI runs (.ci/run), as the whole suite under ASan takes too long
# there (README.md has the figures).
ASAN_READERS_TARGETS := common-tests extract-tests cluster-tests vocab-tests mapstore-tests \
                        eval-tests rrslam-synth rrslam-extract rrslam-cluster rrslam-vocab \
                        rrslam-eval rrslam-mapstore
ASAN_READERS_TESTS := ^(common|extract|cluster|vocab|mapstore|eval)/

build-tsan/CMakeCache.txt build-asan/CMakeCache.txt: build-%/CMakeCache.txt: | deps
	cmake -S . -B build-$* -G "$(CMAKE_GENERATOR)" -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	  -DRRSLAM_DATA_DIR=$(SHARED_DATA) \
	  -DRRSLAM_SANITIZE=$(if $(filter tsan,$*),thread,address)

test-tsan test-asan: test-%: build-%/CMakeCache.txt
	cmake --build build-$* -j $(JOBS) --target $(SANITIZER_TARGETS_$*)
	logs=$(CURDIR)/build-$*/sanitizer-logs; rm -rf $$logs; mkdir -p $$logs; \
	  cd build-$* || exit 1; status=0; \
	  TSAN_OPTIONS="$(TSAN_OPTIONS) suppressions=$(CURDIR)/tests/tsan.supp log_path=$$logs/tsan" \
	  ASAN_OPTIONS="$(ASAN_OPTIONS) handle_abort=1 log_path=$$logs/asan" \
	  UBSAN_OPTIONS="$(UBSAN_OPTIONS) abort_on_error=1 suppressions=$(CURDIR)/tests/ubsan.supp log_path=$$logs/asan" \
	  LSAN_OPTIONS="$(LSAN_OPTIONS) suppressions=$(CURDIR)/tests/lsan.supp" \
	    ctest --output-on-failure -j $(JOBS) -R '$(SANITIZER_TESTS_$*)' $(CTEST_ARGS) || status=$$?; \
	  for report in $$(ls $$logs); do echo "=== $$logs/$$report"; cat $$logs/$$report; status=1; done; \
	  exit $$status

test-asan-readers:
	$(MAKE) test-asan SANITIZER_TARGETS_asan="$(ASAN_READERS_TARGETS)" \
	  SANITIZER_TESTS_asan='$(ASAN_READERS_TESTS)'

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
