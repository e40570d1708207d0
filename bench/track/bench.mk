# `make bench-track`: the track stage against the goals of issue 4.
#
#  - ../shared/data/7scenes-kitchen (1000 frames, settings 7scenes.yaml) with a
#    vocabulary trained on that sequence: frames tracked, ATE RMSE (goal
#    <= 4.3 cm), median tracking time per frame with extraction, without image
#    loading (goal <= 15 ms), peak memory (goal <= 500 MB), two batch runs
#    byte-identical, and a realtime run paced at 30 Hz (local mapping keeps up).
#  - Synthetic rrslam-synth sequences of BENCH_TRACK_FRAMES frames (loop,
#    sweep, rotation), noise-free depth and default noise, each with a
#    vocabulary trained on its noise-free rendering: all frames tracked, ATE
#    RMSE <= 1 cm (noise-free) and <= 2 cm (noise).
# Result: bench/results/track-<UTC date>.txt (and .json).
#
# The inputs are file targets under BENCH_TRACK_DIR (default
# build/bench-data/track), made once and reused (delete the folder to redo):
#   kitchen/features.h5  ORB features of every frame (rrslam-extract)
#   kitchen/tree.h5      k = 10, L = 6 tree on every 2nd frame (rrslam-cluster)
#   kitchen/voc.rrv      the vocabulary (rrslam-vocab build)
#   synth/<path>-clean/, synth/<path>-noisy/   sequences (rrslam-synth, seed 1)
#   synth/<path>-vocab/voc.rrv  vocabulary trained on <path>-clean
BENCH_TRACK_DIR ?= $(BUILD_DIR)/bench-data/track
BENCH_TRACK_FRAMES ?= 600
BENCH_TRACK_KITCHEN ?= $(SHARED_DATA)/7scenes-kitchen
BENCH_TRACK_SETTINGS ?= $(SHARED_DATA)/settings/7scenes.yaml
BENCH_TRACK_PATHS := loop sweep rotation

bench_track_tools := rrslam-synth rrslam-extract rrslam-cluster rrslam-vocab rrslam-track \
  rrslam-eval bench_track

$(BENCH_TRACK_DIR)/kitchen/features.h5:
	@mkdir -p $(@D)
	$(BIN)/rrslam-extract --quiet --sequence $(BENCH_TRACK_KITCHEN) \
	  --settings $(BENCH_TRACK_SETTINGS) --out $@
$(BENCH_TRACK_DIR)/kitchen/tree.h5: $(BENCH_TRACK_DIR)/kitchen/features.h5
	$(BIN)/rrslam-cluster --quiet --features $< --stride 2 --k 10 --levels 6 --seed 0 --out $@
$(BENCH_TRACK_DIR)/kitchen/voc.rrv: $(BENCH_TRACK_DIR)/kitchen/tree.h5 \
                                    $(BENCH_TRACK_DIR)/kitchen/features.h5
	$(BIN)/rrslam-vocab --quiet build --tree $< --features $(word 2,$^) --stride 2 --out $@

# bench_track_synth(path): the two renderings and the vocabulary of one path.
define bench_track_synth
$(BENCH_TRACK_DIR)/synth/$(1)-clean/groundtruth.txt:
	@mkdir -p $$(dir $$(@D))
	$(BIN)/rrslam-synth --quiet --out $$(@D) --trajectory $(1) --frames $(BENCH_TRACK_FRAMES) \
	  --seed 1 --depth-noise 0
$(BENCH_TRACK_DIR)/synth/$(1)-noisy/groundtruth.txt:
	@mkdir -p $$(dir $$(@D))
	$(BIN)/rrslam-synth --quiet --out $$(@D) --trajectory $(1) --frames $(BENCH_TRACK_FRAMES) \
	  --seed 1
$(BENCH_TRACK_DIR)/synth/$(1)-vocab/features.h5: $(BENCH_TRACK_DIR)/synth/$(1)-clean/groundtruth.txt
	@mkdir -p $$(@D)
	$(BIN)/rrslam-extract --quiet --sequence $$(<D) --settings $$(<D)/settings.yaml --out $$@
$(BENCH_TRACK_DIR)/synth/$(1)-vocab/tree.h5: $(BENCH_TRACK_DIR)/synth/$(1)-vocab/features.h5
	$(BIN)/rrslam-cluster --quiet --features $$< --stride 2 --k 10 --levels 5 --seed 0 --out $$@
$(BENCH_TRACK_DIR)/synth/$(1)-vocab/voc.rrv: $(BENCH_TRACK_DIR)/synth/$(1)-vocab/tree.h5 \
                                             $(BENCH_TRACK_DIR)/synth/$(1)-vocab/features.h5
	$(BIN)/rrslam-vocab --quiet build --tree $$< --features $$(word 2,$$^) --stride 2 --out $$@
endef
$(foreach p,$(BENCH_TRACK_PATHS),$(eval $(call bench_track_synth,$(p))))

bench_track_synth_inputs := $(foreach p,$(BENCH_TRACK_PATHS), \
  $(BENCH_TRACK_DIR)/synth/$(p)-clean/groundtruth.txt \
  $(BENCH_TRACK_DIR)/synth/$(p)-noisy/groundtruth.txt \
  $(BENCH_TRACK_DIR)/synth/$(p)-vocab/voc.rrv)
bench_track_kitchen_inputs := $(if $(wildcard $(BENCH_TRACK_KITCHEN)/rgb.txt), \
  $(BENCH_TRACK_DIR)/kitchen/voc.rrv)

.PHONY: bench-track bench-track-data
bench-track-data: $(bench_track_kitchen_inputs) $(bench_track_synth_inputs)

bench-track: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(bench_track_tools)
	$(MAKE) --no-print-directory bench-track-data
	@mkdir -p bench/results
	$(BUILD_DIR)/bench/bench_track --bin $(BIN) --data $(BENCH_TRACK_DIR) \
	  --kitchen $(BENCH_TRACK_KITCHEN) --kitchen-settings $(BENCH_TRACK_SETTINGS) \
	  --paths "$(BENCH_TRACK_PATHS)" --machine "$$(bench/machine.sh)" \
	  --out bench/results/track-$$(date -u +%Y-%m-%d)

BENCH_TARGETS += bench-track
