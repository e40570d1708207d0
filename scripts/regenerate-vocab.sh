#!/usr/bin/env bash
# Regenerates published vocabularies from their sequences, for cron: one
# vocabulary per dataset, rebuilt by `make vocab` (pipelines/vocab.mk) only
# when the dataset's images changed, published atomically with the previous
# one kept. `regenerate-vocab.sh --help` says how; docs/vocab.md has the
# crontab line.
#
# Why each step is as it is:
# - Lock: flock(1) on LOCK_FILE, held by an open file descriptor, so the
#   kernel releases it when the run ends however it ends (even by SIGKILL);
#   make and the tools inherit the descriptor, so a run killed while its
#   pipeline keeps going still holds the lock until that finishes too.
# - "Images changed": `make vocab` redoes a step when its lists (rgb.txt,
#   depth.txt, associations.txt), settings, options or tools are newer than
#   its output, but never looks at the images the lists name. This script
#   fingerprints them: SHA-256 over rgb.txt's content and, for every image it
#   lists, the path, size and modification time in nanoseconds (one stat per
#   image, no image read: 1000 images cost a few ms; a touched image counts
#   as changed, as make would count it). A dataset is rebuilt when that
#   fingerprint or the VAR=value pairs differ from those stored beside the
#   published vocabulary. The pipeline's features.h5 is then removed, so that
#   make redoes extract -> cluster -> build, when it was extracted from other
#   images (the fingerprint stored in the work folder when the extraction
#   started); when only the VAR=value pairs changed, make's own .params files
#   decide which steps to redo.
# - Publish: the new voc.rrv is checked (`rrslam-vocab info`: header,
#   checksum, tree), copied beside the published name and fsynced; the
#   published file is hard-linked to <dataset>.previous.rrv (a rename over
#   the old previous), then the copy is renamed over <dataset>.rrv. rename(2)
#   is atomic: a reader always opens a whole vocabulary, the old or the new.
#   The fingerprint is written last, so a run that dies before it rebuilds
#   next time.
set -uo pipefail

readonly EX_OK=0 EX_USAGE=64 EX_NOINPUT=66 EX_CANTCREAT=73 EX_TEMPFAIL=75
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
readonly REPO

