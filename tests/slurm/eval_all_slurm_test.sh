#!/usr/bin/env bash
# e2e/slurm: `make eval-all` through a real Slurm scheduler (issue 15).
#
# Starts a private one-node Slurm cluster on this machine, all of it in a
# temporary folder: munged (its own key and socket), slurmctld and slurmd
# (their own slurm.conf, free high ports, state, spool, PID and log files),
# without systemd, cgroups or an accounting database. Renders eight short
# synthetic sequences with rrslam-synth (four trajectories, two seeds), then
# runs
#   make -j2 eval-all LAUNCHER="srun -N1 -n1 -c1 ..." SKIP_BUILD=1 ...
# and asserts: make exits 0, every sequence has ate.json and the summary
# lists it, and every tool run of the pipelines (extract, cluster, vocab
# build, track, eval ate; 5 per sequence) ran as a Slurm job: LAUNCHER ends in
# a small wrapper that records the job's SLURM_JOB_ID before it execs the
# tool, and slurmctld's log names each of those jobs. Then runs the same
# eval-all without LAUNCHER into other folders and asserts that the two
# summary tables are identical but for the tracking time column (a
# measurement of this machine's load, not a result).
#
# Exits 77 (CTest: skipped) with one line "e2e/slurm: skipped: <why>" when the
# cluster cannot be set up here: not root, Slurm or MUNGE not installed
# (scripts/install-deps.sh installs them), or a daemon does not start or the
# node does not come up. Daemons and jobs are always stopped on exit (the
# daemons by their PIDs; then any process left that carries this run's marker
# variable, e.g. a job step). RRSLAM_SLURM_KEEP=1 keeps the temporary folder.
#
# Usage: eval_all_slurm_test.sh <bin dir with rrslam-*> <source dir>
set -uo pipefail

