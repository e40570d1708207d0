# `make demo`: the main job on built-in data. Renders a synthetic RGB-D room
# sequence and runs the pipeline's stages on it; outputs under build/demo/.
DEMO_DIR := $(BUILD_DIR)/demo

.PHONY: demo
demo: build
	@mkdir -p $(DEMO_DIR)
	$(BIN)/rrslam-synth --out $(DEMO_DIR)/room --trajectory loop --frames 120 --seed 1
	$(BIN)/rrslam-extract --sequence $(DEMO_DIR)/room --settings $(DEMO_DIR)/room/settings.yaml \
	  --out $(DEMO_DIR)/features.h5
	@echo "demo: outputs in $(DEMO_DIR)/"
