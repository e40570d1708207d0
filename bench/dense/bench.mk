# `make bench-dense`: `rrslam-render dense` on the map of the 7-Scenes kitchen
# (frames [0, 500) of ../shared/data/7scenes-kitchen mapped by rrslam-track,
# 58 keyframes) at --voxel 0.01: BENCH_DENSE_RUNS runs as child processes,
# each one's wall time and peak memory (ru_maxrss from wait4), the stage
# times rrslam-render prints, the points exported; a --voxel 0.0052 run,
# whose voxel grid (2.8 GB) is near the default cap --max-volume-gb 3, within
# 4 GB too (what the default promises); and a --voxel 0.004 run, whose volume
# is above the cap, refused (exit 64). Goals: <= 60 s (median) and <= 4 GB
# peak memory at --voxel 0.01 on 2 cores. About 4 minutes.
#
# The map is bench-map's (build/bench-data/map/runs/7scenes-kitchen.rrm) when
# it exists; otherwise the same mapping run is made here (the bench-track
# pipeline's vocabulary of the kitchen, trained first if missing).
# Result: bench/results/dense-<UTC date>[-BENCH_DENSE_TAG].txt (and .json);
# the model and its picture stay in BENCH_DENSE_DIR/run/ (model.ply, model.png).
BENCH_DENSE_DIR ?= $(BUILD_DIR)/bench-data/dense
BENCH_DENSE_SEQUENCE ?= $(SHARED_DATA)/7scenes-kitchen
BENCH_DENSE_SETTINGS ?= $(SHARED_DATA)/settings/7scenes.yaml
BENCH_DENSE_MAP ?= $(firstword $(wildcard $(BUILD_DIR)/bench-data/map/runs/7scenes-kitchen.rrm) \
  $(BENCH_DENSE_DIR)/7scenes-kitchen.rrm)
BENCH_DENSE_RUNS ?= 3
BENCH_DENSE_VOXEL ?= 0.01
BENCH_DENSE_TAG ?=
bench_dense_pipeline := $(BUILD_DIR)/bench-data/track/pipeline

# The kitchen's map, as bench-map makes it (frames [0, 500), batch mode).
$(BENCH_DENSE_DIR)/7scenes-kitchen.rrm:
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-extract rrslam-cluster rrslam-vocab \
	  rrslam-track
	$(MAKE) --no-print-directory $(bench_dense_pipeline)/7scenes-kitchen/voc.rrv SKIP_BUILD=1 \
	  DATASET=7scenes-kitchen DATA_ROOT=$(patsubst %/,%,$(dir $(BENCH_DENSE_SEQUENCE))) \
	  SETTINGS=$(BENCH_DENSE_SETTINGS) PIPELINE_ROOT=$(bench_dense_pipeline)
	@mkdir -p $(@D)
	$(BIN)/rrslam-track --quiet --sequence $(BENCH_DENSE_SEQUENCE) \
	  --settings $(BENCH_DENSE_SETTINGS) --vocab $(bench_dense_pipeline)/7scenes-kitchen/voc.rrv \
	  --out $(BENCH_DENSE_DIR)/mapping --max-frames 500 --save-map $@

.PHONY: bench-dense
bench-dense: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-render bench_dense
	@if [ ! -f "$(BENCH_DENSE_SEQUENCE)/rgb.txt" ]; then \
	  echo "bench-dense: $(BENCH_DENSE_SEQUENCE) not found, skipped"; exit 0; fi; \
	$(MAKE) --no-print-directory $(BENCH_DENSE_MAP) && mkdir -p bench/results && \
	$(BUILD_DIR)/bench/bench_dense --render $(BIN)/rrslam-render --map $(BENCH_DENSE_MAP) \
	  --sequence $(BENCH_DENSE_SEQUENCE) --work $(BENCH_DENSE_DIR)/run \
	  --runs $(BENCH_DENSE_RUNS) --voxel $(BENCH_DENSE_VOXEL) --machine "$$(bench/machine.sh)" \
	  --out bench/results/dense-$$(date -u +%Y-%m-%d)$(if $(BENCH_DENSE_TAG),-$(BENCH_DENSE_TAG))

BENCH_TARGETS += bench-dense
