#!/usr/bin/env bash
# Runs the map reader fuzz target for a short, reproducible time.
# Usage: run_fuzzer.sh FUZZER_DIR SEED_CORPUS WORK_DIR SECONDS
# The seed corpus holds small map files (regenerate them with
#   RRSLAM_MAPSTORE_WRITE_SEEDS=stages/mapstore/fuzz/corpus \
#     build/tests/mapstore_map_file --gtest_filter=MapFile.WriteFuzzSeeds
# after a format change). Exit 77 (skipped) when the fuzzer was not built (no
# clang with libFuzzer); non-zero on any finding.
set -euo pipefail
fuzzer_dir=$1 seeds=$2 work=$3 seconds=$4

if [[ ! -x "$fuzzer_dir/map_fuzzer" ]]; then
  echo "run_fuzzer: map_fuzzer not built (clang++ with libFuzzer not found): skipped"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
cp "$seeds"/* "$work/corpus/"

echo "run_fuzzer: map_fuzzer for ${seconds} s"
# Fixed seed; new inputs go to the work copy of the corpus, findings to artifacts/.
if ! "$fuzzer_dir/map_fuzzer" -seed=1 -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$work/artifacts/map-" \
    "$work/corpus" 2>"$work/map.log"; then
  echo "run_fuzzer: map_fuzzer found a problem:"
  tail -n 60 "$work/map.log"
  exit 1
fi
grep -E "stat::number_of_executed_units|Done" "$work/map.log" | tail -n 2 || true
