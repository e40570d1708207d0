# `make demo`: the main job on built-in data, no network and no shared data.
# Renders a synthetic room sequence with exact ground truth (rrslam-synth),
# trains a small vocabulary on it (pipelines/vocab.mk: extract -> cluster ->
# vocab), tracks it (rrslam-track on the cached features) and evaluates the
# trajectory against the ground truth (rrslam-eval ate, with a plot) and
# draws the saved map, floor-aligned (rrslam-mapstore align-floor), and the
# trajectory, and makes the navigation grid (rrslam-render):
#   $(DEMO_DIR)/room/                       the sequence (TUM layout, settings.yaml)
#   $(DEMO_DIR)/pipeline/room/features.h5   ORB features; tree.h5, voc.rrv, voc.txt
#   $(DEMO_DIR)/track/                      CameraTrajectory.txt, KeyFrameTrajectory.txt, run.json
#   $(DEMO_DIR)/map.rrm                     the saved map (rrslam.map), its floor frame stored
#   $(DEMO_DIR)/ate.txt, ate.png            absolute trajectory error and its plot
#   $(DEMO_DIR)/render/map_*.png            the map from above and in perspective, z up
#   $(DEMO_DIR)/render/trajectory_*.png     trajectories against the ground truth, error over time
#   $(DEMO_DIR)/render/view.html            the map in 3D in a browser (one offline file)
#   $(DEMO_DIR)/render/grid.{yaml,pgm,png}  the navigation grid (ROS map_server) and its picture
# Every step is a file target: a second `make demo` redoes only what is stale.
# Variables: DEMO_FRAMES (300), DEMO_TRAJECTORY (loop), DEMO_SEED (1).
DEMO_DIR ?= $(BUILD_DIR)/demo
DEMO_FRAMES ?= 300
DEMO_TRAJECTORY ?= loop
DEMO_SEED ?= 1
demo_seq := $(DEMO_DIR)/room
demo_pipeline := $(DEMO_DIR)/pipeline/room

.PHONY: demo demo-run demo-tools
demo_render := $(DEMO_DIR)/render
# Only the eight tools the demo runs are built (`make test` builds the rest).
DEMO_TOOLS := rrslam-synth rrslam-extract rrslam-cluster rrslam-vocab rrslam-track rrslam-eval \
              rrslam-render rrslam-mapstore
demo-tools:
	@echo "demo: 1/3 Debian packages the tools need (scripts/install-deps.sh build; about 2 min" \
	  "on a fresh Debian 12 machine, nothing when they are there)"
	@$(MAKE) --no-print-directory deps-build
	@echo "demo: 2/3 building the $(words $(DEMO_TOOLS)) tools the demo runs into $(BIN)/" \
	  "(about 4 min on 2 cores without ccache; seconds when built)"
	@$(MAKE) --no-print-directory configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target $(DEMO_TOOLS)
	@echo "demo: 3/3 running: synthetic room -> vocabulary -> tracking -> evaluation -> pictures" \
	  "(about 30 s)"

demo: demo-tools
	@$(MAKE) --no-print-directory demo-run
	@echo "demo: outputs in $(DEMO_DIR)/ (trajectory in track/, error plot ate.png):"
	@cat $(DEMO_DIR)/ate.txt
	@echo "demo: pictures of the run:"
	@echo "  map from above        $(demo_render)/map_top.png (floor frame: z up)"
	@echo "  map in perspective    $(demo_render)/map_perspective.png"
	@echo "  navigation grid       $(demo_render)/grid.png (ROS map_server files grid.yaml, grid.pgm)"
	@echo "  trajectory vs. truth  $(demo_render)/trajectory_top.png (and _side, _front, _error)"
	@echo "  3D viewer             $(demo_render)/view.html (open in a browser; works offline)"

demo-run: $(DEMO_DIR)/ate.txt $(demo_render)/map_top.png $(demo_render)/trajectory_top.png \
          $(demo_render)/view.html $(demo_render)/grid.png

$(demo_seq)/groundtruth.txt: $(BIN)/rrslam-synth
	@mkdir -p $(DEMO_DIR)
	$(BIN)/rrslam-synth --out $(demo_seq) --trajectory $(DEMO_TRAJECTORY) --frames $(DEMO_FRAMES) \
	  --seed $(DEMO_SEED)

# The vocabulary pipeline, run on the demo's data root (L = 5 suits a few
# hundred training images).
$(demo_pipeline)/features.h5 $(demo_pipeline)/voc.rrv &: $(demo_seq)/groundtruth.txt
	$(MAKE) --no-print-directory vocab DATASET=room DATA_ROOT=$(DEMO_DIR) \
	  PIPELINE_ROOT=$(DEMO_DIR)/pipeline SKIP_BUILD=1 VOCAB_L=5

# The map is saved, then its floor found (in the keyframes' depth too) and
# stored in it, so every picture can be drawn z up.
$(DEMO_DIR)/track/run.json $(DEMO_DIR)/map.rrm &: $(demo_pipeline)/features.h5 $(demo_pipeline)/voc.rrv $(BIN)/rrslam-track $(BIN)/rrslam-mapstore
	$(BIN)/rrslam-track --sequence $(demo_seq) --settings $(demo_seq)/settings.yaml \
	  --vocab $(demo_pipeline)/voc.rrv --features $(demo_pipeline)/features.h5 --out $(DEMO_DIR)/track \
	  --save-map $(DEMO_DIR)/map.rrm
	$(BIN)/rrslam-mapstore align-floor $(DEMO_DIR)/map.rrm --sequence $(demo_seq)

$(DEMO_DIR)/ate.txt: $(DEMO_DIR)/track/run.json $(BIN)/rrslam-eval
	$(BIN)/rrslam-eval ate --gt $(demo_seq)/groundtruth.txt \
	  --est $(DEMO_DIR)/track/CameraTrajectory.txt --plot $(DEMO_DIR)/ate.png \
	  --plot-title "rrslam demo ($(DEMO_TRAJECTORY), $(DEMO_FRAMES) frames)" --out $@

$(demo_render)/map_top.png: $(DEMO_DIR)/map.rrm $(BIN)/rrslam-render
	$(BIN)/rrslam-render map --map $< --out $(@D) --view top --view perspective --frame floor

$(demo_render)/trajectory_top.png: $(DEMO_DIR)/track/run.json $(BIN)/rrslam-render
	$(BIN)/rrslam-render trajectory --gt $(demo_seq)/groundtruth.txt \
	  --est $(DEMO_DIR)/track/CameraTrajectory.txt --est $(DEMO_DIR)/track/KeyFrameTrajectory.txt \
	  --title "rrslam demo" --out $(@D)

$(demo_render)/view.html: $(DEMO_DIR)/map.rrm $(BIN)/rrslam-render
	$(BIN)/rrslam-render html --map $< --gt $(demo_seq)/groundtruth.txt --out $@ --frame floor

$(demo_render)/grid.png: $(DEMO_DIR)/map.rrm $(BIN)/rrslam-render
	$(BIN)/rrslam-render grid --map $< --sequence $(demo_seq) --out $(@D)/grid.yaml
