# `make bench-extract`: ORB extraction time per 640x480 frame on the first 300
# frames of ../shared/data/7scenes-kitchen (preloaded, so image decoding is not
# timed): rrslam's OrbExtractor (1 and 2 threads) beside cv::ORB with the same
# nFeatures, scaleFactor and nLevels, in the same run. Goals: at most 1.2x
# cv::ORB's median time and at most 12 ms per frame.
# Result: bench/results/extract-<UTC date>.txt (machine line and date first).
BENCH_EXTRACT_FRAMES ?= 300
BENCH_EXTRACT_DATA ?= $(SHARED_DATA)/7scenes-kitchen
BENCH_EXTRACT_SETTINGS ?= $(SHARED_DATA)/settings/7scenes.yaml

.PHONY: bench-extract
bench-extract: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target bench_extract
	@if [ ! -d "$(BENCH_EXTRACT_DATA)" ]; then \
	  echo "bench-extract: $(BENCH_EXTRACT_DATA) not found, skipped"; exit 0; fi; \
	mkdir -p bench/results; \
	out=bench/results/extract-$$(date -u +%Y-%m-%d).txt; \
	cmd="$(BUILD_DIR)/bench/bench_extract --sequence $(BENCH_EXTRACT_DATA) --settings $(BENCH_EXTRACT_SETTINGS) --frames $(BENCH_EXTRACT_FRAMES) -q"; \
	{ echo "# bench-extract: ORB extraction time per frame (medians over $(BENCH_EXTRACT_FRAMES) frames)"; \
	  echo "# machine: $$(bench/machine.sh)"; \
	  echo "# load average before: $$(cut -d' ' -f1-3 /proc/loadavg)"; \
	  echo "# command: $$cmd"; \
	  $$cmd && echo "# load average after: $$(cut -d' ' -f1-3 /proc/loadavg)"; } > $$out.tmp && \
	mv $$out.tmp $$out && cat $$out || { rm -f $$out.tmp; exit 1; }

BENCH_TARGETS += bench-extract
