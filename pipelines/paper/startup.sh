#!/usr/bin/env bash
# The paper's start-up experiment (its Algorithm 4) on one real sequence: map
# the first half of the sequence and save the map, then start RUNS times on
# the map in localization-only mode at the second half's first frame, with
# the binary and with the DBoW2 text form of the same vocabulary (one tree
# identity, so the map accepts both), and read the start-up figures each run
# reports in run.json (`startup`: from the kernel's process start time).
# Usage: startup.sh BIN SEQUENCE SETTINGS PIPELINE_DIR WORK_DIR RUNS OUT.csv
#   PIPELINE_DIR holds the sequence's features.h5, voc.rrv and voc.txt (the
#   vocab pipeline's outputs); the mapping run uses the cached features, the
#   start-ups extract their frames as a live robot would.
# OUT.csv: sequence,vocabulary,runs,first_pose_median_ms,first_pose_max_ms,
#   vocabulary_load_median_ms,map_load_median_ms,first_pose_frame,map_bytes,
#   map_keyframes,map_points,mapped_frames
# Written atomically (OUT.csv.new, then renamed); exit code of the failing tool.
set -euo pipefail
bin=$1 seq=$2 settings=$3 pipeline=$4 work=$5 runs=$6 out=$7
mkdir -p "$work"
frames=$(grep -c -v -E '^[[:space:]]*(#|$)' "$seq/rgb.txt")
half=$((frames / 2))

"$bin/rrslam-track" --quiet --sequence "$seq" --settings "$settings" --vocab "$pipeline/voc.rrv" \
  --features "$pipeline/features.h5" --max-frames "$half" --out "$work/mapping" \
  --save-map "$work/map.rrm"

json_number() {  # json_number FILE KEY: the first "KEY": <number> in FILE
  grep -o "\"$2\": *-\?[0-9.e+-]*" "$1" | head -n 1 | sed 's/.*: *//'
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

map_info=$("$bin/rrslam-mapstore" info --json "$work/map.rrm")
map_bytes=$(stat -c %s "$work/map.rrm")
map_keyframes=$(grep -o '"keyframes": *[0-9]*' <<<"$map_info" | tail -n 1 | grep -o '[0-9]*$')
map_points=$(grep -o '"map_points": *[0-9]*' <<<"$map_info" | tail -n 1 | grep -o '[0-9]*$')

{
  echo "sequence,vocabulary,runs,first_pose_median_ms,first_pose_max_ms,vocabulary_load_median_ms,map_load_median_ms,first_pose_frame,map_bytes,map_keyframes,map_points,mapped_frames"
  for format in binary text; do
    vocab=$pipeline/voc.rrv
    [[ $format == text ]] && vocab=$pipeline/voc.txt
    first=() voc=() map=() frame=
    for ((i = 0; i < runs; ++i)); do
      run=$work/$format-$i
      "$bin/rrslam-track" --quiet --sequence "$seq" --settings "$settings" --vocab "$vocab" \
        --load-map "$work/map.rrm" --localization-only --first-frame "$half" --max-frames 30 \
        --out "$run"
      first+=("$(json_number "$run/run.json" first_pose_ms)")
      voc+=("$(json_number "$run/run.json" vocabulary_load_ms)")
      map+=("$(json_number "$run/run.json" map_load_ms)")
      frame=$(json_number "$run/run.json" first_pose_frame)
    done
    printf '%s,%s,%d,%.1f,%.1f,%.1f,%.1f,%s,%s,%s,%s,%d\n' "$(basename "$seq")" "$format" "$runs" \
      "$(printf '%s\n' "${first[@]}" | median)" "$(printf '%s\n' "${first[@]}" | sort -g | tail -n 1)" \
      "$(printf '%s\n' "${voc[@]}" | median)" "$(printf '%s\n' "${map[@]}" | median)" \
      "$frame" "$map_bytes" "$map_keyframes" "$map_points" "$half"
  done
} > "$out.new"
mv -f "$out.new" "$out"
