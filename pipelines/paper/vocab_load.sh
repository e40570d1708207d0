#!/usr/bin/env bash
# Table 1/2 of the paper: vocabulary file size and load time, DBoW2 text
# against rrslam binary.
# Usage: vocab_load.sh BIN VOCAB_DIR WORK_DIR RUNS ORBVOC OUT.csv
#   BIN        folder of rrslam-vocab, vocab_bench and vocab_bench_generate
#   VOCAB_DIR  real DBoW2 vocabularies (*.txt, and *.yml / *.yml.gz originals)
#   WORK_DIR   where the generated ORBvoc-shaped vocabulary and the binary
#              conversions go (the generated one is made once and kept)
#   ORBVOC     1: include an ORBvoc-shaped vocabulary (k = 10, L = 6, 1.08 M
#              nodes, bench/vocab/make_orbvoc.cc); 0: only VOCAB_DIR's
# Two figures per file:
#   startup_*  RUNS process start-ups of `rrslam-vocab info FILE`, each timed
#              from before its start to its exit (process start, the whole
#              load: text parsed, binary mapped, checked and hashed; printing);
#              median and minimum. What a user waits for.
#   load_median_s  the load alone, in one process (bench/vocab/vocab_bench:
#              median of 5 text loads / 30 binary loads, warm page cache);
#              empty for YAML originals.
# OUT.csv: vocabulary,source,format,bytes,startup_median_s,startup_min_s,runs,load_median_s,note
# A vocabulary that does not load gets a row with its error as the note. No
# field holds a comma (they become ';'), so the file needs no quoting.
# Written atomically (OUT.csv.new, then renamed). Exit 0, or the failing tool's code.
set -euo pipefail
bin=$1 vocab_dir=$2 work=$3 runs=$4 orbvoc=$5 out=$6
mkdir -p "$work"

# Median and minimum of RUNS start-ups of `rrslam-vocab info FILE`, seconds.
time_startups() {
  local file=$1 i start end times=()
  for ((i = 0; i < runs; ++i)); do
    start=$(date +%s%N)
    "$bin/rrslam-vocab" --quiet info "$file" > /dev/null
    end=$(date +%s%N)
    times+=("$(((end - start) / 1000))")
  done
  printf '%s\n' "${times[@]}" | sort -n | awk '{ t[NR] = $1 } END {
    m = (NR % 2) ? t[(NR + 1) / 2] : (t[NR / 2] + t[NR / 2 + 1]) / 2
    printf "%.4f,%.4f", m / 1e6, t[1] / 1e6 }'
}

# In-process load medians of a text file and its binary form: "TEXT_S BINARY_S".
load_medians() {
  "$bin/vocab_bench" "$1" "$2" > "$work/vocab_bench.out"
  awk '$1 == "text_load_median_s" { t = $2 } $1 == "binary_load_median_s" { b = $2 }
       END { print t, b }' "$work/vocab_bench.out"
}

field() { printf '%s' "${1//,/;}"; }

row() {  # row NAME SOURCE FORMAT FILE [LOAD_MEDIAN_S]
  echo "$1,$(field "$2"),$3,$(stat -c %s "$4"),$(time_startups "$4"),$runs,${5:-},"
}

refused() {  # refused NAME SOURCE FORMAT FILE MESSAGE
  echo "$1,$(field "$2"),$3,$(stat -c %s "$4"),,,0,,$(field "$5")"
}

text_and_binary() {  # text_and_binary NAME SOURCE TEXT_FILE BINARY_FILE
  local loads
  loads=($(load_medians "$3" "$4"))
  row "$1" "$2" text "$3" "${loads[0]}"
  row "$1" "rrslam-vocab convert $(basename "$3")" binary "$4" "${loads[1]}"
}

{
  echo "vocabulary,source,format,bytes,startup_median_s,startup_min_s,runs,load_median_s,note"
  if [[ $orbvoc == 1 ]]; then
    # ORB-SLAM2's ORBvoc.txt shape (k = 10, L = 6), generated (bench/vocab).
    if [[ ! -s $work/orbvoc.txt ]]; then
      "$bin/vocab_bench_generate" "$work/orbvoc.txt" 1 >&2
    fi
    "$bin/rrslam-vocab" --quiet convert "$work/orbvoc.txt" "$work/orbvoc.rrv"
    text_and_binary orbvoc-shaped "bench/vocab/make_orbvoc.cc (seed 1)" "$work/orbvoc.txt" \
      "$work/orbvoc.rrv"
  fi
  shopt -s nullglob
  for original in "$vocab_dir"/*.txt "$vocab_dir"/*.yml "$vocab_dir"/*.yml.gz; do
    file=$(basename "$original")
    name=${file%.gz}
    name=${name%.*}
    format=text
    [[ $file == *.yml || $file == *.yml.gz ]] && format=yaml
    if ! message=$("$bin/rrslam-vocab" --quiet convert "$original" "$work/$name.$format.rrv" 2>&1); then
      refused "$name" "$original" "$format" "$original" "${message##*$'\n'}"
    elif [[ $format == text ]]; then
      text_and_binary "$name" "$original" "$original" "$work/$name.$format.rrv"
    else
      row "$name" "$original" "$format" "$original"
    fi
  done
} > "$out.new"
mv -f "$out.new" "$out"
