#!/usr/bin/env bash
# Runs one libFuzzer target for a fixed time from its seed corpus: the CTest
# fuzz smoke tests (<module>/fuzz_<name>, RRSLAM_FUZZ_SECONDS each) and
# `make fuzz-run` (bench/fuzz/run.sh) both go through here.
#
# Usage: run_fuzzer.sh FUZZER SEED_DIR WORK_DIR SECONDS
#   FUZZER    the fuzz target executable (build/fuzz/<name>)
#   SEED_DIR  its committed seed corpus (read-only; copied to WORK_DIR/corpus)
#   WORK_DIR  recreated: corpus/ (seeds plus the inputs the run adds),
#             artifacts/ (findings: crash-*, leak-*, oom-*, timeout-*),
#             fuzz.log (libFuzzer's output) and summary.txt (below)
#   SECONDS   run time (-max_total_time)
# Seed 1, 10 s per input at most, 2 GB of RSS at most. summary.txt holds one
# line of key=value pairs: name seconds (as run: shorter when a finding
# stopped it) execs exec_per_s cov ft corpus corpus_kb findings (cov and ft
# as libFuzzer's last status line prints them).
# Exit 0 when the run ends without a finding, 1 on a finding (the log's tail
# is printed), 77 (skipped) when FUZZER was not built (no clang++ with
# libFuzzer, see cmake/RrslamFuzz.cmake).
set -euo pipefail
if [[ $# -ne 4 ]]; then
  echo "usage: run_fuzzer.sh FUZZER SEED_DIR WORK_DIR SECONDS" >&2
  exit 64
fi
fuzzer=$1 seeds=$2 work=$3 seconds=$4
name=$(basename "$fuzzer")

if [[ ! -x $fuzzer ]]; then
  echo "run_fuzzer: $name not built (clang++ with libFuzzer not found): skipped"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
cp -R "$seeds"/. "$work/corpus/"

echo "run_fuzzer: $name for ${seconds} s"
status=0
start=$(date +%s)
"$fuzzer" -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/corpus" \
  >"$work/fuzz.log" 2>&1 || status=$?
elapsed=$(($(date +%s) - start))

# The last status line ("#123 REDUCE cov: 456 ft: 789 corp: 12/3456b ...").
last=$(grep -E '^#[0-9]+[[:space:]].* cov: ' "$work/fuzz.log" | tail -n 1 || true)
field() { sed -n "s/.* $1: \([0-9]*\).*/\1/p" <<<"$last"; }
stat() { sed -n "s/^stat::$1: *\([0-9]*\).*/\1/p" "$work/fuzz.log" | tail -n 1; }
findings=$(find "$work/artifacts" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'oom-*' \
  -o -name 'timeout-*' \) | wc -l)
corpus_files=$(find "$work/corpus" -type f | wc -l)
corpus_kb=$(du -sk "$work/corpus" | cut -f1)
summary="name=$name seconds=$elapsed execs=$(stat number_of_executed_units)"
summary+=" exec_per_s=$(stat average_exec_per_sec) cov=$(field cov) ft=$(field ft)"
summary+=" corpus=$corpus_files corpus_kb=$corpus_kb findings=$findings"
echo "$summary" >"$work/summary.txt"
echo "run_fuzzer: $summary"

if [[ $status -ne 0 || $findings -ne 0 ]]; then
  echo "run_fuzzer: $name found a problem (exit $status; inputs in $work/artifacts/):"
  tail -n 60 "$work/fuzz.log"
  exit 1
fi
