#!/usr/bin/env bash
# `make fuzz-run`: runs every libFuzzer target for a set time and records the
# figures. Usage: bench/fuzz/run.sh FUZZ_DIR SECONDS RESULTS_DIR [NAME...]
#   FUZZ_DIR     a build tree's fuzz/ folder: the targets, and targets.txt
#                (name and seed corpus of each, written by CMake's
#                rrslam_add_fuzz_test)
#   SECONDS      run time of each target
#   RESULTS_DIR  receives fuzz-<date>.txt (fuzz-<date>-<SECONDS>s.txt for runs
#                shorter than 600 s, and -<name> appended for each NAME given):
#                the machine line, the command, and
#                per target the seconds, executions, executions per second,
#                coverage (libFuzzer's cov: edges and ft: features), corpus
#                size and findings
#   NAME...      only these targets (default: every target in targets.txt)
# Two targets run at a time (2 cores), each through cmake/run_fuzzer.sh (seed
# 1, 10 s per input at most, 2 GB RSS at most) in FUZZ_DIR/work/<name>/,
# whose corpus/ keeps the inputs the run added and artifacts/ its findings.
# Exit 1 when a target has a finding, 77 when no target was built.
set -euo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: bench/fuzz/run.sh FUZZ_DIR SECONDS RESULTS_DIR [NAME...]" >&2
  exit 64
fi
fuzz_dir=$1 seconds=$2 results=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
runner=$here/../../cmake/run_fuzzer.sh
manifest=$fuzz_dir/targets.txt
if [[ ! -s $manifest ]]; then
  echo "fuzz-run: $manifest missing: configure the build tree first" >&2
  exit 66
fi
mkdir -p "$results"
date=$(date -u +%Y-%m-%d)
suffix=$([[ $seconds -lt 600 ]] && echo "-${seconds}s" || true)
for name in "$@"; do suffix+="-${name%_fuzzer}"; done
out=$results/fuzz-$date$suffix.txt
machine=$("$here/../machine.sh")
load=$(cut -d' ' -f1-3 /proc/loadavg)

declare -A seeds
names=()
while read -r name seed_dir; do
  [[ -z $name ]] && continue
  if [[ $# -gt 0 && " $* " != *" $name "* ]]; then continue; fi
  seeds[$name]=$seed_dir
  names+=("$name")
done <"$manifest"

# Two at a time; each run's console output goes to its work folder.
status=0
for ((i = 0; i < ${#names[@]}; i += 2)); do
  pids=()
  for name in "${names[@]:i:2}"; do
    mkdir -p "$fuzz_dir/work"
    "$runner" "$fuzz_dir/$name" "${seeds[$name]}" "$fuzz_dir/work/$name" "$seconds" \
      >"$fuzz_dir/work/$name.out" 2>&1 &
    pids+=($!)
  done
  for pid in "${pids[@]}"; do
    code=0
    wait "$pid" || code=$?
    [[ $code -eq 1 ]] && status=1
  done
  for name in "${names[@]:i:2}"; do cat "$fuzz_dir/work/$name.out"; done
done

built=0
{
  echo "# fuzz-run: every libFuzzer target for ${seconds} s (command: make fuzz-run FUZZ_SECONDS=$seconds," \
    "that is bench/fuzz/run.sh $fuzz_dir $seconds $results${*:+ $*})"
  echo "# machine: $machine"
  echo "# load average when the run started (1, 5, 15 min): $load (2 cores, two targets at a time; other jobs share them)"
  echo "# cov = edges covered, ft = libFuzzer features, corpus = inputs kept (seeds included);"
  echo "# findings = crash/leak/oom/timeout inputs in $fuzz_dir/work/<target>/artifacts/"
  echo
  printf "%-22s %8s %11s %8s %6s %7s %8s %9s  %s\n" target seconds execs exec/s cov ft corpus findings \
    "goal (>= 600 s, 0 findings)"
  for name in "${names[@]}"; do
    summary=$fuzz_dir/work/$name/summary.txt
    if [[ ! -s $summary ]]; then
      printf "%-22s %s\n" "$name" "not built (clang++ with libFuzzer not found): skipped"
      continue
    fi
    built=1
    get() { sed -n "s/.*\b$1=\([^ ]*\).*/\1/p" "$summary"; }
    verdict=$([[ $(get findings) -eq 0 && $(get seconds) -ge 600 ]] && echo PASS ||
      { [[ $(get findings) -eq 0 ]] && echo "0 findings (shorter run)" || echo FAIL; })
    printf "%-22s %8s %11s %8s %6s %7s %8s %9s  %s\n" "$name" "$(get seconds)" "$(get execs)" \
      "$(get exec_per_s)" "$(get cov)" "$(get ft)" "$(get corpus)" "$(get findings)" "$verdict"
  done
} >"$out"
cat "$out"
echo "fuzz-run: results in $out"
[[ $built -eq 0 ]] && exit 77
exit $status
