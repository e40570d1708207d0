#!/usr/bin/env bash
# The vocabulary benchmark. Usage: bench/vocab/run.sh BUILD_DIR SHARED_DATA RESULTS_DIR
# Writes RESULTS_DIR/vocab-<date>.txt (and .json) with the machine line, every
# figure and its goal. Intermediate files go to BUILD_DIR/bench-data/vocab/.
set -euo pipefail
build=$1 shared=$2 results=$3
bin=$build/bin
work=$build/bench-data/vocab
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work" "$results"
date=$(date -u +%Y-%m-%d)
machine=$("$here/../machine.sh")
load=$(cut -d' ' -f1-3 /proc/loadavg)

# 1. An ORBvoc-shaped DBoW2 text vocabulary (generated once) and its binary form.
if [[ ! -s $work/orbvoc.txt ]]; then
  "$bin/vocab_bench_generate" "$work/orbvoc.txt" 1
fi
"$bin/rrslam-vocab" --quiet convert "$work/orbvoc.txt" "$work/orbvoc.rrv"
text_bytes=$(stat -c %s "$work/orbvoc.txt")
binary_bytes=$(stat -c %s "$work/orbvoc.rrv")

# 2. Training on every 2nd frame of 7scenes-kitchen (extraction not timed).
kitchen=$shared/7scenes-kitchen
features_arg=()
training=""
if [[ -d $kitchen ]]; then
  # Extracted on every run (4 s): a cached file would outlive a change of the extractor.
  "$bin/rrslam-extract" --quiet --sequence "$kitchen" --settings "$shared/settings/7scenes.yaml" \
    --out "$work/kitchen.h5"
  /usr/bin/time -f "%e %M %U %S" -o "$work/cluster.time" "$bin/rrslam-cluster" --quiet \
    --features "$work/kitchen.h5" --stride 2 --k 10 --levels 6 --seed 0 --threads 2 \
    --out "$work/kitchen_tree.h5"
  /usr/bin/time -f "%e %M %U %S" -o "$work/build.time" "$bin/rrslam-vocab" --quiet build \
    --tree "$work/kitchen_tree.h5" --features "$work/kitchen.h5" --stride 2 --threads 2 \
    --out "$work/kitchen.rrv"
  read -r cluster_s cluster_kb cluster_user cluster_sys < <(tail -n 1 "$work/cluster.time")
  read -r build_s build_kb build_user build_sys < <(tail -n 1 "$work/build.time")
  cpu() { awk -v u="$1" -v s="$2" 'BEGIN { printf "%.2f", u + s }'; }
  info=$("$bin/rrslam-vocab" info --json "$work/kitchen.rrv")
  descriptors=$(grep -o '"num_descriptors": *[0-9]*' <<<"$info" | grep -o '[0-9]*$')
  images=$(grep -o '"training_images": *[0-9]*' <<<"$info" | grep -o '[0-9]*$')
  words=$(grep -o '"words": *[0-9]*' <<<"$info" | head -n 1 | grep -o '[0-9]*$')
  training=yes
  features_arg=("$work/kitchen.h5")
fi

# 3. Loads and transform (1000 real descriptors when the kitchen features exist).
"$bin/vocab_bench" "$work/orbvoc.txt" "$work/orbvoc.rrv" "${features_arg[@]}" > "$work/bench.out"
get() { awk -v k="$1" '$1 == k { print $2 }' "$work/bench.out"; }

verdict() {  # verdict VALUE GOAL -> PASS/FAIL (VALUE <= GOAL)
  awk -v v="$1" -v g="$2" 'BEGIN { print (v <= g) ? "PASS" : "FAIL" }'
}
ms() { awk -v s="$1" 'BEGIN { printf "%.2f", s * 1000 }'; }
mb() { awk -v b="$1" 'BEGIN { printf "%.2f", b / 1e6 }'; }

text_s=$(get text_load_median_s)
binary_s=$(get binary_load_median_s)
transform_s=$(get transform_1000_median_s)

