# `make bench-track`: the track stage against the goals of issue 4.
#
#  - ../shared/data/7scenes-kitchen (1000 frames, settings 7scenes.yaml) with a
#    vocabulary trained on that sequence: frames tracked, ATE RMSE (goal
#    <= 4.3 cm), median tracking time per frame with extraction, without image
#    loading (goal <= 15 ms), peak memory (goal <= 500 MB), two batch runs
#    byte-identical, and a realtime run paced at 30 Hz (local mapping keeps up);
#    as a diagnostic, the ATE with other vocabularies trained on the sequence.
#  - Synthetic rrslam-synth sequences of BENCH_TRACK_FRAMES frames (loop,
#    sweep, rotation), noise-free depth and default noise, each with a
#    vocabulary trained on its noise-free rendering: all frames tracked, ATE
#    RMSE <= 1 cm (noise-free) and <= 2 cm (noise).
# Result: bench/results/track-<UTC date>.txt (and .json).
#
# The inputs live under BENCH_TRACK_DIR (default build/bench-data/track). The
# vocabularies come from the vocab pipeline (pipelines/vocab.mk, the recipe of
# `make vocab`), whose steps are file targets depending on their inputs and
# executables; the synthetic sequences depend on rrslam-synth. So a rerun
# redoes exactly what a changed tool or input made stale:
#   pipeline/7scenes-kitchen/  features.h5, tree.h5, voc.rrv: the kitchen's own
#                              vocabulary with the pipeline's defaults
#                              (k = 10, L = 6, every frame), as
#                              `make vocab DATASET=7scenes-kitchen` trains it
#   synth/<path>-clean/, synth/<path>-noisy/   sequences (rrslam-synth, seed 1)
#   pipeline/<path>-clean/voc.rrv  vocabulary trained on <path>-clean
#                              (k = 10, L = 5, every 2nd frame)
#   pipeline-stride2-seed<s>/7scenes-kitchen/voc.rrv  the kitchen's other
#                              vocabularies (diagnostic, BENCH_TRACK_OTHER_SEEDS)
BENCH_TRACK_DIR ?= $(BUILD_DIR)/bench-data/track
BENCH_TRACK_FRAMES ?= 600
BENCH_TRACK_KITCHEN ?= $(SHARED_DATA)/7scenes-kitchen
BENCH_TRACK_SETTINGS ?= $(SHARED_DATA)/settings/7scenes.yaml
BENCH_TRACK_PATHS := loop sweep rotation

bench_track_tools := rrslam-synth rrslam-extract rrslam-cluster rrslam-vocab rrslam-track \
  rrslam-eval bench_track
bench_track_pipeline := $(BENCH_TRACK_DIR)/pipeline
bench_track_kitchen_name := $(notdir $(BENCH_TRACK_KITCHEN))
bench_track_kitchen_vocab := $(bench_track_pipeline)/$(bench_track_kitchen_name)/voc.rrv

# bench_track_synth(path): the two renderings of one path.
define bench_track_synth
$(BENCH_TRACK_DIR)/synth/$(1)-clean/groundtruth.txt: $(BIN)/rrslam-synth
	@mkdir -p $$(dir $$(@D))
	$(BIN)/rrslam-synth --quiet --out $$(@D) --trajectory $(1) --frames $(BENCH_TRACK_FRAMES) \
	  --seed 1 --depth-noise 0
$(BENCH_TRACK_DIR)/synth/$(1)-noisy/groundtruth.txt: $(BIN)/rrslam-synth
	@mkdir -p $$(dir $$(@D))
	$(BIN)/rrslam-synth --quiet --out $$(@D) --trajectory $(1) --frames $(BENCH_TRACK_FRAMES) \
	  --seed 1
endef
$(foreach p,$(BENCH_TRACK_PATHS),$(eval $(call bench_track_synth,$(p))))

bench_track_synth_inputs := $(foreach p,$(BENCH_TRACK_PATHS), \
  $(BENCH_TRACK_DIR)/synth/$(p)-clean/groundtruth.txt \
  $(BENCH_TRACK_DIR)/synth/$(p)-noisy/groundtruth.txt)
bench_track_has_kitchen := $(wildcard $(BENCH_TRACK_KITCHEN)/rgb.txt)
bench_track_kitchen_args := SKIP_BUILD=1 DATASET=$(bench_track_kitchen_name) \
  DATA_ROOT=$(patsubst %/,%,$(dir $(BENCH_TRACK_KITCHEN))) SETTINGS=$(BENCH_TRACK_SETTINGS)
# Diagnostic: the kitchen's ATE with other vocabularies trained on it (every
# 2nd frame, with these k-means seeds), to show its spread over training choices.
BENCH_TRACK_OTHER_SEEDS ?= 0 1
bench_track_other_pipeline = $(BENCH_TRACK_DIR)/pipeline-stride2-seed$(1)
bench_track_other_vocab = $(call bench_track_other_pipeline,$(1))/$(bench_track_kitchen_name)/voc.rrv

.PHONY: bench-track bench-track-data
bench-track-data: $(bench_track_synth_inputs)
ifneq ($(bench_track_has_kitchen),)
	$(MAKE) --no-print-directory $(bench_track_kitchen_vocab) $(bench_track_kitchen_args) \
	  PIPELINE_ROOT=$(bench_track_pipeline)
	$(foreach s,$(BENCH_TRACK_OTHER_SEEDS),$(MAKE) --no-print-directory \
	  $(call bench_track_other_vocab,$(s)) $(bench_track_kitchen_args) PIPELINE_ROOT=$(call bench_track_other_pipeline,$(s)) \
	  VOCAB_STRIDE=2 VOCAB_SEED=$(s) &&) true
endif
	$(MAKE) --no-print-directory SKIP_BUILD=1 \
	  $(foreach p,$(BENCH_TRACK_PATHS),$(bench_track_pipeline)/$(p)-clean/voc.rrv) \
	  DATASET="$(addsuffix -clean,$(BENCH_TRACK_PATHS))" DATA_ROOT=$(BENCH_TRACK_DIR)/synth \
	  PIPELINE_ROOT=$(bench_track_pipeline) VOCAB_L=5 VOCAB_STRIDE=2

bench-track: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(bench_track_tools)
	$(MAKE) --no-print-directory bench-track-data
	@mkdir -p bench/results
	$(BUILD_DIR)/bench/bench_track --bin $(BIN) --data $(BENCH_TRACK_DIR) \
	  --kitchen $(BENCH_TRACK_KITCHEN) --kitchen-settings $(BENCH_TRACK_SETTINGS) \
	  --kitchen-vocab $(bench_track_kitchen_vocab) \
	  $(foreach s,$(BENCH_TRACK_OTHER_SEEDS),--kitchen-other-vocab $(call bench_track_other_vocab,$(s))) \
	  --paths "$(BENCH_TRACK_PATHS)" --machine "$$(bench/machine.sh)" \
	  --out bench/results/track-$$(date -u +%Y-%m-%d)

BENCH_TARGETS += bench-track