readonly name="e2e/slurm"
if [[ $# -ne 2 ]]; then
  echo "usage: $0 <bin dir> <source dir>" >&2
  exit 64
fi
bin=$(cd "$1" 2>/dev/null && pwd) || { echo "$name: FAILED: no bin dir $1"; exit 1; }
src=$(cd "$2" 2>/dev/null && pwd) || { echo "$name: FAILED: no source dir $2"; exit 1; }

skip() {
  echo "$name: skipped: $*"
  exit 77
}

# A Slurm job around this test (CI on a cluster) must not leak into the private
# cluster: srun would try to start a step of that job there.
while read -r v; do unset "$v"; done < <(compgen -e | grep '^SLURM_')

# --- Prerequisites -----------------------------------------------------------
[[ $(id -u) -eq 0 ]] || skip "needs root to run slurmd (SlurmUser=root; run as root)"
for tool in munged munge unmunge slurmctld slurmd srun sinfo scontrol scancel make timeout; do
  command -v "$tool" >/dev/null ||
    skip "$tool not found (scripts/install-deps.sh installs slurm-wlm and munge)"
done
for t in synth extract cluster vocab track eval; do
  [[ -x $bin/rrslam-$t ]] || { echo "$name: FAILED: $bin/rrslam-$t is missing"; exit 1; }
done

# The MUNGE socket path must fit in sun_path (108 bytes) and every folder on it
# must be searchable by all (munged checks), so the folder lives in /tmp unless
# TMPDIR is short.
base=${TMPDIR:-/tmp}
[[ ${#base} -le 40 && -d $base ]] || base=/tmp
tmp=$(mktemp -d "$base/rrslam-slurm.XXXXXX") || skip "cannot create a folder in $base"
chmod 711 "$tmp"
readonly tmp conf="$tmp/slurm.conf"
readonly marker="RRSLAM_SLURM_TEST=$tmp"  # in the environment of daemons and jobs
munged_pid="" ctld_pid="" slurmd_pid="" make_pid="" synth_pids=()

# --- Cleanup: always, also on a signal (CTest's timeout) ---------------------
alive() { [[ -n $1 ]] && kill -0 "$1" 2>/dev/null; }

# Sends TERM to each PID, waits up to 10 s for all of them, then KILLs.
stop_pids() {
  local pid left i
  for pid in "$@"; do alive "$pid" && kill -TERM "$pid" 2>/dev/null; done
  for ((i = 0; i < 100; ++i)); do
    left=0
    for pid in "$@"; do alive "$pid" && left=1; done
    [[ $left -eq 0 ]] && break
    sleep 0.1
  done
  for pid in "$@"; do alive "$pid" && kill -KILL "$pid" 2>/dev/null; done
  for pid in "$@"; do [[ -n $pid ]] && wait "$pid" 2>/dev/null; done
  return 0
}

# PIDs of the processes whose environment holds this run's marker.
marked_pids() {
  local e pid
  while read -r e; do
    pid=${e#/proc/}; pid=${pid%/environ}
    [[ $pid -ne $$ ]] && echo "$pid"
  done < <(grep -lsxzF "$marker" /proc/[0-9]*/environ)
  return 0
}

cleanup() {
  local rc=$?
  trap - EXIT TERM INT HUP
  local t_stop=$SECONDS
  stop_pids "$make_pid" "${synth_pids[@]}"
  if alive "$ctld_pid"; then
    SLURM_CONF=$conf timeout 10 scancel --quiet --user="$(id -un)" >/dev/null 2>&1
  fi
  stop_pids "$slurmd_pid"
  stop_pids "$ctld_pid"
  stop_pids "$munged_pid"
  local left
  left=$(marked_pids)
  if [[ -n $left ]]; then
    echo "$name: killing leftover processes: $left"
    # shellcheck disable=SC2086
    kill -KILL $left 2>/dev/null
  fi
  echo "$name: cluster stopped in $((SECONDS - t_stop)) s"
  if [[ ${RRSLAM_SLURM_KEEP:-0} == 1 ]]; then
    echo "$name: kept $tmp"
  else
    rm -rf "$tmp"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 143' TERM INT HUP

# Prints the last lines of each daemon log (on failure, for CTest's output).
show_logs() {
  local f
  for f in "$tmp"/munged.log "$tmp"/slurmctld.log "$tmp"/slurmd.log; do
    [[ -s $f ]] || continue
    echo "---- last lines of $(basename "$f") ----"
    tail -n "${1:-20}" "$f"
  done
}

fail() {
  echo "$name: FAILED: $*"
  show_logs 30
  exit 1
}

# The line of a daemon's log that best says why it stopped: its last fatal
# line, else its last error (other than slurmctld's notes on a first start
# without saved state), else its last line.
why_stopped() {
  local log=$1 why
  why=$(grep -i 'fatal' "$log" 2>/dev/null | tail -n 1)
  [[ -n $why ]] || why=$(grep -i 'error' "$log" 2>/dev/null |
                         grep -viE 'state file|NOTE: Trying backup' | tail -n 1)
  [[ -n $why ]] || why=$(tail -n 1 "$log" 2>/dev/null)
  echo "$why"
}

skip_daemon() {
  local why
  why=$(why_stopped "$2")
  skip "$1 did not start${why:+: $why}"
}

# --- MUNGE: own key and socket ---------------------------------------------------
if ! head -c 1024 /dev/urandom > "$tmp/munge.key" || ! chmod 600 "$tmp/munge.key"; then
  skip "cannot write a MUNGE key"
fi
sock="$tmp/munge.sock"
env "$marker" munged --foreground --force --key-file="$tmp/munge.key" --socket="$sock" \
  --pid-file="$tmp/munged.pid" --seed-file="$tmp/munged.seed" > "$tmp/munged.log" 2>&1 &
munged_pid=$!
for ((i = 0; i < 100; ++i)); do
  [[ -S $sock ]] && break
  alive "$munged_pid" || break
  sleep 0.1
done
munge -n -S "$sock" 2>/dev/null | unmunge -S "$sock" >/dev/null 2>&1 ||
  skip_daemon munged "$tmp/munged.log"

# --- Slurm: one node, this machine ------------------------------------------
host=$(hostname -s 2>/dev/null || hostname)
[[ -n $host ]] || skip "no host name"
# As many CPUs as slurmd finds (more would drain the node), at least 1.
cpus=$(slurmd -C 2>/dev/null | sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' | head -n 1)
[[ $cpus =~ ^[1-9][0-9]*$ ]] || cpus=$(nproc)

# A TCP port in [20000, 60000) that nothing listens on now.
listening_ports() {
  local f _ local_addr state
  for f in /proc/net/tcp /proc/net/tcp6; do
    [[ -r $f ]] || continue
    while read -r _ local_addr _ state _; do
      [[ $state == 0A ]] && echo $((16#${local_addr##*:}))  # 0A: LISTEN
    done < <(tail -n +2 "$f")
  done
}
free_port() {
  local used p
  used=" $(listening_ports | tr '\n' ' ') $* "
  while :; do
    p=$((20000 + (RANDOM * 32768 + RANDOM) % 40000))
    [[ $used == *" $p "* ]] || { echo "$p"; return; }
  done
}

write_conf() {
  local ctld_port=$1 slurmd_port=$2
  mkdir -p "$tmp/state" "$tmp/spool"
  : > "$tmp/plugstack.conf"
  cat > "$conf" <<EOF
# One-node Slurm for tests/slurm/eval_all_slurm_test.sh (written by it).
ClusterName=rrslamtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$tmp/plugstack.conf
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
MailProg=/bin/true
ReturnToService=2
SchedulerType=sched/builtin
InactiveLimit=0
KillWait=5
MinJobAge=300
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
}

node_state() {
  SLURM_CONF=$conf timeout 5 sinfo -h -N -n "$host" -o %T 2>/dev/null | head -n 1
}

# Starts slurmctld and slurmd in the foreground (-D: they log to stderr, which
# goes to slurmctld.log and slurmd.log); waits up to 30 s for the node to be idle.
# Returns 0 when it is; else sets start_failure to why not and returns 2 when a
# port was taken (worth trying others), 1 otherwise.
start_failure=""
start_slurm() {
  : > "$tmp/slurmctld.log"
  : > "$tmp/slurmd.log"
  env "$marker" slurmctld -D -c -f "$conf" >> "$tmp/slurmctld.log" 2>&1 &
  ctld_pid=$!
  env "$marker" slurmd -D -f "$conf" -N "$host" >> "$tmp/slurmd.log" 2>&1 &
  slurmd_pid=$!
  local state="" deadline=$((SECONDS + 30)) reason
  while ((SECONDS < deadline)); do
    if ! alive "$ctld_pid" || ! alive "$slurmd_pid"; then break; fi
    state=$(node_state)
    [[ $state == idle* ]] && return 0
    sleep 0.2
  done
  if ! alive "$ctld_pid"; then
    start_failure="slurmctld did not start: $(why_stopped "$tmp/slurmctld.log")"
  elif ! alive "$slurmd_pid"; then
    start_failure="slurmd did not start: $(why_stopped "$tmp/slurmd.log")"
  else
    reason=$(SLURM_CONF=$conf timeout 5 scontrol show node "$host" 2>/dev/null |
             sed -n 's/.*Reason=\(.*\)/\1/p')
    start_failure="node $host did not become idle within 30 s (state: ${state:-unknown}${reason:+, reason: $reason})"
  fi
  grep -qi 'address already in use' "$tmp/slurmctld.log" "$tmp/slurmd.log" && return 2
  return 1
}

started=1
for _ in 1 2 3; do
  ctld_port=$(free_port)
  write_conf "$ctld_port" "$(free_port "$ctld_port")"
  start_slurm
  started=$?
  [[ $started -eq 0 ]] && break
  stop_pids "$slurmd_pid" "$ctld_pid"
  slurmd_pid="" ctld_pid=""
  [[ $started -eq 2 ]] || break
done
[[ $started -eq 0 ]] || skip "$start_failure"
t_cluster=$SECONDS
echo "$name: one-node Slurm up on $host ($cpus CPUs) in ${t_cluster} s"

# --- Data: eight short synthetic sequences ----------------------------------
# Four trajectories, two seeds (other textures, noise and holes); the shake
# without motion blur, which would make its rendering most of the test's time.
readonly frames=40
sequences=()
mkdir -p "$tmp/data"
for seed in 3 4; do
  for traj in loop sweep rotation shake; do
    sequences+=("$traj-$seed")
    # Side by side, one thread each: rendering is much of the test's time.
    "$bin/rrslam-synth" --quiet --out "$tmp/data/$traj-$seed" --trajectory "$traj" \
      --frames "$frames" --seed "$seed" --motion-blur 0 --threads 1 \
      > "$tmp/synth-$traj-$seed.log" 2>&1 &
    synth_pids+=($!)
  done
done
readonly sequences
for pid in "${synth_pids[@]}"; do
  if ! wait "$pid"; then
    cat "$tmp/synth-"*.log
    fail "rrslam-synth failed"
  fi
done
synth_pids=()
t_synth=$SECONDS

# --- eval-all through srun -------------------------------------------------------
# Each tool runs as `srun ... record-job rrslam-<tool> ...`; record-job notes
# the Slurm job it runs in, then becomes the tool.
cat > "$tmp/record-job" <<EOF
#!/bin/sh
echo "\${SLURM_JOB_ID:-none} \$(basename "\$1")" >> "$tmp/jobs.txt"
exec "\$@"
EOF
chmod 755 "$tmp/record-job"
launcher="srun -N1 -n1 -c1 --export=ALL,$marker $tmp/record-job"
# make gets what is left of the test's time (CTest's TIMEOUT, which kills
# without asking) but 30 s, so that a hanging job still ends in a clean stop
# of the cluster and a report.
make_timeout=$((${RRSLAM_SLURM_TEST_TIMEOUT:-600} - SECONDS - 30))
((make_timeout >= 60)) || make_timeout=60
t0=$SECONDS
# Runs make eval-all into $tmp/eval$1 and $tmp/pipeline$1 with LAUNCHER=$2,
# its output in $tmp/make$1.log, within what is left of make_timeout; fails
# the test when make does.
run_eval_all() {
  local suffix=$1 launch=$2 left=$((make_timeout - (SECONDS - t0)))
  ((left >= 30)) || left=30
  SLURM_CONF=$conf env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL \
    timeout -k 10 "$left" make --no-print-directory -C "$src" -j2 eval-all \
    DATA_ROOT="$tmp/data" EVAL_ROOT="$tmp/eval$suffix" PIPELINE_ROOT="$tmp/pipeline$suffix" \
    BIN="$bin" SKIP_BUILD=1 VOCAB_K=6 VOCAB_L=3 LAUNCHER="$launch" > "$tmp/make$suffix.log" 2>&1 &
  make_pid=$!
  wait "$make_pid"
  local rc=$?
  make_pid=""
  if [[ $rc -ne 0 ]]; then
    echo "---- make eval-all${launch:+ through srun} (exit $rc) ----"
    tail -n 80 "$tmp/make$suffix.log"
    [[ $rc -eq 124 ]] && fail "make eval-all timed out after $left s"
    fail "make eval-all exited with $rc"
  fi
}
run_eval_all "" "$launcher"
t_make=$((SECONDS - t0))
echo "$name: make -j2 eval-all through srun: ${t_make} s (${#sequences[@]} sequences)"

# --- Checks ------------------------------------------------------------------------
errors=0
check() {
  if ! eval "$1"; then
    echo "$name: check failed: $2"
    errors=$((errors + 1))
  fi
}
for s in "${sequences[@]}"; do
  check "[[ -s $tmp/eval/own/$s/ate.json ]]" "no eval/own/$s/ate.json"
  check "grep -q '\"rmse' $tmp/eval/own/$s/ate.json" "eval/own/$s/ate.json has no RMSE"
  check "grep -q '| $s |' $tmp/eval/own/summary.md" "summary.md does not list $s"
done
check "grep -q 'srun -N1 -n1 -c1' $tmp/make.log" "make did not run the tools through srun"

# Every tool run of both pipelines, each in a Slurm job of its own.
expected=(rrslam-extract rrslam-cluster rrslam-vocab rrslam-track rrslam-eval)
touch "$tmp/jobs.txt"
echo "$name: tool runs (Slurm job, tool):"
sed 's/^/  /' "$tmp/jobs.txt"
for t in "${expected[@]}"; do
  n=$(awk -v t="$t" '$2 == t' "$tmp/jobs.txt" | wc -l)
  check "[[ $n -eq ${#sequences[@]} ]]" \
    "$t ran $n times under srun, expected ${#sequences[@]} (one per sequence)"
done
check "! grep -q '^none ' $tmp/jobs.txt" "a tool ran without SLURM_JOB_ID"
runs=$(wc -l < "$tmp/jobs.txt")
jobs=$(awk '{print $1}' "$tmp/jobs.txt" | sort -u | wc -l)
want=$((${#expected[@]} * ${#sequences[@]}))
check "[[ $jobs -eq $runs && $runs -eq $want ]]" \
  "$runs tool runs in $jobs distinct Slurm jobs; expected $want, each in a job of its own"
# slurmctld allocated each of those jobs (its log names the job id).
while read -r id _; do
  [[ $id == none ]] && continue
  check "grep -qE 'JobId=$id( |\$)' $tmp/slurmctld.log" "slurmctld.log never names JobId=$id"
done < "$tmp/jobs.txt"

if [[ $errors -ne 0 ]]; then
  echo "---- make eval-all ----"
  tail -n 60 "$tmp/make.log"
  fail "$errors check(s) failed"
fi

# --- The same evaluation without Slurm: the same table -----------------------
t1=$SECONDS
run_eval_all "-local" ""
t_local=$((SECONDS - t1))
echo "$name: make -j2 eval-all without LAUNCHER: ${t_local} s"
# The table without its last column (tracking median ms: time, not a result).
results_table() {
  awk -F'|' 'BEGIN { OFS = "|" } /^\|/ { NF -= 2; print $0 "|"; next } { print }' "$1"
}
if ! diff <(results_table "$tmp/eval/own/summary.md") \
          <(results_table "$tmp/eval-local/own/summary.md") > "$tmp/summary.diff"; then
  echo "---- summary through srun (<) and local (>) ----"
  cat "$tmp/summary.diff"
  fail "the summary through srun differs from the local run's"
fi
echo "$name: summary tables through srun and local identical but for tracking time:"
sed 's/^/  /' "$tmp/eval/own/summary.md"
echo "$name: passed (cluster up ${t_cluster} s, synth $((t_synth - t_cluster)) s," \
  "eval-all ${t_make} s through srun and ${t_local} s local, total ${SECONDS} s)"
