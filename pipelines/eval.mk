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
#   <name>/error.txt   the error (the tool's message), when tracking or evaluation
#                      failed; track.log and ate.log hold the tools' logs
#   <name>/skipped.txt why the sequence was not run: its rgb.txt lists fewer
#                      than EVAL_MIN_FRAMES frames (checked before any tool runs)
# and summary.md / summary.json over all sequences (rrslam-eval summary), with
# ORB-SLAM2's published ATE where EVAL_REFERENCE has one. A sequence that fails
# is listed as failed; the others still run, and eval-all exits with status 1
# after writing the summary. A skipped sequence is listed as skipped and does
# not count as a failure. Settings per sequence as in pipelines/vocab.mk
# (settings.yaml in the folder, or by TUM camera, or SETTINGS=...).
# The executables are brought up to date first (`make tools`); SKIP_BUILD=1 uses those in
# $(BIN) as they are.
# Variables: DATA_ROOT, VOCAB, EVAL_ROOT (build/eval), EVAL_MODE (batch |
# realtime), EVAL_SEQUENCES (default: all), EVAL_MIN_FRAMES (30: one second at
# TUM's 30 Hz), EVAL_REFERENCE (pipelines/orbslam2_ate.csv; empty: no reference
# column), EVAL_REFERENCE_NAME (ORB-SLAM2), SKIP_BUILD (0), LAUNCHER (empty; a
# prefix of each tool's command, e.g. "srun -c2": see pipelines/vocab.mk).
eval_mk_dir := $(dir $(lastword $(MAKEFILE_LIST)))
EVAL_ROOT ?= $(BUILD_DIR)/eval
VOCAB ?=
EVAL_MODE ?= batch
EVAL_SEQUENCES ?= $(sort $(foreach g,$(wildcard $(DATA_ROOT)/*/groundtruth.txt),$(if \
  $(wildcard $(dir $(g))rgb.txt),$(notdir $(patsubst %/,%,$(dir $(g)))))))
# Shorter sequences are not tracked (0: none is skipped): on a few frames the
# vocabulary is trained on almost nothing and the rigid alignment of ATE absorbs
# most of the error, so the figure says nothing (and fewer than 3 poses cannot
# be aligned at all).
EVAL_MIN_FRAMES ?= 30
EVAL_REFERENCE ?= $(eval_mk_dir)orbslam2_ate.csv
EVAL_REFERENCE_NAME ?= ORB-SLAM2
eval_results := $(EVAL_ROOT)/$(if $(VOCAB),$(notdir $(VOCAB)),own)
eval_vocab = $(or $(VOCAB),$(PIPELINE_ROOT)/$(1)/voc.rrv)
eval_summary_args = $(addprefix $(eval_results)/,$(EVAL_SEQUENCES)) $(if $(EVAL_REFERENCE), \
  --reference $(EVAL_REFERENCE) --reference-name "$(EVAL_REFERENCE_NAME)")

.PHONY: eval-all eval-run
# With SKIP_BUILD=1 nothing is built (as in the vocab pipeline): the tools must
# exist. A sequence whose rgb.txt lists fewer than EVAL_MIN_FRAMES frames gets
# skipped.txt (any earlier one is removed) and is not run; the others are.
eval-all: $(if $(filter 1,$(SKIP_BUILD)),,tools)
	@test -n "$(EVAL_SEQUENCES)" || { echo "eval-all: no sequence with rgb.txt and groundtruth.txt under DATA_ROOT=$(DATA_ROOT)"; exit 66; }
	@[[ "$(EVAL_MIN_FRAMES)" =~ ^[0-9]+$$ ]] || { echo "eval-all: EVAL_MIN_FRAMES=$(EVAL_MIN_FRAMES); must be a whole number of frames"; exit 64; }
	$(if $(filter 1,$(SKIP_BUILD)),@for t in $(BIN)/rrslam-track $(BIN)/rrslam-eval; do test -x $$t || \
	  { echo "eval-all: $$t is missing (SKIP_BUILD=1 uses existing executables)"; exit 1; }; done)
	-@run=; for s in $(foreach n,$(EVAL_SEQUENCES),$(n):$(call vocab_seq,$(n))); do \
	  n=$${s%%:*}; seq=$${s#*:}; d=$(eval_results)/$$n; rm -f $$d/skipped.txt; frames=; \
	  if [ -n "$$seq" ]; then frames=$$(grep -c -v -E '^[[:space:]]*(#|$$)' $$seq/rgb.txt); fi; \
	  if [ -n "$$frames" ] && [ "$$frames" -lt $(EVAL_MIN_FRAMES) ]; then mkdir -p $$d && echo \
	    "too short ($$frames frames < EVAL_MIN_FRAMES = $(EVAL_MIN_FRAMES))" > $$d/skipped.txt && \
	    echo "eval-all: $$n skipped: $$(cat $$d/skipped.txt)"; else run="$$run $$n"; fi; done; \
	  [ -z "$$run" ] || $(MAKE) --no-print-directory -k eval-run DATASET="$$run" SKIP_BUILD=1
	@for n in $(EVAL_SEQUENCES); do d=$(eval_results)/$$n; \
	  if [ ! -f $$d/skipped.txt ] && [ ! -f $$d/ate.json ] && [ ! -f $$d/error.txt ]; then \
	    mkdir -p $$d && echo "no trajectory: extraction or vocabulary training failed (see make's output)" \
	    > $$d/error.txt; fi; done
	$(BIN)/rrslam-eval summary $(eval_summary_args) --out $(eval_results)/summary.md
	$(BIN)/rrslam-eval summary $(eval_summary_args) --json --out $(eval_results)/summary.json
	@cat $(eval_results)/summary.md
	@failed=0; for n in $(EVAL_SEQUENCES); do [ -f $(eval_results)/$$n/ate.json ] || \
	  [ -f $(eval_results)/$$n/skipped.txt ] || failed=$$((failed + 1)); done; [ $$failed -eq 0 ] || \
	  { echo "eval-all: $$failed of $(words $(EVAL_SEQUENCES)) sequences failed"; exit 1; }

eval-run: $(foreach n,$(DATASET),$(eval_results)/$(n)/ate.json)

# Rules of one run, tracked and evaluated into folder $(1): sequence folder
# $(2), settings $(3), vocabulary $(4), cached features $(5). A failure leaves
# the tool's last line (its error message) in $(1)/error.txt; its whole log is
# in track.log or ate.log. The paper pipeline (pipelines/paper.mk) uses the
# same rules for its cells. $(LAUNCHER) prefixes each tool's command (e.g.
# LAUNCHER="srun -c2" runs it as a Slurm job).
define eval_run_rules
$(1)/track/run.json: $(5) $(4) $(BIN)/rrslam-track
	@mkdir -p $(1) && rm -f $(1)/error.txt
	$(LAUNCHER) $(BIN)/rrslam-track --quiet --sequence $(2) --settings $(3) --vocab $(4) \
	  --features $(5) --mode $(EVAL_MODE) --out $$(@D) 2> $(1)/track.log \
	  || { tail -n 1 $(1)/track.log > $(1)/error.txt; cat $(1)/track.log; exit 1; }

$(1)/ate.json: $(1)/track/run.json $(BIN)/rrslam-eval
	@rm -f $(1)/error.txt
	$(LAUNCHER) $(BIN)/rrslam-eval ate --gt $(2)/groundtruth.txt \
	  --est $(1)/track/CameraTrajectory.txt --json --out $$@ \
	  --plot $(1)/ate.png --plot-title "$(notdir $(1))" 2> $(1)/ate.log \
	  || { tail -n 1 $(1)/ate.log > $(1)/error.txt; cat $(1)/ate.log; exit 1; }
endef
$(foreach n,$(DATASET),$(eval $(call eval_run_rules,$(eval_results)/$(n),$(call vocab_seq,$(n)),$(call \
  vocab_settings,$(n)),$(call eval_vocab,$(n)),$(PIPELINE_ROOT)/$(n)/features.h5)))
