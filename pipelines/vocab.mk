# `make vocab DATASET=<name>`: trains a vocabulary on one RGB-D sequence:
#   extract (rrslam-extract) -> cluster (rrslam-cluster) -> build (rrslam-vocab)
# and leaves under $(PIPELINE_ROOT)/<name>/ (default build/pipeline/<name>/):
#   features.h5   ORB features of every EXTRACT_STRIDE-th frame
#   tree.h5       hierarchical k-means tree (k = VOCAB_K, depth VOCAB_L)
#   voc.rrv       the vocabulary, binary (loads in milliseconds)
#   voc.txt       the same vocabulary as DBoW2 text (ORB-SLAM2's ORBvoc.txt format)
#
# The sequence is DATA_ROOT/<name> (default data/), or the TUM folder of a short
# name: DATASET=fr1_room finds DATA_ROOT/rgbd_dataset_freiburg1_room. Settings:
# SETTINGS=<yaml> if given, else the sequence's settings.yaml, else by TUM
# camera (fr1 -> $(SHARED_DATA)/settings/tum1.yaml, fr2 -> tum2, fr3 -> tum3).
# Several names (DATASET="fr1_room fr2_desk") train one vocabulary each, in
# parallel with make -j.
#
# Each step is a file target depending on its inputs, on its executable and on
# a .params file that changes only when the step's variables change, so a rerun
# redoes only stale steps. .DELETE_ON_ERROR (top-level Makefile) and the atomic
# writers of the tools leave no partial output. The executables are brought up
# to date with one `cmake --build` first; SKIP_BUILD=1 uses $(BIN)/rrslam-* as
# they are (tests and scripts that built them already).
#
# Variables: VOCAB_K (10), VOCAB_L (6), VOCAB_STRIDE (1: every N-th extracted
# frame is a training image), VOCAB_SEED (0), VOCAB_MAX_DESCRIPTORS (0 = all),
# VOCAB_WEIGHTING (tf-idf), VOCAB_SCORING (l1), VOCAB_THREADS (0 = all cores),
# EXTRACT_STRIDE (1), EXTRACT_MAX_FRAMES (0 = all), SETTINGS, PIPELINE_ROOT,
# SKIP_BUILD (0), LAUNCHER (empty: a command that prefixes each tool's run, e.g.
# "srun -c2" for a Slurm cluster; PIPELINE_ROOT must then be on a file system
# every node shares).

VOCAB_K ?= 10
VOCAB_L ?= 6
VOCAB_STRIDE ?= 1
VOCAB_SEED ?= 0
VOCAB_MAX_DESCRIPTORS ?= 0
VOCAB_WEIGHTING ?= tf-idf
VOCAB_SCORING ?= l1
VOCAB_THREADS ?= 0
EXTRACT_STRIDE ?= 1
EXTRACT_MAX_FRAMES ?= 0
SETTINGS ?=
PIPELINE_ROOT ?= $(BUILD_DIR)/pipeline
SKIP_BUILD ?= 0

vocab_tools := $(BIN)/rrslam-extract $(BIN)/rrslam-cluster $(BIN)/rrslam-vocab

# TUM's folder name of dataset $(1): fr2_desk -> rgbd_dataset_freiburg2_desk.
vocab_tum_name = rgbd_dataset_freiburg$(patsubst fr%,%,$(1))
# Sequence folder of dataset $(1): DATA_ROOT/$(1), or the TUM folder name.
vocab_seq = $(patsubst %/rgb.txt,%,$(firstword $(wildcard \
  $(DATA_ROOT)/$(1)/rgb.txt $(DATA_ROOT)/$(call vocab_tum_name,$(1))/rgb.txt)))
# TUM camera (1, 2 or 3) of dataset $(1), from fr<N>_... or ...freiburg<N>_...
vocab_camera = $(firstword $(foreach c,1 2 3,$(if \
  $(filter fr$(c)_%,$(1))$(findstring freiburg$(c)_,$(1)),$(c))))
vocab_settings = $(or $(SETTINGS),$(call vocab_settings_in,$(1),$(call vocab_seq,$(1))))
# Settings of dataset $(1) in folder $(2): the folder's settings.yaml, else the
# shared settings of the TUM camera its name gives (also bench/real_sequences.mk).
vocab_settings_in = $(or $(wildcard $(2)/settings.yaml),$(if \
  $(call vocab_camera,$(1)),$(SHARED_DATA)/settings/tum$(call vocab_camera,$(1)).yaml))

vocab_no_settings = vocab: no settings for '$(1)': give SETTINGS=<yaml> (no settings.yaml in \
  the sequence, no TUM camera in the name)

# `make vocab-sequence DATASET=<names>`: prints the sequence folder of each
# name, one a line (an empty line when there is none), so that scripts find
# it as `vocab` does (scripts/regenerate-vocab.sh fingerprints its images).
.PHONY: vocab-sequence
vocab-sequence:
	@$(foreach d,$(DATASET),echo '$(call vocab_seq,$(d))';)

.PHONY: vocab
vocab: $(foreach d,$(DATASET),$(PIPELINE_ROOT)/$(d)/voc.rrv $(PIPELINE_ROOT)/$(d)/voc.txt)
	@$(foreach d,$(DATASET),echo "vocab: $(PIPELINE_ROOT)/$(d)/voc.rrv and voc.txt";)

