#!/usr/bin/env bash
# Runs the vocabulary fuzz targets for a short, reproducible time each.
# Usage: run_fuzzers.sh FUZZER_DIR RRSLAM_VOCAB SEED_CORPUS WORK_DIR SECONDS
# The seed corpus holds small DBoW2 text vocabularies; their binary forms are
# made with `rrslam-vocab convert`. Exit 77 (skipped) when the fuzzers were
# not built (no clang with libFuzzer); non-zero on any finding.
set -euo pipefail
fuzzer_dir=$1 vocab=$2 seeds=$3 work=$4 seconds=$5

if [[ ! -x "$fuzzer_dir/vocab_text_fuzzer" || ! -x "$fuzzer_dir/vocab_binary_fuzzer" ]]; then
  echo "run_fuzzers: fuzz targets not built (clang++ with libFuzzer not found): skipped"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work/text" "$work/binary" "$work/artifacts"
cp "$seeds"/*.txt "$work/text/"
for f in "$seeds"/*.txt; do
  "$vocab" --quiet convert "$f" "$work/binary/$(basename "$f" .txt).rrv"
done

status=0
for target in text binary; do
  echo "run_fuzzers: vocab_${target}_fuzzer for ${seconds} s"
  # Fixed seed; new inputs go to the work copy of the corpus, findings to artifacts/.
  if ! "$fuzzer_dir/vocab_${target}_fuzzer" -seed=1 -max_total_time="$seconds" -timeout=10 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$work/artifacts/${target}-" \
      "$work/$target" 2>"$work/${target}.log"; then
    echo "run_fuzzers: vocab_${target}_fuzzer found a problem:"
    tail -n 60 "$work/${target}.log"
    status=1
  else
    grep -E "stat::number_of_executed_units|Done" "$work/${target}.log" | tail -n 2 || true
  fi
done
exit $status
