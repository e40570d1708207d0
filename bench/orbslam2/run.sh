#!/usr/bin/env bash
# ORB-SLAM2 itself on the sequences and vocabularies of `make bench-track`, so
# that rrslam's figures there can be read against the system it follows.
#
#   bench/orbslam2/run.sh RGBD_TUM BIN TRACK_DATA SHARED_DATA RUNS OUT_PREFIX
#
#   RGBD_TUM     ORB-SLAM2's Examples/RGB-D/rgbd_tum, built by the user
#                (raulmur/ORB_SLAM2; nothing of it is in this repository)
#   BIN          rrslam's executables (rrslam-vocab, rrslam-eval)
#   TRACK_DATA   bench-track's inputs (BENCH_TRACK_DIR: synthetic sequences
#                and vocabularies, made by `make bench-track-data`)
#   SHARED_DATA  the shared data folder (the real sequences)
#   RUNS         runs per case (ORB-SLAM2 runs in threads, paced by the
#                frame timestamps: its result varies from run to run)
#   OUT_PREFIX   writes OUT_PREFIX.txt (the table) and OUT_PREFIX.tsv
#
# Each case runs `rgbd_tum VOCAB SETTINGS SEQUENCE ASSOCIATIONS` RUNS times in
# TRACK_DATA/orbslam2/runs/<case>/run<i> with the vocabulary bench-track uses
# for that sequence, converted to DBoW2 text (`rrslam-vocab convert`), and the
# same settings file; the ATE is `rrslam-eval ate` of CameraTrajectory.txt
# against the sequence's ground truth, as bench-track computes it.
# "loops" counts the "Loop detected!" lines ORB-SLAM2 prints.
set -euo pipefail
if [[ $# -ne 6 ]]; then
  echo "usage: $0 RGBD_TUM BIN TRACK_DATA SHARED_DATA RUNS OUT_PREFIX" >&2
  exit 64
fi
rgbd_tum=$1 bin=$2 data=$(cd "$3" && pwd) shared=$(cd "$4" && pwd) runs=$5 out=$6
[[ -x "$rgbd_tum" ]] || { echo "bench-orbslam2: $rgbd_tum: not an executable (ORB-SLAM2's rgbd_tum)" >&2; exit 66; }
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "bench-orbslam2: runs must be a positive integer, not '$runs'" >&2; exit 64; }
work=$data/orbslam2
mkdir -p "$work/vocab" "$work/runs"

# TUM's associate.py rule, the one rrslam-track pairs by
# (AssociateTimestamps, common/dataset.h): pairs by smallest time difference
# first, under 0.02 s, each stamp used once. rgbd_tum needs the pairs as a
# file, and no rrslam tool writes one, hence this copy of the rule.
associate() {  # SEQUENCE_DIR OUT
  python3 - "$1" "$2" <<'EOF'
import sys
def read(path):
    rows = {}
    for line in open(path):
        if line.strip() and not line.startswith('#'):
            f = line.split()
            rows[float(f[0])] = f[1]
    return rows
rgb, depth = read(sys.argv[1] + '/rgb.txt'), read(sys.argv[1] + '/depth.txt')
pairs = sorted((abs(a - b), a, b) for a in rgb for b in depth if abs(a - b) < 0.02)
used_a, used_b, kept = set(), set(), []
for _, a, b in pairs:
    if a not in used_a and b not in used_b:
        used_a.add(a); used_b.add(b); kept.append((a, b))
with open(sys.argv[2], 'w') as f:
    for a, b in sorted(kept):
        f.write('%f %s %f %s\n' % (a, rgb[a], b, depth[b]))
EOF
}

text_vocab() {  # RRV -> path of its DBoW2 text form (made once)
  local name
  name=$(echo "${1#"$data"/}" | tr '/' '_')
  local txt=$work/vocab/${name%.rrv}.txt
  if [[ ! -f "$txt" || "$txt" -ot "$1" ]]; then
    "$bin/rrslam-vocab" -q convert "$1" "$work/vocab/tmp.$$.txt" && mv "$work/vocab/tmp.$$.txt" "$txt"
  fi
  echo "$txt"
}

printf 'case\tvocabulary\truns\tate_cm\tmedian_cm\tmin_cm\tmax_cm\tposes\tframes\tloops\n' > "$out.tsv"
run_case() {  # CASE SEQUENCE SETTINGS VOCAB_RRV
  local name=$1 seq=$2 settings=$3 vocab_rrv=$4
  if [[ ! -f "$seq/groundtruth.txt" || ! -f "$vocab_rrv" ]]; then
    echo "bench-orbslam2: $name skipped: $seq/groundtruth.txt or $vocab_rrv missing" >&2
    return
  fi
  local assoc=$seq/associations.txt
  if [[ ! -f "$assoc" ]]; then
    assoc=$work/runs/$(echo "$name" | tr / _).associations.txt
    associate "$seq" "$assoc"
  fi
  local vocab frames ates=() loops=0 poses=0
  vocab=$(text_vocab "$vocab_rrv")
  frames=$(grep -c . "$assoc")
  for i in $(seq 1 "$runs"); do
    local dir=$work/runs/$name/run$i
    rm -rf "$dir" && mkdir -p "$dir"
    (cd "$dir" && "$rgbd_tum" "$vocab" "$settings" "$seq" "$assoc" > stdout.log 2> stderr.log) ||
      { echo "bench-orbslam2: $name run $i: rgbd_tum failed (logs in $dir)" >&2; exit 70; }
    ates+=("$("$bin/rrslam-eval" ate --gt "$seq/groundtruth.txt" --est "$dir/CameraTrajectory.txt" |
      awk '/absolute_translational_error.rmse/ {printf "%.4f", $2 * 100}')")
    loops=$((loops + $(grep -c 'Loop detected' "$dir/stdout.log" || true)))
    poses=$(grep -c . "$dir/CameraTrajectory.txt")
  done
  local sorted
  sorted=$(printf '%s\n' "${ates[@]}" | sort -g)
  local median min max
  median=$(echo "$sorted" | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}')
  min=$(echo "$sorted" | head -1) max=$(echo "$sorted" | tail -1)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "${vocab_rrv#"$data"/}" "$runs" \
    "$(IFS=,; echo "${ates[*]}")" "$median" "$min" "$max" "$poses" "$frames" "$loops" >> "$out.tsv"
  echo "bench-orbslam2: $name: ATE ${ates[*]} cm (median $median)" >&2
}

kitchen=$shared/7scenes-kitchen fr1=$shared/tum/fr1_xyz
for v in pipeline pipeline-stride2-seed0 pipeline-stride2-seed1; do
  run_case "7scenes-kitchen/$v" "$kitchen" "$shared/settings/7scenes.yaml" "$data/$v/7scenes-kitchen/voc.rrv"
  run_case "fr1_xyz/$v" "$fr1" "$shared/settings/tum1.yaml" "$data/$v/fr1_xyz/voc.rrv"
done
for p in loop sweep rotation; do
  for n in clean noisy; do
    run_case "synth-$p-$n" "$data/synth/$p-$n" "$data/synth/$p-$n/settings.yaml" "$data/pipeline/$p-clean/voc.rrv"
  done
done
run_case synth-shake "$data/synth/shake" "$data/synth/shake/settings.yaml" "$data/pipeline/shake/voc.rrv"
for l in laps laps-dse laps-dsw; do
  run_case "synth-$l" "$data/synth/$l" "$data/synth/$l/settings.yaml" "$data/pipeline/loop-clean/voc.rrv"
done

{
  echo "# bench-orbslam2: ORB-SLAM2's rgbd_tum on bench-track's sequences and vocabularies (command: make bench-orbslam2 ORBSLAM2_RGBD_TUM=$rgbd_tum BENCH_ORBSLAM2_RUNS=$runs)"
  echo "# machine: $(bench/machine.sh 2>/dev/null || true)"
  echo "# ATE RMSE in cm per run (rrslam-eval ate, SE(3) alignment); poses: lines of the last run's CameraTrajectory.txt; frames: frames paired in the associations; loops = 'Loop detected!' over all runs"
  column -t -s $'\t' "$out.tsv"
} > "$out.txt"
cat "$out.txt"