ifneq ($(filter vocab,$(MAKECMDGOALS)),)
  ifeq ($(strip $(DATASET)),)
    $(error vocab: set DATASET=<name>, a sequence folder under DATA_ROOT=$(DATA_ROOT))
  endif
  $(foreach d,$(DATASET),$(if $(call vocab_seq,$(d)),,$(error vocab: no sequence '$(d)' \
    under DATA_ROOT=$(DATA_ROOT) (looked for $(DATA_ROOT)/$(d)/rgb.txt and \
    $(DATA_ROOT)/$(call vocab_tum_name,$(d))/rgb.txt))))
  $(foreach d,$(DATASET),$(if $(call vocab_settings,$(d)),,$(error $(call vocab_no_settings,$(d)))))
endif

# Rewrites $@ only when its content changes, so that dependents rebuild only
# then (the recipe runs every time through vocab-force).
define vocab_write_params
@mkdir -p $(@D)
@printf '%s\n' '$(1)' > $@.new; if cmp -s $@.new $@; then rm -f $@.new; else mv -f $@.new $@; fi
endef

# Rules of one dataset, $(1).
define vocab_dataset_rules
$(PIPELINE_ROOT)/$(1)/extract.params: vocab-force
	$$(call vocab_write_params,sequence=$(call vocab_seq,$(1)) settings=$(call vocab_settings,$(1)) stride=$(EXTRACT_STRIDE) max_frames=$(EXTRACT_MAX_FRAMES))

$(PIPELINE_ROOT)/$(1)/cluster.params: vocab-force
	$$(call vocab_write_params,k=$(VOCAB_K) levels=$(VOCAB_L) stride=$(VOCAB_STRIDE) seed=$(VOCAB_SEED) max_descriptors=$(VOCAB_MAX_DESCRIPTORS))

$(PIPELINE_ROOT)/$(1)/build.params: vocab-force
	$$(call vocab_write_params,weighting=$(VOCAB_WEIGHTING) scoring=$(VOCAB_SCORING) stride=$(VOCAB_STRIDE))

$(PIPELINE_ROOT)/$(1)/features.h5: $(PIPELINE_ROOT)/$(1)/extract.params $(BIN)/rrslam-extract \
    $(wildcard $(call vocab_seq,$(1))/rgb.txt $(call vocab_seq,$(1))/depth.txt \
               $(call vocab_seq,$(1))/associations.txt) $(call vocab_settings,$(1))
	$(if $(call vocab_settings,$(1)),,@echo "$(call vocab_no_settings,$(1))" >&2; exit 66)
	$(LAUNCHER) $(BIN)/rrslam-extract --sequence $(call vocab_seq,$(1)) --settings $(call vocab_settings,$(1)) \
	  --stride $(EXTRACT_STRIDE) --max-frames $(EXTRACT_MAX_FRAMES) --out $$@

$(PIPELINE_ROOT)/$(1)/tree.h5: $(PIPELINE_ROOT)/$(1)/features.h5 $(PIPELINE_ROOT)/$(1)/cluster.params \
    $(BIN)/rrslam-cluster
	$(LAUNCHER) $(BIN)/rrslam-cluster --features $$< --k $(VOCAB_K) --levels $(VOCAB_L) --seed $(VOCAB_SEED) \
	  --stride $(VOCAB_STRIDE) --max-descriptors $(VOCAB_MAX_DESCRIPTORS) --threads $(VOCAB_THREADS) \
	  --out $$@

$(PIPELINE_ROOT)/$(1)/voc.rrv: $(PIPELINE_ROOT)/$(1)/tree.h5 $(PIPELINE_ROOT)/$(1)/features.h5 \
    $(PIPELINE_ROOT)/$(1)/build.params $(BIN)/rrslam-vocab
	$(LAUNCHER) $(BIN)/rrslam-vocab build --tree $$< --features $(PIPELINE_ROOT)/$(1)/features.h5 \
	  --weighting $(VOCAB_WEIGHTING) --scoring $(VOCAB_SCORING) --stride $(VOCAB_STRIDE) \
	  --threads $(VOCAB_THREADS) --out $$@

$(PIPELINE_ROOT)/$(1)/voc.txt: $(PIPELINE_ROOT)/$(1)/voc.rrv $(BIN)/rrslam-vocab
	$(LAUNCHER) $(BIN)/rrslam-vocab convert $$< $$@
endef

$(foreach d,$(DATASET),$(eval $(call vocab_dataset_rules,$(d))))

# The executables: one cmake --build brings all three up to date (make then
# sees a new mtime only when one was relinked), or, with SKIP_BUILD=1, they
# are taken as they are.
ifeq ($(SKIP_BUILD),1)
$(vocab_tools):
	@test -x $@ || { echo "vocab: $@ is missing (SKIP_BUILD=1 uses existing executables)"; exit 1; }
else
$(vocab_tools) &: vocab-force | $(BUILD_DIR)/CMakeCache.txt
	cmake --build $(BUILD_DIR) -j $(JOBS) --target rrslam-extract rrslam-cluster rrslam-vocab
endif

vocab-force: ;
