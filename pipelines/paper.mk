# `make paper`: the seed paper's experiments on the data given, as one command:
# $(PAPER_ROOT)/report.md (default build/paper/report.md) with its tables as
# CSV and its figures as PNG beside it.
#
# Sequences: every folder under PAPER_DATA (DATA_ROOT when it exists, else the
# shared data, ../shared/data), one or two levels down, that holds rgb.txt and
# groundtruth.txt and lists at least EVAL_MIN_FRAMES frames, plus synthetic
# rooms rendered by rrslam-synth (PAPER_SYNTH trajectories, PAPER_SYNTH_FRAMES
# frames each) into $(PAPER_ROOT)/data/synth-<trajectory>. A sequence is named
# by its folder's name (7scenes-kitchen, fr1_xyz, synth-loop, ...); settings as
# in the vocab pipeline (settings.yaml in the folder, else by TUM camera).
#
# Cells, each a file target (a rerun redoes only what depends on a change;
# `make -j2 paper` runs independent cells in parallel):
#   pipeline/<seq>/       features.h5 and the sequence's own small vocabulary
#                         voc.rrv / voc.txt (pipelines/vocab.mk, VOCAB_K x VOCAB_L)
#   general/<seq>/        voc.rrv trained on the features of all the OTHER sequences
#                         together (the paper's general vocabulary, leave-one-out)
#   runs/<variant>/<seq>/ rrslam-track + rrslam-eval ate (pipelines/eval.mk's rules):
#                         own (own vocabulary), general, transfer (PAPER_TRANSFER's
#                         vocabulary on every other sequence)
#   ate-table.md/.csv, ate-bars.png   rrslam-eval compare over the runs (Table 3/4)
#   figures/<seq>/trajectory_*.png    the own-vocabulary trajectory against the
#                                     ground truth (rrslam-render trajectory)
#   vocab-load.csv        text and binary size and load time, 5 start-ups each
#                         (pipelines/paper/vocab_load.sh; Table 1/2), for an
#                         ORBvoc-shaped vocabulary (bench/vocab's generator; not
#                         with PAPER_ORBVOC=0) and the real DBoW2 vocabularies in
#                         PAPER_VOCABS ($(SHARED_DATA)/vocab)
#   startup/<seq>.csv     start-up on a saved map, text vs binary vocabulary
#                         (pipelines/paper/startup.sh)
#   report.md             every table, each number's command and input, and the
#                         paper's figures beside ours (pipelines/paper/report.sh)
# Runs are deterministic (batch mode), so each ATE cell is one run.
#
# Variables: PAPER_ROOT, PAPER_DATA, PAPER_SYNTH (loop shake), PAPER_SYNTH_FRAMES
# (300), PAPER_TRANSFER (the first real sequence), PAPER_STARTUP_RUNS (5),
# PAPER_VOCABS, PAPER_ORBVOC (1), PAPER_REFERENCE (a CSV of the seed paper's
# Table 3/4 figures, "sequence,variant,ate_rmse_cm", printed beside ours), and
# the vocab and eval pipelines' (VOCAB_K, VOCAB_L, EVAL_MODE, LAUNCHER, ...).
PAPER_ROOT ?= $(BUILD_DIR)/paper
PAPER_DATA ?= $(if $(wildcard $(DATA_ROOT)/.),$(DATA_ROOT),$(SHARED_DATA))
PAPER_SYNTH ?= loop shake
PAPER_SYNTH_FRAMES ?= 300
PAPER_STARTUP_RUNS ?= 5
PAPER_VOCABS ?= $(SHARED_DATA)/vocab
PAPER_ORBVOC ?= 1
PAPER_REFERENCE ?=
paper_mk_dir := $(dir $(lastword $(MAKEFILE_LIST)))

.PHONY: paper paper-cells

ifneq ($(filter paper paper-cells paper-report,$(MAKECMDGOALS)),)
# Real sequences (folders), long enough to evaluate.
paper_real_dirs := $(shell for f in $(PAPER_DATA)/*/groundtruth.txt $(PAPER_DATA)/*/*/groundtruth.txt; do \
  d=$${f%/groundtruth.txt}; [ -f "$$d/rgb.txt" ] || continue; \
  n=$$(grep -c -v -E '^[[:space:]]*(\#|$$)' "$$d/rgb.txt"); \
  [ "$$n" -ge $(EVAL_MIN_FRAMES) ] && echo "$$d"; done 2>/dev/null)
paper_synth_names := $(addprefix synth-,$(PAPER_SYNTH))
paper_real_names := $(notdir $(paper_real_dirs))
paper_names := $(paper_real_names) $(paper_synth_names)
$(foreach d,$(paper_real_dirs),$(eval paper_seq.$(notdir $(d)) := $(d)))
$(foreach n,$(paper_synth_names),$(eval paper_seq.$(n) := $(PAPER_ROOT)/data/$(n)))
ifneq ($(words $(paper_names)),$(words $(sort $(paper_names))))
  $(error paper: two sequences share a folder name: $(paper_names))
