# `make bench`: every benchmark. Each bench/<name>/bench.mk defines a target
# bench-<name> and appends it to BENCH_TARGETS. Results are written to
# bench/results/<name>-<date>.{txt,json} with the machine description.
BENCH_TARGETS :=

# The command that reproduces a result, for its header: make $(1) with those of
# the variables $(2) that were given on the command line or in the environment.
bench_command = $(strip make $(1) $(foreach v,$(2),$(if $(filter command line environment,$(origin $(v))),$(v)="$($(v))")))
include bench/real_sequences.mk
-include $(wildcard bench/*/bench.mk)

.PHONY: bench
bench: $(BENCH_TARGETS)
	@echo "bench: results in bench/results/"
