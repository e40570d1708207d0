#!/usr/bin/env bash
# Writes the paper report (Markdown) on stdout from the cells `make paper`
# made under PAPER_ROOT (pipelines/paper.mk): every table, the command and
# input behind each number, and the seed paper's figures beside ours.
# Usage: report.sh BIN PAPER_ROOT "SEQUENCES" TRANSFER_SEQUENCE VOCAB_K VOCAB_L [REFERENCE]
# REFERENCE (PAPER_REFERENCE): a CSV of the seed paper's Table 3/4 figures,
# "sequence,variant,ate_rmse_cm" with that header line (variant: own, general
# or transfer), printed beside ours; without it the report says there is none.
set -euo pipefail
bin=$1 root=$2 names=$3 transfer=$4 k=$5 levels=$6 reference=${7:-}
if [[ -n $reference && $(head -n 1 "$reference" 2>/dev/null | tr -d '\r') != "sequence,variant,ate_rmse_cm" ]]; then
  echo "report.sh: $reference: not a PAPER_REFERENCE file (its first line must be sequence,variant,ate_rmse_cm)" >&2
  exit 65
fi
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)

mb() { awk -v b="$1" 'BEGIN { printf "%.2f", b / 1e6 }'; }
json_number() { grep -o "\"$2\": *[0-9.e+-]*" "$1" | head -n 1 | sed 's/.*: *//'; }
rel() { echo "${1#"$root"/}"; }

echo "# rrslam: the seed paper's experiments"
echo
echo "Made by \`make paper\` (pipelines/paper.mk) on $("$repo/bench/machine.sh")."
echo "rrslam $(git -C "$repo" describe --always --dirty 2>/dev/null || echo unknown)."
echo "Sequences: $names. Every figure below is measured by this run;"
echo "the seed paper's own figures are quoted beside them where the paper has one."
echo

echo "## Table 1/2: vocabulary size and load time, DBoW2 text against rrslam binary"
echo
if [[ -f $root/vocab-load.csv ]]; then
  echo "Start-up: one \`rrslam-vocab info FILE\` process, timed from before its start to its"
  echo "exit (start, the whole load and check, exit), median and minimum of the start-ups"
  echo "given; load: the load alone inside one process (bench/vocab/vocab_bench, warm"
  echo "page cache). Command: \`pipelines/paper/vocab_load.sh\`; table: \`$(rel "$root/vocab-load.csv")\`."
  echo
  echo "| vocabulary | format | size MB | start-up s (median) | start-up s (min) | start-ups | load s (in process) | note |"
  echo "|---|---|---:|---:|---:|---:|---:|---|"
  tail -n +2 "$root/vocab-load.csv" | while IFS=, read -r name source format bytes median min runs load note; do
    echo "| $name | $format | $(mb "$bytes") | ${median:--} | ${min:--} | $runs | ${load:--} | ${note} |"
  done
  echo "| *seed paper: ORBvoc.txt* | text | *145.3* | *8.06* | | | | ORB-SLAM2's vocabulary; the paper's Table 1/2 |"
  echo "| *seed paper: its binary form* | binary | *44.4* | *0.43* | | | | |"
else
  echo "Not measured: \`$(rel "$root/vocab-load.csv")\` is missing (see make's output)."
fi
echo

echo "## Table 3/4: ATE RMSE per sequence and vocabulary"
echo
echo "Vocabularies (all k = $k, L = $levels, TF-IDF, L1): **own**, trained on the sequence"
echo "itself (\`make vocab\`: rrslam-extract, rrslam-cluster, rrslam-vocab build);"
echo "**general**, trained on all the other sequences together (the paper's general"
echo "vocabulary, leave-one-out); **transfer**, $transfer's own vocabulary applied to"
echo "every other sequence (the paper trains on fr1_room and tests on the others)."
echo "Each cell is one \`rrslam-track --mode batch\` run (deterministic: a rerun gives the"
echo "same trajectory) evaluated by \`rrslam-eval ate\`; changes are against **general**,"
echo "as the paper prints them. Table: \`rrslam-eval compare\` -> \`ate-table.md\`,"
echo "\`ate-table.csv\`; runs in \`runs/<variant>/<sequence>/\` (track/run.json holds each"
echo "run's command line and options)."
echo
if [[ -f $root/ate-table.md ]]; then
  cat "$root/ate-table.md"