endif
ifeq ($(strip $(paper_names)),)
  $(error paper: no sequence: no folder with rgb.txt and groundtruth.txt under PAPER_DATA=$(PAPER_DATA) and PAPER_SYNTH is empty)
endif
PAPER_TRANSFER ?= $(firstword $(paper_real_names) $(paper_synth_names))
ifeq ($(filter $(PAPER_TRANSFER),$(paper_names)),)
  $(error paper: PAPER_TRANSFER=$(PAPER_TRANSFER) is not one of the sequences: $(paper_names))
endif
endif

# Settings of sequence $(1): a synthetic one's own (written with it, so it may
# not exist yet), a real one's as the vocab pipeline finds them
# (vocab_settings_in: its settings.yaml, else its TUM camera's).
paper_settings = $(if $(filter $(paper_synth_names),$(1)),$(paper_seq.$(1))/settings.yaml,$(call \
  vocab_settings_in,$(1),$(paper_seq.$(1))))
paper_features = $(PAPER_ROOT)/pipeline/$(1)/features.h5
paper_others = $(filter-out $(1),$(paper_names))
paper_variants := own general transfer
paper_transfer_names = $(filter-out $(PAPER_TRANSFER),$(paper_names))
paper_runs = $(foreach n,$(paper_names),$(PAPER_ROOT)/runs/own/$(n)/ate.json \
  $(if $(call paper_others,$(n)),$(PAPER_ROOT)/runs/general/$(n)/ate.json)) \
  $(foreach n,$(paper_transfer_names),$(PAPER_ROOT)/runs/transfer/$(n)/ate.json)

paper: $(if $(filter 1,$(SKIP_BUILD)),,tools)
	@echo "paper: $(words $(paper_names)) sequences ($(paper_names)); transfer vocabulary from $(PAPER_TRANSFER)"
	@$(MAKE) --no-print-directory -k paper-cells SKIP_BUILD=1; status=$$?; \
	  $(MAKE) --no-print-directory paper-report SKIP_BUILD=1 || exit 1; \
	  echo "paper: $(PAPER_ROOT)/report.md"; exit $$status

# Every cell; -k: a failed cell leaves error.txt and the others still run.
paper-cells: $(paper_runs) $(PAPER_ROOT)/vocab-load.csv \
  $(foreach n,$(paper_real_names),$(PAPER_ROOT)/startup/$(n).csv \
    $(PAPER_ROOT)/figures/$(n)/trajectory_top.png) \
  $(foreach n,$(paper_synth_names),$(PAPER_ROOT)/figures/$(n)/trajectory_top.png)

.PHONY: paper-report
paper-report: $(PAPER_ROOT)/report.md

# --- Synthetic sequences -----------------------------------------------------
define paper_synth_rules
$(PAPER_ROOT)/data/synth-$(1)/rgb.txt: $(BIN)/rrslam-synth
	@mkdir -p $$(dir $$(@D))
	$(LAUNCHER) $(BIN)/rrslam-synth --quiet --out $$(@D) --trajectory $(1) \
	  --frames $(PAPER_SYNTH_FRAMES) --seed 1
endef
$(foreach t,$(PAPER_SYNTH),$(eval $(call paper_synth_rules,$(t))))

# --- Features and own vocabularies (the vocab pipeline, one sequence each) ---
define paper_own_rules
$(call paper_features,$(1)) $(PAPER_ROOT)/pipeline/$(1)/voc.rrv $(PAPER_ROOT)/pipeline/$(1)/voc.txt &: \
    $(paper_seq.$(1))/rgb.txt $(vocab_tools)
	$$(MAKE) --no-print-directory vocab DATASET=$(1) DATA_ROOT=$(patsubst %/,%,$(dir $(paper_seq.$(1)))) \
	  PIPELINE_ROOT=$(PAPER_ROOT)/pipeline SETTINGS=$(call paper_settings,$(1)) SKIP_BUILD=1
endef
$(foreach n,$(paper_names),$(eval $(call paper_own_rules,$(n))))

# --- General vocabularies: trained on all the other sequences together -------
define paper_general_rules
$(PAPER_ROOT)/general/$(1)/tree.h5: $(foreach o,$(call paper_others,$(1)),$(call paper_features,$(o))) \
    $(BIN)/rrslam-cluster
	@mkdir -p $$(@D)
	$(LAUNCHER) $(BIN)/rrslam-cluster --quiet --features $$(filter %.h5,$$^) --k $(VOCAB_K) \
	  --levels $(VOCAB_L) --seed $(VOCAB_SEED) --stride $(VOCAB_STRIDE) \
	  --max-descriptors $(VOCAB_MAX_DESCRIPTORS) --threads $(VOCAB_THREADS) --out $$@

