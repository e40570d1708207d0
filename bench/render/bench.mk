# `make bench-render`: rrslam-render's map pictures (<= 1 s) and HTML viewer
# (<= 5 MB) on a generated 200-keyframe, 20,000-point map (bench_render.cc).
# The dense model is measured by bench-dense (bench/dense/bench.mk).
# Result: bench/results/render-<UTC date>.txt (and .json).
BENCH_RENDER_DIR ?= $(BUILD_DIR)/bench-data/render
BENCH_RENDER_REPEATS ?= 5

.PHONY: bench-render
bench-render: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-render bench_render
	@mkdir -p bench/results
	$(BUILD_DIR)/bench/bench_render --bin $(BIN) --runs $(BENCH_RENDER_DIR) \
	  --repeats $(BENCH_RENDER_REPEATS) --machine "$$(bench/machine.sh)" \
	  --out bench/results/render-$$(date -u +%Y-%m-%d)

BENCH_TARGETS += bench-render