usage() {
  cat <<EOF
Usage: scripts/regenerate-vocab.sh [options] DATASET... [VAR=value ...]

Rebuilds the vocabulary of each DATASET with \`make vocab\` when its images
changed since the vocabulary published in PUBLISH_DIR was built, and
publishes it atomically as PUBLISH_DIR/<dataset>.rrv, keeping the one it
replaces as PUBLISH_DIR/<dataset>.previous.rrv. Meant for cron: one run at a
time (flock), everything logged to LOG_DIR/regenerate-vocab-YYYY-MM-DD.log,
nothing on stdout; one line on stderr when a run fails.

DATASET is a sequence folder under DATA_ROOT or a TUM short name (fr1_room),
as for \`make vocab\`. VAR=value pairs are passed to make: VOCAB_* (VOCAB_K=10,
VOCAB_L=6, ...), EXTRACT_* and SETTINGS=<yaml> (see pipelines/vocab.mk); a
change of them rebuilds too.

Options (each also read from the environment variable named in brackets):
  --data-root DIR    sequences [DATA_ROOT] (default: $REPO/data)
  --publish-dir DIR  published vocabularies and fingerprints [PUBLISH_DIR]
                     (default: $REPO/build/vocab)
  --work-dir DIR     make's PIPELINE_ROOT, the pipeline's files [WORK_DIR]
                     (default: PUBLISH_DIR/work)
  --log-dir DIR      dated logs [LOG_DIR] (default: PUBLISH_DIR/logs)
  --lock-file FILE   the lock [LOCK_FILE] (default: PUBLISH_DIR/.regenerate-vocab.lock)
  --wait SECONDS     wait up to SECONDS for another run to finish [WAIT]
                     (default: 0, give up at once)
  --bin DIR          use the rrslam-* executables in DIR as they are [BIN]
                     (default: make builds $REPO/build/bin first)
  --force            rebuild even when nothing changed
  -h, --help         this text

Files, per dataset:
  PUBLISH_DIR/<dataset>.rrv            the vocabulary (rrslam binary)
  PUBLISH_DIR/<dataset>.previous.rrv   the one it replaced
  PUBLISH_DIR/<dataset>.fingerprint    what it was built from: images, VAR=value

Exit codes:
  0   every dataset rebuilt and published, or already up to date
  64  bad usage (unknown option, no DATASET)
  66  a DATASET has no sequence under DATA_ROOT, or rgb.txt lists a missing image
  73  a folder, the log, the lock or a published file cannot be written
  75  another run holds the lock (after --wait SECONDS, if given); nothing done
  2   \`make vocab\` failed (make's code; the log names the step and the tool's
      own exit code); the published vocabulary is unchanged
  65  the new vocabulary failed its check; the published one is unchanged
With several datasets the run goes on after a failure and exits with the first
failure's code.
EOF
}

die_usage() {
  echo "regenerate-vocab: $1 (see --help)" >&2
  exit "$EX_USAGE"
}

DATA_ROOT="${DATA_ROOT:-$REPO/data}"
PUBLISH_DIR="${PUBLISH_DIR:-$REPO/build/vocab}"
WORK_DIR="${WORK_DIR:-}"
LOG_DIR="${LOG_DIR:-}"
LOCK_FILE="${LOCK_FILE:-}"
WAIT="${WAIT:-0}"
BIN="${BIN:-}"
FORCE=0
datasets=()
make_vars=()

while (($#)); do
  case "$1" in
    -h | --help)
      usage
      exit "$EX_OK"
      ;;
    --data-root | --publish-dir | --work-dir | --log-dir | --lock-file | --wait | --bin)
      (($# >= 2)) || die_usage "$1 needs a value"
      case "$1" in
        --data-root) DATA_ROOT="$2" ;;
        --publish-dir) PUBLISH_DIR="$2" ;;
        --work-dir) WORK_DIR="$2" ;;
        --log-dir) LOG_DIR="$2" ;;
        --lock-file) LOCK_FILE="$2" ;;
        --wait) WAIT="$2" ;;
        --bin) BIN="$2" ;;
      esac
      shift 2
      ;;
    --force)
      FORCE=1
      shift
      ;;
    -*) die_usage "unknown option $1" ;;
    VOCAB_[A-Z]*=* | EXTRACT_[A-Z]*=*)
      make_vars+=("$1")
      shift
      ;;
    SETTINGS=*) # make runs in the repository: an absolute path.
      settings="${1#SETTINGS=}"
      [[ -z "$settings" || "$settings" = /* ]] || settings="$PWD/$settings"
      make_vars+=("SETTINGS=$settings")
      shift
      ;;
    *=*) die_usage "$1: only VOCAB_*, EXTRACT_* and SETTINGS are passed to make" ;;
    *)
      datasets+=("$1")
      shift
      ;;
  esac
done

((${#datasets[@]})) || die_usage "no DATASET given"
[[ "$WAIT" =~ ^[0-9]+$ ]] || die_usage "--wait $WAIT: not a whole number of seconds"
for d in "${datasets[@]}"; do
  [[ "$d" =~ ^[A-Za-z0-9._-]+$ && "$d" != .* ]] ||
    die_usage "DATASET '$d': a name, not a path (letters, digits, '.', '_', '-')"
done

# Absolute paths: make runs in $REPO.
abs() { [[ "$1" = /* ]] && echo "$1" || echo "$PWD/$1"; }
DATA_ROOT="$(abs "$DATA_ROOT")"
PUBLISH_DIR="$(abs "$PUBLISH_DIR")"
WORK_DIR="$(abs "${WORK_DIR:-$PUBLISH_DIR/work}")"
LOG_DIR="$(abs "${LOG_DIR:-$PUBLISH_DIR/logs}")"
LOCK_FILE="$(abs "${LOCK_FILE:-$PUBLISH_DIR/.regenerate-vocab.lock}")"
[[ -z "$BIN" ]] || BIN="$(abs "$BIN")"

for dir in "$PUBLISH_DIR" "$WORK_DIR" "$LOG_DIR" "$(dirname "$LOCK_FILE")"; do
  if ! mkdir -p "$dir" 2>/dev/null || [[ ! -w "$dir" ]]; then
    echo "regenerate-vocab: cannot create or write $dir" >&2
    exit "$EX_CANTCREAT"
  fi
done

LOG_FILE="$LOG_DIR/regenerate-vocab-$(date +%F).log"
if ! : >>"$LOG_FILE" 2>/dev/null; then
  echo "regenerate-vocab: cannot write the log $LOG_FILE" >&2
  exit "$EX_CANTCREAT"
fi
# Appends go in whole lines (O_APPEND): a run that finds the lock taken can
# log beside the one that holds it.
log() { printf '%s [pid %d] %s\n' "$(date '+%F %T%z')" "$$" "$*" >>"$LOG_FILE"; }
fail() { # code message: logged, and one line on stderr for cron's mail.
  log "error: $2"
  echo "regenerate-vocab: $2 (exit $1; log: $LOG_FILE)" >&2
}

# --- Lock ---------------------------------------------------------------------
# Opened for appending, so that a run that does not get the lock never
# truncates anything; the holder's pid goes to LOCK_FILE.pid.
if ! exec 9>>"$LOCK_FILE"; then
  echo "regenerate-vocab: cannot open the lock $LOCK_FILE" >&2
  exit "$EX_CANTCREAT"
fi
if ! flock --exclusive --wait "$WAIT" 9; then
  holder="$(cat "$LOCK_FILE.pid" 2>/dev/null || true)"
  log "another run holds $LOCK_FILE${holder:+ (pid $holder)}; waited ${WAIT} s;" \
    "exit 75, nothing done"
  exit "$EX_TEMPFAIL"
fi
echo "$$" >"$LOCK_FILE.pid"
log "start: datasets ${datasets[*]}; DATA_ROOT=$DATA_ROOT PUBLISH_DIR=$PUBLISH_DIR" \
  "WORK_DIR=$WORK_DIR${BIN:+ BIN=$BIN}${make_vars[*]:+ vars: ${make_vars[*]}}"

make_args=(--no-print-directory -C "$REPO" DATA_ROOT="$DATA_ROOT" PIPELINE_ROOT="$WORK_DIR")
[[ -z "$BIN" ]] || make_args+=(BIN="$BIN" SKIP_BUILD=1)
make_args+=("${make_vars[@]}")
VOCAB_TOOL="${BIN:-$REPO/build/bin}/rrslam-vocab"

# Fingerprint of the images of sequence $1: rgb.txt's hash, then one line per
# listed image (path, size, mtime in ns), hashed. Prints it, or returns 66
# after logging the missing file.
image_fingerprint() {
  local seq="$1" list="$1/rgb.txt" missing
  [[ -f "$list" ]] || {
    log "error: $list not found"
    return "$EX_NOINPUT"
  }
  # TUM lists: '#' comments, then "timestamp path" lines.
  missing="$(cd "$seq" && awk '!/^[[:space:]]*#/ && NF >= 2 { print $2 }' rgb.txt |
    while IFS= read -r image; do [[ -f "$image" ]] || echo "$image"; done | head -n 3)"
  if [[ -n "$missing" ]]; then
    log "error: $list lists missing images: ${missing//$'\n'/, }"
    return "$EX_NOINPUT"
  fi
  {
    sha256sum <"$list"
    (cd "$seq" && awk '!/^[[:space:]]*#/ && NF >= 2 { print $2 }' rgb.txt |
      tr '\n' '\0' | xargs -0 -r stat --printf '%n\t%s\t%.9Y\n')
  } | sha256sum | cut -d' ' -f1
}

# Mode of the files this script creates: what the umask allows, without x
# (mktemp creates 0600).
FILE_MODE="$(umask -S | tr -d x)"
readonly FILE_MODE

# Copies $1 to $2 atomically (temporary beside $2, fsync, rename).
publish_file() {
  local src="$1" dst="$2" tmp
  tmp="$(mktemp "$dst.XXXXXX.tmp")" || return 1
  if cp "$src" "$tmp" && chmod "$FILE_MODE" "$tmp" && sync "$tmp" && mv -f "$tmp" "$dst"; then
    sync "$(dirname "$dst")" 2>/dev/null # The rename itself, durable.
    return 0
  fi
  rm -f "$tmp"
  return 1
}

# Rebuilds and publishes dataset $1 if needed; returns its exit code.
regenerate() {
  local name="$1" seq images_fp params_fp fp_file old_images="" old_params="" code
  local published="$PUBLISH_DIR/$name.rrv" previous="$PUBLISH_DIR/$name.previous.rrv"
  fp_file="$PUBLISH_DIR/$name.fingerprint"
  seq="$(make -s "${make_args[@]}" vocab-sequence DATASET="$name" 2>>"$LOG_FILE")"
  if [[ -z "$seq" ]]; then
    fail "$EX_NOINPUT" "$name: no sequence under $DATA_ROOT (as \`make vocab\` looks for it)"
    return "$EX_NOINPUT"
  fi
  images_fp="$(image_fingerprint "$seq")" || {
    code=$?
    fail "$code" "$name: cannot fingerprint the images of $seq"
    return "$code"
  }
  # The VAR=value pairs and the pipeline's defaults (pipelines/vocab.mk).
  params_fp="$({
    printf '%s\n' "${make_vars[@]}" | sort
    sha256sum <"$REPO/pipelines/vocab.mk"
  } | sha256sum | cut -d' ' -f1)"
  if [[ -f "$fp_file" ]]; then
    old_images="$(sed -n 's/^images //p' "$fp_file")"
    old_params="$(sed -n 's/^params //p' "$fp_file")"
  fi
  if ((!FORCE)) && [[ -f "$published" && "$images_fp" == "$old_images" &&
    "$params_fp" == "$old_params" ]]; then
    log "$name: up to date (images $images_fp unchanged since $published was built)"
    return "$EX_OK"
  fi
  if ((FORCE)); then
    log "$name: --force"
  elif [[ "$images_fp" != "$old_images" ]]; then
    log "$name: images of $seq changed (fingerprint ${old_images:-none} -> $images_fp)"
  else
    log "$name: make variables changed"
  fi
  # make does not see images change: when the features in the work folder
  # were extracted from other images than these (per the fingerprint stored
  # there when that extraction started), redo the pipeline from extraction.
  local work_fp="$WORK_DIR/$name/images.fingerprint"
  if ((FORCE)) || [[ "$images_fp" != "$(cat "$work_fp" 2>/dev/null)" ]]; then
    rm -f "$WORK_DIR/$name/features.h5"
  fi
  if ! mkdir -p "$WORK_DIR/$name" || ! echo "$images_fp" >"$work_fp"; then
    fail "$EX_CANTCREAT" "$name: cannot write $work_fp"
    return "$EX_CANTCREAT"
  fi
  log "$name: rebuilding: make vocab DATASET=$name"
  local start=$SECONDS
  make "${make_args[@]}" vocab DATASET="$name" >>"$LOG_FILE" 2>&1
  code=$?
  if ((code != 0)); then
    fail "$code" "$name: make vocab failed with exit $code; $published is unchanged"
    return "$code"
  fi
  local built="$WORK_DIR/$name/voc.rrv"
  if ! "$VOCAB_TOOL" info "$built" >>"$LOG_FILE" 2>&1; then
    fail 65 "$name: the new $built fails its check; $published is unchanged"
    return 65
  fi
  # A vocabulary equal to the published one (e.g. an image touched, not
  # changed) is not published again: the previous one stays the one before.
  local same=0
  if [[ -f "$published" ]] && cmp -s "$built" "$published"; then
    same=1
  elif [[ -f "$published" ]]; then
    # Keep the published vocabulary as the previous one (hard link, then
    # rename over the old previous: atomic), then rename the new one in.
    local link
    link="$(mktemp -u "$previous.XXXXXX.tmp")"
    if ! { ln "$published" "$link" 2>/dev/null || cp -p "$published" "$link"; } ||
      ! mv -f "$link" "$previous"; then
      rm -f "$link"
      fail "$EX_CANTCREAT" "$name: cannot keep $published as $previous"
      return "$EX_CANTCREAT"
    fi
  fi
  if ((!same)) && ! publish_file "$built" "$published"; then
    fail "$EX_CANTCREAT" "$name: cannot publish $published"
    return "$EX_CANTCREAT"
  fi
  local fp_tmp
  if ! fp_tmp="$(mktemp "$fp_file.XXXXXX.tmp")" ||
    ! printf 'images %s\nparams %s\nsequence %s\nvars %s\nbuilt %s\n' "$images_fp" "$params_fp" \
      "$seq" "${make_vars[*]}" "$(date '+%F %T%z')" >"$fp_tmp" ||
    ! chmod "$FILE_MODE" "$fp_tmp" || ! mv -f "$fp_tmp" "$fp_file"; then
    rm -f "${fp_tmp:-}"
    fail "$EX_CANTCREAT" "$name: cannot write $fp_file"
    return "$EX_CANTCREAT"
  fi
  if ((same)); then
    log "$name: rebuilt in $((SECONDS - start)) s, equal to $published byte for byte: left as it is"
  else
    log "$name: published $published, built in $((SECONDS - start)) s$([[ -f "$previous" ]] &&
      echo "; the one it replaced is $previous")"
  fi
  return "$EX_OK"
}

status=$EX_OK
for name in "${datasets[@]}"; do
  regenerate "$name"
  code=$?
  ((code == 0 || status != 0)) || status=$code
done
rm -f "$LOCK_FILE.pid"
log "done: exit $status"
exit "$status"
