# `make fuzz`: builds the libFuzzer targets (clang++ -fsanitize=fuzzer,address,
# undefined) in their own build tree, $(FUZZ_BUILD_DIR)/fuzz/:
#   vocab_binary_fuzzer   the binary vocabulary loader (rrslam.vocabulary)
#   vocab_text_fuzzer     the DBoW2 text vocabulary parser
#   map_fuzzer            the map file reader (rrslam.map)
# `make fuzz-run FUZZ_SECONDS=300` then runs each for that long from the seed
# corpora in stages/vocab/fuzz/corpus and stages/mapstore/fuzz/corpus
# (findings in $(FUZZ_BUILD_DIR)/fuzz/work/ and mapstore_work/ artifacts/).
# The test suite runs the same targets for a few seconds each (CTest tests
# vocab/fuzz and mapstore/fuzz).

FUZZ_BUILD_DIR ?= build-fuzz
FUZZ_SECONDS ?= 60

.PHONY: fuzz fuzz-run

$(FUZZ_BUILD_DIR)/CMakeCache.txt: | deps
	cmake -S . -B $(FUZZ_BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DRRSLAM_DATA_DIR=$(SHARED_DATA)

fuzz: $(FUZZ_BUILD_DIR)/CMakeCache.txt
	cmake --build $(FUZZ_BUILD_DIR) -j $(JOBS) --target vocab_fuzzers mapstore_fuzzers
	@echo "fuzz: targets in $(FUZZ_BUILD_DIR)/fuzz/ (run them with: make fuzz-run)"

fuzz-run: fuzz
	cmake --build $(FUZZ_BUILD_DIR) -j $(JOBS) --target rrslam-vocab
	stages/vocab/fuzz/run_fuzzers.sh $(FUZZ_BUILD_DIR)/fuzz $(FUZZ_BUILD_DIR)/bin/rrslam-vocab \
	  stages/vocab/fuzz/corpus $(FUZZ_BUILD_DIR)/fuzz/work $(FUZZ_SECONDS)
	stages/mapstore/fuzz/run_fuzzer.sh $(FUZZ_BUILD_DIR)/fuzz stages/mapstore/fuzz/corpus \
	  $(FUZZ_BUILD_DIR)/fuzz/mapstore_work $(FUZZ_SECONDS)
