# Real sequences of the benchmarks (bench-track, bench-map), by name, so that
# any RGB-D sequence with ground truth can be measured by naming it:
#   make bench-map BENCH_MAP_REAL="7scenes-kitchen fr1_xyz fr2_desk"
# Sequence NAME is the folder
#   bench_real_dir.NAME=<folder> when given (e.g. on the command line), else
#   the first of SHARED_DATA/NAME, SHARED_DATA/tum/NAME and TUM's full name
#   (fr2_desk: rgbd_dataset_freiburg2_desk) under SHARED_DATA or SHARED_DATA/tum
#   that holds rgb.txt;
# its settings are
#   bench_real_settings.NAME=<yaml> when given, else the folder's settings.yaml,
#   else by the camera its name gives: fr1_... -> SHARED_DATA/settings/tum1.yaml
#   (fr2 tum2, fr3 tum3), 7scenes-... -> 7scenes.yaml. TUM's names and
#   cameras are pipelines/vocab.mk's (vocab_tum_name, vocab_settings_in).
# The folder's own name must be NAME or TUM's full name: the vocabulary
# pipeline that trains the sequence's vocabulary finds it by name. A name with
# no folder is reported as skipped by each bench (bench_real_missing).
bench_real_dir = $(or $(bench_real_dir.$(1)),$(patsubst %/rgb.txt,%,$(firstword $(wildcard \
  $(SHARED_DATA)/$(1)/rgb.txt $(SHARED_DATA)/tum/$(1)/rgb.txt \
  $(SHARED_DATA)/$(call vocab_tum_name,$(1))/rgb.txt \
  $(SHARED_DATA)/tum/$(call vocab_tum_name,$(1))/rgb.txt))))
bench_real_settings = $(or $(bench_real_settings.$(1)),$(call vocab_settings_in,$(1),$(call \
  bench_real_dir,$(1))),$(if $(filter 7scenes-%,$(1)),$(SHARED_DATA)/settings/7scenes.yaml))
# Frames listed in the sequence's rgb.txt (comments and blank lines aside).
bench_real_frames = $(shell grep -c -v -E '^[[:space:]]*(#|$$)' $(call bench_real_dir,$(1))/rgb.txt)
# The names of $(1) (a list) with a folder, and a shell command that reports
# the others (bench $(2)) as skipped.
bench_real_present = $(foreach n,$(1),$(if $(call bench_real_dir,$(n)),$(n)))
bench_real_missing = $(foreach n,$(filter-out $(call bench_real_present,$(1)),$(1)),echo \
  "$(2): $(n) skipped: no folder with rgb.txt as $(SHARED_DATA)/$(n), \
  $(SHARED_DATA)/tum/$(n) or TUM's full name (or give bench_real_dir.$(n)=<folder>)" >&2;) true
# The kitchen's folder has a settings.yaml equal to this one; the benches have
# always named this one, and their cached features record the path.
bench_real_settings.7scenes-kitchen := $(SHARED_DATA)/settings/7scenes.yaml

# `make bench-real-sequences BENCH_REAL="NAME ..."`: what the benches take for
# each name, a line each: NAME, folder, settings, frames in rgb.txt ("-" where
# there is none).
BENCH_REAL ?=
.PHONY: bench-real-sequences
bench-real-sequences:
	@$(foreach n,$(BENCH_REAL),echo "$(n) $(or $(call bench_real_dir,$(n)),-) $(or \
	  $(call bench_real_settings,$(n)),-) $(if $(call bench_real_dir,$(n)),$(call \
	  bench_real_frames,$(n)),-)";) true
