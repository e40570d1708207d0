# `make bench-vocab`: the vocabulary benchmark (bench/vocab/run.sh). Generates
# an ORBvoc-shaped vocabulary (k=10, L=6, ~1.08 M nodes) and measures its text
# and binary load times, binary size, the BoW transform of 1000 descriptors,
# and training (rrslam-cluster + rrslam-vocab build) on every 2nd frame of
# $(SHARED_DATA)/7scenes-kitchen. Results: bench/results/vocab-<date>.txt.
BENCH_TARGETS += bench-vocab

.PHONY: bench-vocab
bench-vocab: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-extract rrslam-cluster rrslam-vocab \
	  vocab_bench vocab_bench_generate
	bench/vocab/run.sh $(BUILD_DIR) $(SHARED_DATA) bench/results
