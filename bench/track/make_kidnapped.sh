#!/usr/bin/env bash
# Builds a "kidnapped camera" sequence from a TUM-layout sequence: frames
# [A, B) followed by frames [C, D) again, with new, later timestamps (1/30 s
# apart, continuing the first part), so the camera jumps back to a place it
# has mapped. Images are symbolic links (nothing is copied); rgb.txt,
# depth.txt and groundtruth.txt (the ground truth of each frame relabelled
# with its new timestamp, nearest pose within 0.02 s) are written anew.
#
#   bench/track/make_kidnapped.sh SRC A B C D OUT
#
# Frames are the lines of SRC/associations.txt when it exists, else each line
# of rgb.txt with the depth image of depth.txt nearest in time. Writes OUT atomically (OUT.tmp,
# then rename); fails with a message naming the file when SRC lacks a list.
set -euo pipefail
if [[ $# -ne 6 ]]; then
  echo "usage: $0 SRC A B C D OUT" >&2
  exit 64
fi
src=$(cd "$1" && pwd)
a=$2 b=$3 c=$4 d=$5 out=$6
for f in rgb.txt depth.txt groundtruth.txt; do
  [[ -f "$src/$f" ]] || { echo "make_kidnapped: $src/$f: missing" >&2; exit 66; }
done
# OUT is replaced only when it is missing, empty or an earlier output of this
# script (its files, images as symbolic links): never a folder of the user's.
if [[ -e "$out" || -L "$out" ]]; then
  foreign=$(find "$out" -maxdepth 0 ! -type d -printf '%f\n'
    find "$out" -mindepth 1 -maxdepth 1 ! -name rgb ! -name depth ! -name rgb.txt \
      ! -name depth.txt ! -name groundtruth.txt ! -name settings.yaml -printf '%f\n' 2>/dev/null
    find "$out"/rgb "$out"/depth -mindepth 1 ! -type l -printf '%P\n' 2>/dev/null || true)
  if [[ -n "$foreign" ]]; then
    echo "make_kidnapped: $out: holds files make_kidnapped did not write ($(head -1 <<<"$foreign")); give an empty or new folder" >&2
    exit 73
  fi
fi
tmp="$out.tmp.$$"
rm -rf "$tmp"
mkdir -p "$tmp/rgb" "$tmp/depth"
python3 - "$src" "$a" "$b" "$c" "$d" "$tmp" <<'EOF'
import bisect, os, sys
src, a, b, c, d, out = sys.argv[1], *map(int, sys.argv[2:6]), sys.argv[6]
def rows(name):
    with open(os.path.join(src, name)) as f:
        return [l.split() for l in f if l.strip() and not l.startswith('#')]
if os.path.exists(os.path.join(src, 'associations.txt')):
    frames = [(float(r[0]), r[1], r[3]) for r in rows('associations.txt')]
else:  # Each colour image with the depth image nearest in time (TUM's lists).
    depth = sorted((float(r[0]), r[1]) for r in rows('depth.txt'))
    depth_t = [t for t, _ in depth]
    frames = []
    for r in rows('rgb.txt'):
        t = float(r[0])
        j = bisect.bisect_left(depth_t, t)
        near = min((x for x in (j - 1, j) if 0 <= x < len(depth)), key=lambda x: abs(depth_t[x] - t))
        frames.append((t, r[1], depth[near][1]))
gt = sorted((float(r[0]), r[1:]) for r in rows('groundtruth.txt'))
stamps = [t for t, _ in gt]
order = list(range(a, b)) + list(range(c, d))
if max(order) >= len(frames):
    sys.exit(f'make_kidnapped: {src} has {len(frames)} frames; asked for frame {max(order)}')
t0 = frames[a][0]
with open(f'{out}/rgb.txt', 'w') as fr, open(f'{out}/depth.txt', 'w') as fd, \
     open(f'{out}/groundtruth.txt', 'w') as fg:
    fr.write('# timestamp filename (kidnapped: frames %d-%d, then %d-%d)\n' % (a, b - 1, c, d - 1))
    fd.write('# timestamp filename\n')
    fg.write('# timestamp tx ty tz qx qy qz qw (relabelled)\n')
    for k, i in enumerate(order):
        t, rgb, depth = frames[i]
        new_t = t0 + k / 30.0
        ext_r, ext_d = os.path.splitext(rgb)[1], os.path.splitext(depth)[1]
        os.symlink(os.path.join(src, rgb), f'{out}/rgb/{k:06d}{ext_r}')
        os.symlink(os.path.join(src, depth), f'{out}/depth/{k:06d}{ext_d}')
        fr.write(f'{new_t:.6f} rgb/{k:06d}{ext_r}\n')
        fd.write(f'{new_t:.6f} depth/{k:06d}{ext_d}\n')
        j = bisect.bisect_left(stamps, t)
        best = min((x for x in (j - 1, j) if 0 <= x < len(stamps)), key=lambda x: abs(stamps[x] - t))
        if abs(stamps[best] - t) <= 0.02:
            fg.write(f'{new_t:.6f} ' + ' '.join(gt[best][1]) + '\n')
EOF
[[ -f "$src/settings.yaml" ]] && ln -s "$src/settings.yaml" "$tmp/settings.yaml"
rm -rf "$out"
mv "$tmp" "$out"
