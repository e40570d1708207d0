# `make bench-octomap`: `rrslam-render octomap` on a map of the 7-Scenes
# kitchen at 5 cm, BENCH_OCTOMAP_RUNS runs as child processes (wall time,
# peak memory), the file read by octomap-tools (edit_octree), and the
# navigation grid made from it (`grid`): how many keyframe cameras stand
# over free cells. Goals (issue 32): <= 60 s and <= 2 GB on 2 cores. A minute.
#
# The map: BENCH_OCTOMAP_MAP, by default bench-dense's (frames [0, 500) of
# the kitchen; made as bench-dense makes it when missing). The floor is
# found from the map points and the keyframes' depth on every run (a map
# aligned by rrslam-mapstore align-floor uses the stored one).
# Result: bench/results/octomap-<UTC date>[-BENCH_OCTOMAP_TAG].txt (and .json);
# the tree and the grid stay in BENCH_OCTOMAP_DIR (map.bt, grid.yaml/pgm/png).
BENCH_OCTOMAP_DIR ?= $(BUILD_DIR)/bench-data/octomap
BENCH_OCTOMAP_MAP ?= $(BENCH_DENSE_MAP)
BENCH_OCTOMAP_SEQUENCE ?= $(BENCH_DENSE_SEQUENCE)
BENCH_OCTOMAP_RUNS ?= 3
BENCH_OCTOMAP_RESOLUTION ?= 0.05
BENCH_OCTOMAP_TAG ?=

.PHONY: bench-octomap
bench-octomap: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-render bench_octomap
	@if [ ! -f "$(BENCH_OCTOMAP_SEQUENCE)/rgb.txt" ]; then \
	  echo "bench-octomap: $(BENCH_OCTOMAP_SEQUENCE) not found, skipped"; exit 0; fi; \
	$(MAKE) --no-print-directory $(BENCH_OCTOMAP_MAP) && mkdir -p bench/results && \
	$(BUILD_DIR)/bench/bench_octomap --render $(BIN)/rrslam-render --map $(BENCH_OCTOMAP_MAP) \
	  --sequence $(BENCH_OCTOMAP_SEQUENCE) --work $(BENCH_OCTOMAP_DIR) \
	  --runs $(BENCH_OCTOMAP_RUNS) --resolution $(BENCH_OCTOMAP_RESOLUTION) \
	  --machine "$$(bench/machine.sh)" \
	  --out bench/results/octomap-$$(date -u +%Y-%m-%d)$(if $(BENCH_OCTOMAP_TAG),-$(BENCH_OCTOMAP_TAG))

BENCH_TARGETS += bench-octomap