else
  echo "Not made: \`ate-table.md\` is missing (see make's output)."
fi
echo
if [[ -n $reference ]]; then
  echo "Seed paper's figures (from \`$reference\`, PAPER_REFERENCE) beside ours, in cm:"
  echo
  echo "| sequence | vocabulary | seed paper | rrslam |"
  echo "|---|---|---:|---:|"
  tail -n +2 "$reference" | while IFS=, read -r seq variant paper_cm _; do
    [[ -z $seq ]] && continue
    ours=$(awk -F, -v s="$seq" -v v="$variant" '$1 == s && $2 == v { print $3 }' \
      "$root/ate-table.csv" 2>/dev/null || true)
    echo "| $seq | $variant | $paper_cm | ${ours:-not run} |"
  done
else
  echo "Seed paper: its Table 3/4 measure fr1_room's vocabulary on fr1_xyz, fr1_360, fr2_rpy"
  echo "and fr2_desk. Its ATE values are not in the material this project was given, so none"
  echo "is quoted here; give them as PAPER_REFERENCE=<csv> (docs/paper.md) to print them beside ours."
fi
echo
echo "Vocabulary sizes:"
echo
echo "| sequence | own: nodes | own: MB (binary) | general: nodes | general: MB (binary) |"
echo "|---|---:|---:|---:|---:|"
for n in $names; do
  cells=""
  for v in "pipeline/$n/voc.rrv" "general/$n/voc.rrv"; do
    if [[ -f $root/$v ]]; then
      nodes=$("$bin/rrslam-vocab" info --json "$root/$v" 2>/dev/null | grep -o '"nodes": *[0-9]*' | head -n 1 | grep -o '[0-9]*$' || true)
      cells="$cells | ${nodes:--} | $(mb "$(stat -c %s "$root/$v")")"
    else
      cells="$cells | - | -"
    fi
  done
  echo "| $n$cells |"
done
echo
if [[ -f $root/ate-bars.png ]]; then
  echo "![ATE RMSE per sequence and vocabulary](ate-bars.png)"
  echo
fi

echo "## Start-up on a saved map: process start to first pose"
echo
echo "The paper's Algorithm 4: the first half of each real sequence is mapped and saved"
echo "(\`rrslam-track --save-map\`), then rrslam-track starts on the map"
echo "(\`--load-map --localization-only --first-frame <half>\`) with the binary and with"
echo "the text form of the same vocabulary; figures from run.json \`startup\` (from the"
echo "kernel's process start time). Command: \`pipelines/paper/startup.sh\`; tables:"
echo "\`startup/<sequence>.csv\`."
echo
shopt -s nullglob
startup=("$root"/startup/*.csv)
if ((${#startup[@]})); then
  echo "| sequence | vocabulary | first pose ms (median) | first pose ms (max) | vocabulary load ms | map load ms | map MB | keyframes | points | start-ups |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
  for f in "${startup[@]}"; do
    tail -n +2 "$f" | while IFS=, read -r seq voc runs first first_max voc_ms map_ms frame bytes kfs pts mapped; do
      echo "| $seq | $voc | $first | $first_max | $voc_ms | $map_ms | $(mb "$bytes") | $kfs | $pts | $runs |"
    done
  done
  echo
  echo "Seed paper: 8.06 s to load ORBvoc.txt against 0.43 s for its binary form, before any map."
else
  echo "Not measured: no real sequence, or the start-up cells failed (see make's output)."
fi
echo

echo "## Trajectories against the ground truth"
echo
echo "Own-vocabulary run of each sequence, aligned as ATE (\`rrslam-render trajectory\`):"
echo
for n in $names; do
  if [[ -f $root/figures/$n/trajectory_top.png ]]; then
    echo "- $n: ![${n}](figures/$n/trajectory_top.png) (also \`_side\`, \`_front\`, \`_error\`)"
  else
    echo "- $n: not made (the run failed; see \`runs/own/$n/error.txt\`)"
  fi
done
