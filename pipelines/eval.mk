# `make eval-all`: tracks every RGB-D sequence with ground truth under
# DATA_ROOT (a folder holding rgb.txt and groundtruth.txt, e.g. TUM's
# rgbd_dataset_freiburg1_room) and evaluates its trajectory (ATE), with any
# vocabulary:
#   VOCAB=<file>   one vocabulary for every sequence (ORB-SLAM2's ORBvoc.txt, a
#                  .rrv from `make vocab`, ...); results in $(EVAL_ROOT)/<file name>/
#   VOCAB unset    each sequence's own small vocabulary, trained by the vocab
#                  pipeline (pipelines/vocab.mk); results in $(EVAL_ROOT)/own/
# Per sequence <name>, in the results folder:
#   <name>/track/      rrslam-track's outputs (CameraTrajectory.txt, run.json, ...),
#                      run on the sequence's cached features (vocab pipeline's
#                      features.h5, so a rerun skips extraction)
#   <name>/ate.json    rrslam-eval ate --json, and <name>/ate.png its plot
#   <name>/error.txt   the error, when tracking or evaluation failed
# and summary.md / summary.json over all sequences (rrslam-eval summary). A
# sequence that fails is listed as failed; the others still run, and eval-all
# exits with status 1 after writing the summary. Settings per
# sequence as in pipelines/vocab.mk (settings.yaml in the folder, or by TUM
# camera, or SETTINGS=...). Variables: DATA_ROOT, VOCAB, EVAL_ROOT
# (build/eval), EVAL_MODE (batch | realtime), EVAL_SEQUENCES (default: all).
EVAL_ROOT ?= $(BUILD_DIR)/eval
VOCAB ?=
EVAL_MODE ?= batch
EVAL_SEQUENCES ?= $(sort $(foreach g,$(wildcard $(DATA_ROOT)/*/groundtruth.txt),$(if \
  $(wildcard $(dir $(g))rgb.txt),$(notdir $(patsubst %/,%,$(dir $(g)))))))
eval_results := $(EVAL_ROOT)/$(if $(VOCAB),$(notdir $(VOCAB)),own)
eval_vocab = $(or $(VOCAB),$(PIPELINE_ROOT)/$(1)/voc.rrv)

.PHONY: eval-all eval-run
eval-all: build
	@test -n "$(EVAL_SEQUENCES)" || { echo "eval-all: no sequence with rgb.txt and groundtruth.txt under DATA_ROOT=$(DATA_ROOT)"; exit 66; }
	-@$(MAKE) --no-print-directory -k eval-run DATASET="$(EVAL_SEQUENCES)" SKIP_BUILD=1
	@for n in $(EVAL_SEQUENCES); do d=$(eval_results)/$$n; \
	  if [ ! -f $$d/ate.json ] && [ ! -f $$d/error.txt ]; then mkdir -p $$d && echo \
	    "no trajectory: extraction or vocabulary training failed (see make's output)" \
	    > $$d/error.txt; fi; done
	$(BIN)/rrslam-eval summary $(addprefix $(eval_results)/,$(EVAL_SEQUENCES)) \
	  --out $(eval_results)/summary.md
	$(BIN)/rrslam-eval summary $(addprefix $(eval_results)/,$(EVAL_SEQUENCES)) --json \
	  --out $(eval_results)/summary.json
	@cat $(eval_results)/summary.md
	@failed=0; for n in $(EVAL_SEQUENCES); do [ -f $(eval_results)/$$n/ate.json ] || \
	  failed=$$((failed + 1)); done; [ $$failed -eq 0 ] || \
	  { echo "eval-all: $$failed of $(words $(EVAL_SEQUENCES)) sequences failed"; exit 1; }

eval-run: $(foreach n,$(DATASET),$(eval_results)/$(n)/ate.json)

# Rules of one sequence, $(1). A failure leaves the tool's last line in error.txt.
define eval_sequence_rules
$(eval_results)/$(1)/track/run.json: $(PIPELINE_ROOT)/$(1)/features.h5 $(call eval_vocab,$(1)) \
    $(BIN)/rrslam-track
	@mkdir -p $(eval_results)/$(1) && rm -f $(eval_results)/$(1)/error.txt
	$(BIN)/rrslam-track --quiet --sequence $(call vocab_seq,$(1)) \
	  --settings $(call vocab_settings,$(1)) --vocab $(call eval_vocab,$(1)) \
	  --features $(PIPELINE_ROOT)/$(1)/features.h5 --mode $(EVAL_MODE) --out $$(@D) \
	  2> $(eval_results)/$(1)/track.log || { tail -n 1 $(eval_results)/$(1)/track.log \
	  > $(eval_results)/$(1)/error.txt; cat $(eval_results)/$(1)/track.log; exit 1; }

$(eval_results)/$(1)/ate.json: $(eval_results)/$(1)/track/run.json $(BIN)/rrslam-eval
	$(BIN)/rrslam-eval ate --gt $(call vocab_seq,$(1))/groundtruth.txt \
	  --est $(eval_results)/$(1)/track/CameraTrajectory.txt --json --out $$@ \
	  --plot $(eval_results)/$(1)/ate.png --plot-title "$(1)" \
	  || { echo "evaluation failed (see make's output)" > $(eval_results)/$(1)/error.txt; exit 1; }
endef
$(foreach n,$(DATASET),$(eval $(call eval_sequence_rules,$(n))))
