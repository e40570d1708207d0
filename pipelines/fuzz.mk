# `make fuzz`: builds the libFuzzer targets (clang++ -fsanitize=fuzzer,address,
# undefined) in their own build tree, $(FUZZ_BUILD_DIR)/fuzz/, one per reader:
#   vocab_binary_fuzzer   the binary vocabulary loader (rrslam.vocabulary), past
#                         its checksums (common/fuzz/repair_header.h)
#   vocab_text_fuzzer     the DBoW2 text vocabulary parser
#   vocab_yaml_fuzzer     the DBoW2 YAML vocabulary parser (.yml, .yml.gz)
#   map_fuzzer            the map file reader (rrslam.map), past its checksums
#   settings_fuzzer       the settings YAML reader (ParseSettings, ParseViewpoint)
#   tum_lists_fuzzer      rgb.txt / depth.txt lists, associations files, pairing
#   trajectory_fuzzer     the TUM trajectory reader
#   features_fuzzer       the features file reader (rrslam.features, HDF5 image)
#   vocab_tree_fuzzer     the vocabulary tree reader (rrslam.vocab_tree, HDF5 image)
# `make fuzz-run FUZZ_SECONDS=600` then runs each for that long from its seed
# corpus, two at a time (bench/fuzz/run.sh through cmake/run_fuzzer.sh), and
# writes the figures to bench/results/fuzz-<date>.txt (fuzz-<date>-<N>s.txt
# for runs under 600 s); inputs each run added and its findings are in
# $(FUZZ_BUILD_DIR)/fuzz/work/<target>/ (corpus/, artifacts/).
# FUZZ_TARGETS="features_fuzzer map_fuzzer" runs only those.
# The test suite runs the same targets for a few seconds each (CTest tests
# <module>/fuzz_<name>, e.g. vocab/fuzz_vocab_binary).
# `make fuzz-seeds` rewrites the committed seed corpora from the code that
# generates them (after a format change), using the test programs of
# $(BUILD_DIR).

FUZZ_BUILD_DIR ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_TARGETS ?=

.PHONY: fuzz fuzz-run fuzz-seeds

$(FUZZ_BUILD_DIR)/CMakeCache.txt: | deps
	cmake -S . -B $(FUZZ_BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DRRSLAM_DATA_DIR=$(SHARED_DATA)

fuzz: $(FUZZ_BUILD_DIR)/CMakeCache.txt
	cmake --build $(FUZZ_BUILD_DIR) -j $(JOBS) --target fuzzers
	@echo "fuzz: targets in $(FUZZ_BUILD_DIR)/fuzz/ (run them with: make fuzz-run)"

fuzz-run: fuzz
	bench/fuzz/run.sh $(FUZZ_BUILD_DIR)/fuzz $(FUZZ_SECONDS) bench/results $(FUZZ_TARGETS)

# Each seed test writes its corpus under the folder RRSLAM_WRITE_FUZZ_SEEDS
# names and checks it reads back; the vocabulary seeds are the DBoW2 texts of
# stages/vocab/fuzz/corpus, their binary forms, and in corpus_yaml/ their
# DBoW2 YAML forms (k4_l3 gzip-compressed).
fuzz-seeds: $(BUILD_DIR)/CMakeCache.txt
	cmake --build $(BUILD_DIR) -j $(JOBS) --target common_text_seeds extract_features_seeds \
	  cluster_vocab_tree_seeds mapstore_map_file rrslam-vocab
	RRSLAM_WRITE_FUZZ_SEEDS=common/fuzz $(BUILD_DIR)/tests/common_text_seeds
	RRSLAM_WRITE_FUZZ_SEEDS=stages/extract/fuzz $(BUILD_DIR)/tests/extract_features_seeds
	RRSLAM_WRITE_FUZZ_SEEDS=stages/cluster/fuzz $(BUILD_DIR)/tests/cluster_vocab_tree_seeds
	RRSLAM_MAPSTORE_WRITE_SEEDS=stages/mapstore/fuzz/corpus $(BUILD_DIR)/tests/mapstore_map_file \
	  --gtest_filter=MapFile.WriteFuzzSeeds
	for f in stages/vocab/fuzz/corpus/*.txt; do \
	  $(BIN)/rrslam-vocab --quiet convert "$$f" "$${f%.txt}.rrv" || exit 1; \
	done
	mkdir -p stages/vocab/fuzz/corpus_yaml
	for v in k3_l2.yml k4_l3.yml.gz two_words.yml; do \
	  $(BIN)/rrslam-vocab --quiet convert stages/vocab/fuzz/corpus/$${v%%.*}.txt \
	    stages/vocab/fuzz/corpus_yaml/$$v || exit 1; \
	done