# 4. Whole processes: `rrslam-vocab info` on the binary vocabulary (load,
# checksum, structure, identity) against `rrslam-vocab --version` (the
# process alone), median of 21 runs each (bash's clock: no fork to time).
median_ms() {
  local times=() start
  for _ in $(seq 21); do
    start=$EPOCHREALTIME
    "$@" > /dev/null 2>&1
    times+=("$(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.3f", (b - a) * 1000 }')")
  done
  printf '%s\n' "${times[@]}" | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'
}
version_ms=$(median_ms "$bin/rrslam-vocab" --version)
info_ms=$(median_ms "$bin/rrslam-vocab" --quiet info "$work/orbvoc.rrv")
extra_ms=$(awk -v a="$info_ms" -v b="$version_ms" 'BEGIN { printf "%.1f", a - b }')
out=$results/vocab-$date.txt
{
  echo "# rrslam vocabulary benchmark (bench/vocab/run.sh, make bench-vocab)"
  echo "machine: $machine"
  echo "date: $date"
  echo "load average when the run started (1, 5, 15 min): $load (2 cores; other jobs share them)"
  echo
  echo "ORBvoc-shaped vocabulary (bench/vocab/make_orbvoc.cc, seed 1): k=10 L=6" \
       "nodes=$(get nodes) words=$(get words)"
  printf "%-66s %10s s   goal <= 1 s     %s\n" "text load, DBoW2 text $(mb "$text_bytes") MB, warm cache (median of 5)" \
    "$text_s" "$(verdict "$text_s" 1.0)"
  printf "%-66s %10s ms  goal <= 5 ms    %s\n" "binary load, warm cache, until it can transform (median of 30)" \
    "$(ms "$binary_s")" "$(verdict "$binary_s" 0.005)"
  printf "%-66s %10s ms  (min of 30)\n" "" "$(ms "$(get binary_load_min_s)")"
  printf "%-66s %10s ms  goal <= 10 ms   %s\n" \
    "rrslam-vocab info, whole process, beyond --version ($info_ms - $version_ms ms, median of 21)" \
    "$extra_ms" "$(verdict "$extra_ms" 10)"
  printf "%-66s %10s MB  goal <= 44 MB   %s\n" "binary file size ($binary_bytes bytes)" \
    "$(mb "$binary_bytes")" "$(verdict "$binary_bytes" 44000000)"
  printf "%-66s %10s ms  goal <= 0.5 ms  %s\n" \
    "transform 1000 $(get descriptors_source | sed 's/features/real (kitchen)/') descriptors + feature vector (median of 300)" \
    "$(ms "$transform_s")" "$(verdict "$transform_s" 0.0005)"
  printf "%-66s %10s ms  (first call, cold)\n" "" "$(ms "$(get transform_1000_first_s)")"
  echo
  if [[ -n $training ]]; then
    total_s=$(awk -v a="$cluster_s" -v b="$build_s" 'BEGIN { printf "%.2f", a + b }')
    peak_kb=$(( cluster_kb > build_kb ? cluster_kb : build_kb ))
    peak_mb=$(awk -v k="$peak_kb" 'BEGIN { printf "%.0f", k / 1024 }')
    echo "training: 7scenes-kitchen every 2nd frame ($images images, $descriptors descriptors)," \
         "k=10 L=6, --threads 2 -> $words words"
    printf "%-66s %10s s   (CPU %s s)\n" "  rrslam-cluster, wall (peak RSS $((cluster_kb / 1024)) MB)" "$cluster_s" \
      "$(cpu "$cluster_user" "$cluster_sys")"
    printf "%-66s %10s s   (CPU %s s)\n" "  rrslam-vocab build, wall (peak RSS $((build_kb / 1024)) MB)" "$build_s" \
      "$(cpu "$build_user" "$build_sys")"
    printf "%-66s %10s s   goal <= 10 s    %s\n" "  cluster + build, wall" "$total_s" "$(verdict "$total_s" 10)"
    printf "%-66s %10s MB  goal <= 1024 MB %s\n" "  peak memory (max RSS of the two)" "$peak_mb" \
      "$(verdict "$peak_mb" 1024)"
  else
    echo "training: skipped ($kitchen not found)"
  fi
} > "$out"
cat "$out"
echo "bench-vocab: results in $out"