$(PAPER_ROOT)/general/$(1)/voc.rrv: $(PAPER_ROOT)/general/$(1)/tree.h5 $(BIN)/rrslam-vocab
	$(LAUNCHER) $(BIN)/rrslam-vocab --quiet build --tree $$< \
	  --features $(foreach o,$(call paper_others,$(1)),$(call paper_features,$(o))) \
	  --weighting $(VOCAB_WEIGHTING) --scoring $(VOCAB_SCORING) --stride $(VOCAB_STRIDE) \
	  --threads $(VOCAB_THREADS) --out $$@
endef
$(foreach n,$(paper_names),$(if $(call paper_others,$(n)),$(eval $(call paper_general_rules,$(n)))))

# --- Track and evaluate: pipelines/eval.mk's rules, one cell per run ---------
paper_run = $(eval $(call eval_run_rules,$(PAPER_ROOT)/runs/$(1)/$(2),$(paper_seq.$(2)),$(call \
  paper_settings,$(2)),$(3),$(call paper_features,$(2))))
$(foreach n,$(paper_names),$(call paper_run,own,$(n),$(PAPER_ROOT)/pipeline/$(n)/voc.rrv))
$(foreach n,$(paper_names),$(if $(call paper_others,$(n)),$(call \
  paper_run,general,$(n),$(PAPER_ROOT)/general/$(n)/voc.rrv)))
$(foreach n,$(paper_transfer_names),$(call paper_run,transfer,$(n),$(PAPER_ROOT)/pipeline/$(PAPER_TRANSFER)/voc.rrv))

# --- Tables and figures ------------------------------------------------------
$(PAPER_ROOT)/ate-table.md $(PAPER_ROOT)/ate-table.csv $(PAPER_ROOT)/ate-bars.png &: \
    $(wildcard $(paper_runs)) $(BIN)/rrslam-eval
	$(BIN)/rrslam-eval compare $(foreach v,$(paper_variants),$(if $(wildcard $(PAPER_ROOT)/runs/$(v)),--column \
	  $(v)=$(PAPER_ROOT)/runs/$(v))) \
	  $(if $(wildcard $(PAPER_ROOT)/runs/general),--baseline general) --title "ATE RMSE per sequence and vocabulary" \
	  --out $(PAPER_ROOT)/ate-table.md --csv $(PAPER_ROOT)/ate-table.csv --plot $(PAPER_ROOT)/ate-bars.png

define paper_figure_rules
$(PAPER_ROOT)/figures/$(1)/trajectory_top.png: $(PAPER_ROOT)/runs/own/$(1)/ate.json $(BIN)/rrslam-render
	@mkdir -p $$(dir $$(@D))
	$(LAUNCHER) $(BIN)/rrslam-render --quiet trajectory --gt $(paper_seq.$(1))/groundtruth.txt \
	  --est $(PAPER_ROOT)/runs/own/$(1)/track/CameraTrajectory.txt --title "$(1)" --out $$(@D)
endef
$(foreach n,$(paper_names),$(eval $(call paper_figure_rules,$(n))))

$(PAPER_ROOT)/vocab-load.csv: $(paper_mk_dir)paper/vocab_load.sh $(BIN)/rrslam-vocab \
    $(BIN)/vocab_bench_generate $(BIN)/vocab_bench $(wildcard $(PAPER_VOCABS)/*)
	@mkdir -p $(PAPER_ROOT)/vocab
	$(LAUNCHER) $(paper_mk_dir)paper/vocab_load.sh $(BIN) $(PAPER_VOCABS) $(PAPER_ROOT)/vocab \
	  $(PAPER_STARTUP_RUNS) $(PAPER_ORBVOC) $@

define paper_startup_rules
$(PAPER_ROOT)/startup/$(1).csv: $(paper_mk_dir)paper/startup.sh $(BIN)/rrslam-track \
    $(PAPER_ROOT)/pipeline/$(1)/voc.rrv $(PAPER_ROOT)/pipeline/$(1)/voc.txt
	@mkdir -p $$(@D)
	$(LAUNCHER) $(paper_mk_dir)paper/startup.sh $(BIN) $(paper_seq.$(1)) $(call paper_settings,$(1)) \
	  $(PAPER_ROOT)/pipeline/$(1) $(PAPER_ROOT)/startup/$(1) $(PAPER_STARTUP_RUNS) $$@
endef
$(foreach n,$(paper_real_names),$(eval $(call paper_startup_rules,$(n))))

$(PAPER_ROOT)/report.md: $(paper_mk_dir)paper/report.sh $(PAPER_ROOT)/ate-table.md \
    $(wildcard $(PAPER_ROOT)/vocab-load.csv $(PAPER_ROOT)/startup/*.csv \
      $(PAPER_ROOT)/figures/*/trajectory_top.png) $(PAPER_REFERENCE)
	$(paper_mk_dir)paper/report.sh $(BIN) $(PAPER_ROOT) "$(paper_names)" "$(PAPER_TRANSFER)" \
	  "$(VOCAB_K)" "$(VOCAB_L)" "$(PAPER_REFERENCE)" > $@.new || { rm -f $@.new; exit 1; }
	mv -f $@.new $@
