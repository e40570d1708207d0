# `make bench-lifelong`: maps kept over many sessions, against the goals of
# issue 31.
#
#  - Identical sessions (BENCH_LIFELONG_REAL, by default the kitchen and
#    fr1_xyz): the first BENCH_LIFELONG_FRAMES frames mapped and saved, then
#    BENCH_LIFELONG_SESSIONS restore-mapping runs on the same frames, each on
#    the map the last one saved. Per session: loaded points culled as changed
#    (goal <= 1%), keyframes and points after it; keyframes after the last
#    session at most 1.1 x those after the first. Each sequence with the
#    vocabulary and cached features of bench-track's pipeline (built here if
#    missing), so the sessions differ only by the map they load.
#  - Offline merge: each sequence's first 30% and last 40% of frames mapped
#    separately (two world frames) and merged (rrslam-mapstore merge): the
#    merged map's keyframes against the ground truth under one rigid
#    alignment, at most 1.2 x the keyframe ATE of one run over every frame;
#    the middle 30% localized in the merged map (--localization-only): at
#    least 99% of its frames tracked.
#  - Atlas (issue 31's online merge) on rrslam-synth's room: the sweep
#    mapped; the turn, which starts looking away from it and turns onto it,
#    run on that map in batch and realtime mode: merged within 1 s of camera
#    time after the first frame whose true view overlaps the map, ATE <= 2 cm
#    in the loaded map's frame, 0 frames lost after the merge; the turn's
#    first 100 frames (never meeting the map): 0 frames lost after the new
#    map started. With the first real sequence's vocabulary.
#  - Kills: BENCH_LIFELONG_KILLS SIGKILLs of rrslam-mapstore merge (the first
#    real sequence's two maps, --out an existing map) at moments uniform over
#    its run, and as many of the turn session loading and saving one map
#    file at moments uniform over its merge: the old map intact each time, or
#    the new one complete; never a broken file.
# Result: bench/results/lifelong-<UTC date>[-BENCH_LIFELONG_TAG].txt (and .json).
BENCH_LIFELONG_DIR ?= $(BUILD_DIR)/bench-data/lifelong
BENCH_LIFELONG_REAL ?= 7scenes-kitchen fr1_xyz
BENCH_LIFELONG_FRAMES ?= 150
BENCH_LIFELONG_SESSIONS ?= 5
BENCH_LIFELONG_KILLS ?= 10
BENCH_LIFELONG_TAG ?=
bench_lifelong_pipeline := $(BUILD_DIR)/bench-data/track/pipeline
bench_lifelong_present := $(call bench_real_present,$(BENCH_LIFELONG_REAL))

.PHONY: bench-lifelong
bench-lifelong: configure
	@$(call bench_real_missing,$(BENCH_LIFELONG_REAL),bench-lifelong)
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-extract rrslam-cluster rrslam-vocab \
	  rrslam-track rrslam-mapstore rrslam-synth bench_lifelong
	$(foreach n,$(bench_lifelong_present),$(MAKE) --no-print-directory \
	  $(bench_lifelong_pipeline)/$(n)/voc.rrv SKIP_BUILD=1 DATASET=$(n) \
	  DATA_ROOT=$(patsubst %/,%,$(dir $(call bench_real_dir,$(n)))) \
	  SETTINGS=$(call bench_real_settings,$(n)) PIPELINE_ROOT=$(bench_lifelong_pipeline) &&) true
	@mkdir -p bench/results
	$(BUILD_DIR)/bench/bench_lifelong --bin $(BIN) --runs $(BENCH_LIFELONG_DIR) \
	  $(foreach n,$(bench_lifelong_present),--real $(n) --real-dir $(call bench_real_dir,$(n)) \
	    --real-settings $(call bench_real_settings,$(n)) \
	    --real-vocab $(bench_lifelong_pipeline)/$(n)/voc.rrv \
	    --real-features $(bench_lifelong_pipeline)/$(n)/features.h5) \
	  $(if $(bench_lifelong_present),--synth-vocab $(bench_lifelong_pipeline)/$(firstword $(bench_lifelong_present))/voc.rrv) \
	  --frames $(BENCH_LIFELONG_FRAMES) --sessions $(BENCH_LIFELONG_SESSIONS) \
	  --kills $(BENCH_LIFELONG_KILLS) \
	  --machine "$$(bench/machine.sh)" \
	  --command '$(call bench_command,bench-lifelong,BENCH_LIFELONG_REAL BENCH_LIFELONG_FRAMES BENCH_LIFELONG_SESSIONS BENCH_LIFELONG_KILLS BENCH_LIFELONG_TAG BENCH_LIFELONG_DIR)' \
	  --out bench/results/lifelong-$$(date -u +%Y-%m-%d)$(if $(BENCH_LIFELONG_TAG),-$(BENCH_LIFELONG_TAG))
BENCH_TARGETS += bench-lifelong
