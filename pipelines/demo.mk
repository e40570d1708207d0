# `make demo`: the main job on built-in data, no network and no shared data.
# Renders a synthetic room sequence with exact ground truth (rrslam-synth),
# trains a small vocabulary on it (pipelines/vocab.mk: extract -> cluster ->
# vocab), tracks it (rrslam-track on the cached features) and evaluates the
# trajectory against the ground truth (rrslam-eval ate, with a plot):
#   $(DEMO_DIR)/room/                       the sequence (TUM layout, settings.yaml)
#   $(DEMO_DIR)/pipeline/room/features.h5   ORB features; tree.h5, voc.rrv, voc.txt
#   $(DEMO_DIR)/track/                      CameraTrajectory.txt, KeyFrameTrajectory.txt, run.json
#   $(DEMO_DIR)/ate.txt, ate.png            absolute trajectory error and its plot
# Every step is a file target: a second `make demo` redoes only what is stale.
# Variables: DEMO_FRAMES (300), DEMO_TRAJECTORY (loop), DEMO_SEED (1).
DEMO_DIR ?= $(BUILD_DIR)/demo
DEMO_FRAMES ?= 300
DEMO_TRAJECTORY ?= loop
DEMO_SEED ?= 1
demo_seq := $(DEMO_DIR)/room
demo_pipeline := $(DEMO_DIR)/pipeline/room

.PHONY: demo demo-run
demo: build
	@$(MAKE) --no-print-directory demo-run
	@echo "demo: outputs in $(DEMO_DIR)/ (trajectory in track/, error plot ate.png):"
	@cat $(DEMO_DIR)/ate.txt

demo-run: $(DEMO_DIR)/ate.txt

$(demo_seq)/groundtruth.txt: $(BIN)/rrslam-synth
	@mkdir -p $(DEMO_DIR)
	$(BIN)/rrslam-synth --out $(demo_seq) --trajectory $(DEMO_TRAJECTORY) --frames $(DEMO_FRAMES) \
	  --seed $(DEMO_SEED)

# The vocabulary pipeline, run on the demo's data root (L = 5 suits a few
# hundred training images).
$(demo_pipeline)/features.h5 $(demo_pipeline)/voc.rrv &: $(demo_seq)/groundtruth.txt
	$(MAKE) --no-print-directory vocab DATASET=room DATA_ROOT=$(DEMO_DIR) \
	  PIPELINE_ROOT=$(DEMO_DIR)/pipeline SKIP_BUILD=1 VOCAB_L=5

$(DEMO_DIR)/track/run.json: $(demo_pipeline)/features.h5 $(demo_pipeline)/voc.rrv $(BIN)/rrslam-track
	$(BIN)/rrslam-track --sequence $(demo_seq) --settings $(demo_seq)/settings.yaml \
	  --vocab $(demo_pipeline)/voc.rrv --features $(demo_pipeline)/features.h5 --out $(@D)

$(DEMO_DIR)/ate.txt: $(DEMO_DIR)/track/run.json $(BIN)/rrslam-eval
	$(BIN)/rrslam-eval ate --gt $(demo_seq)/groundtruth.txt \
	  --est $(DEMO_DIR)/track/CameraTrajectory.txt --plot $(DEMO_DIR)/ate.png \
	  --plot-title "rrslam demo ($(DEMO_TRAJECTORY), $(DEMO_FRAMES) frames)" --out $@
