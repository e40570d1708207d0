# `make bench`: every benchmark. Each bench/<name>/bench.mk defines a target
# bench-<name> and appends it to BENCH_TARGETS. Results are written to
# bench/results/<name>-<date>.{txt,json} with the machine description.
BENCH_TARGETS :=
include bench/real_sequences.mk
-include $(wildcard bench/*/bench.mk)

.PHONY: bench
bench: $(BENCH_TARGETS)
	@echo "bench: results in bench/results/"
