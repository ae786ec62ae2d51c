#!/usr/bin/env bash
# Runs a tiled frame on a real Slurm cluster of one node: this machine.
#
# Installs Debian's slurm-wlm and munge when missing, starts munged, slurmctld and slurmd directly
# (no systemd; configs, state and logs in a private folder, never /etc), waits until the node is
# idle, submits a job array of TILES tasks (scripts/slurm-tile.sbatch) and a merge job that depends
# on it (scripts/slurm-merge.sbatch), waits for both, checks the merged result against a single
# run, and stops every daemon and job it started on exit, failure and Ctrl-C included.
# Running it again is safe: a run killed too hard to clean up (kill -9) is cleaned up by the next.
#
# Usage: scripts/slurm-local.sh                 runs the farm (settings through the environment)
#        scripts/slurm-local.sh --run CMD...   runs CMD instead, with the cluster up and SLURM_CONF
#                                              exported (e.g. --run bash, to try sbatch by hand)
# Settings:
#   FARM_JOB       raylab (default): `raylab render SCENE --tile auto`, `raylab merge`, and a
#                  byte comparison with a single render; stand-in: each task writes "ID/COUNT" to
#                  part-ID.txt and the merge checks them (to try the scheduler alone)
#   TILES          number of tiles, the array is 0..TILES-1 (default 4)
#   RAYLAB         raylab binary for FARM_JOB=raylab (default: target/release/raylab)
#   SCENE          scene for FARM_JOB=raylab (default: scenes/cornell.toml)
#   CPUS_PER_TILE  CPUs Slurm gives each tile (default 1: on 2 cores, two tiles at a time)
#   WAIT_SECONDS   give up waiting for the jobs after this long (default 600)
#   SLURM_LOCAL_DIR  state folder: configs, munge key and socket, spool, logs
#                  (default ${TMPDIR:-/tmp}/raylab-slurm-UID; wiped at the start of each run)
#   FARM_OUT       folder for the parts and the merged result (default: SLURM_LOCAL_DIR/out);
#                  must hold no part-* files from an earlier run
#   KEEP_STATE     1: keep SLURM_LOCAL_DIR after a successful run (it is always kept on failure)
#   SLURMCTLD_PORT, SLURMD_PORT  TCP ports on 127.0.0.1 (default 6817, 6818)
#   FARM_FAIL_TILE this tile exits 1, to see the failure path (the merge is cancelled, exit 1)
#
# As root (a container, CI) nothing else is needed. As another user: slurm-wlm and munge must be
# installed already (or sudo work without a password), and the jobs run as that same user (slurmd
# cannot switch users without root).
set -euo pipefail

SCRIPTS=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(dirname "$SCRIPTS")
RUN=() # --run CMD...: the command to run on the cluster instead of the farm
case ${1:-} in
  -h | --help) sed -n '2,/^set -euo/{/^set -euo/d;s/^# \{0,1\}//;p}' "$0"; exit 0 ;;
  --run)
    shift
    [ $# -gt 0 ] || { echo "error: --run needs a command" >&2; exit 2; }
    RUN=("$@")
    ;;
  '') ;;
  *) echo "error: unknown argument '$1' (settings go through the environment; see --help)" >&2; exit 2 ;;
esac

# --- What the farm runs. Issue 13 plugs the real commands in here and in the two .sbatch files.
FARM_JOB=${FARM_JOB:-raylab}
TILES=${TILES:-4}
RAYLAB=${RAYLAB:-$REPO/target/release/raylab}
SCENE=${SCENE:-$REPO/scenes/cornell.toml}
CPUS_PER_TILE=${CPUS_PER_TILE:-1}
WAIT_SECONDS=${WAIT_SECONDS:-600}

# --- The cluster.
STATE=${SLURM_LOCAL_DIR:-${TMPDIR:-/tmp}/raylab-slurm-$(id -u)}
FARM_OUT=${FARM_OUT:-$STATE/out}
KEEP_STATE=${KEEP_STATE:-0}
SLURMCTLD_PORT=${SLURMCTLD_PORT:-6817}
SLURMD_PORT=${SLURMD_PORT:-6818}
USER_NAME=$(id -un)
MARKER=.raylab-slurm-local # marks a state folder as this script's, so only such a folder is wiped
DAEMONS=(slurmd slurmctld munged) # in stopping order
export SLURM_CONF=$STATE/etc/slurm.conf

say() { printf '[%4ds] %s\n' "$SECONDS" "$*"; }
die() { echo "error: $*" >&2; exit 1; }
is_count() { case $1 in '' | *[!0-9]* | 0*) return 1 ;; esac; }

check_settings() {
  is_count "$TILES" || die "TILES='$TILES' is not a positive integer"
  is_count "$CPUS_PER_TILE" || die "CPUS_PER_TILE='$CPUS_PER_TILE' is not a positive integer"
  is_count "$WAIT_SECONDS" || die "WAIT_SECONDS='$WAIT_SECONDS' is not a positive integer"
  case $STATE in /*) ;; *) die "SLURM_LOCAL_DIR must be an absolute path" ;; esac
  case $FARM_OUT in /*) ;; *) die "FARM_OUT must be an absolute path (the jobs run elsewhere)" ;; esac
  case $FARM_JOB in
    stand-in) ;;
    raylab)
      [ -x "$RAYLAB" ] || die "RAYLAB=$RAYLAB is not an executable (build it: cargo build --release --features mesh,bvh,exr)"
      [ -f "$SCENE" ] || die "SCENE=$SCENE is not a file"
      # The jobs run in FARM_OUT, so relative paths would point elsewhere there.
      RAYLAB=$(realpath -e "$RAYLAB") SCENE=$(realpath -e "$SCENE")
      "$RAYLAB" render --help | grep -q -- '--tile' ||
        die "$RAYLAB has no 'render --tile' (an old build? rebuild it with --features exr); FARM_JOB=stand-in runs without raylab"
      ;;
    *) die "FARM_JOB='$FARM_JOB' is neither stand-in nor raylab" ;;
  esac
}

install_packages() {
  local missing=()
  for tool in munged munge slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
    command -v "$tool" >/dev/null || missing+=("$tool")
  done
  [ ${#missing[@]} = 0 ] && return 0
  say "installing slurm-wlm and munge (missing: ${missing[*]})"
  local sudo=""
  if [ "$(id -u)" != 0 ]; then
    sudo -n true 2>/dev/null || die "${missing[*]} missing: install slurm-wlm and munge as root first"
    sudo="sudo -n"
  fi
  command -v apt-get >/dev/null || die "${missing[*]} missing and no apt-get: install Slurm and MUNGE"
  $sudo apt-get update -qq
  # The packages' own services are not started in a container (policy-rc.d); on a machine with
  # systemd they would be, on the system's /etc/slurm config: ours uses its own ports and socket.
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
    slurm-wlm munge >/dev/null
}

# The pid of DAEMON from its pid file in STATE, if that process is still that daemon.
daemon_pid() {
  local pid
  pid=$(cat "$STATE/run/$1.pid" 2>/dev/null) || return 1
  case $pid in '' | *[!0-9]*) return 1 ;; esac
  [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$1" ] || return 1
  echo "$pid"
}

# Stops the daemons recorded in STATE's pid files (TERM, then KILL after 10 s), by pid only.
stop_daemons() {
  local name pid
  for name in "${DAEMONS[@]}"; do
    pid=$(daemon_pid "$name") || continue
    kill -TERM "$pid" 2>/dev/null || continue
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
      say "$name ($pid) ignored SIGTERM for 10 s: SIGKILL"
      kill -KILL "$pid" 2>/dev/null || true
    fi
  done
}

# Cancels every job of this private cluster and waits (20 s at most) until none is left.
cancel_jobs() {
  [ -n "$(daemon_pid slurmctld)" ] || return 0
  scancel --user="$USER_NAME" 2>/dev/null || return 0
  for _ in $(seq 40); do
    [ -z "$(squeue -h -o %i 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  say "jobs still listed after 20 s: $(squeue -h -o '%i %T' | tr '\n' ' ')"
}

CLEANUP_ARMED=0
cleanup() {
  local rc=$?
  set +e
  trap - EXIT INT TERM
  [ "$CLEANUP_ARMED" = 1 ] || exit "$rc"
  say "tearing down"
  cancel_jobs
  stop_daemons
  if [ "$rc" != 0 ]; then
    # The daemons' logs (their .out only where the .log is empty: a failure before logging).
    for log in "$STATE"/log/*.log "$STATE"/log/slurm*.out; do
      [ -s "$log" ] || continue
      case $log in *.out) [ -s "${log%.out}.log" ] && continue ;; esac
      echo "--- last lines of $log"
      tail -n 5 "$log"
    done
    say "failed (exit $rc); state and logs kept in $STATE"
  elif [ "$KEEP_STATE" = 1 ]; then
    say "state and logs kept in $STATE"
  else
    rm -rf "$STATE"
  fi
  exit "$rc"
}

# Makes STATE afresh: stops what a killed earlier run left behind, wipes its folder.
fresh_state() {
  if [ -e "$STATE" ]; then
    [ -e "$STATE/$MARKER" ] ||
      die "$STATE exists and was not made by this script: remove it or set SLURM_LOCAL_DIR"
    if compgen -G "$STATE/run/*.pid" >/dev/null; then
      say "stopping what an earlier run left in $STATE"
      [ -f "$SLURM_CONF" ] && cancel_jobs
      stop_daemons
    fi
    rm -rf "$STATE"
  fi
  mkdir -p "$STATE"/{etc,run,log,ctld,slurmd}
  touch "$STATE/$MARKER"
  # munged wants its socket folder searchable by all (any user's job talks to it), not writable.
  install -d -m 0755 "$STATE/munge"
  mkdir -p "$FARM_OUT"
  if compgen -G "$FARM_OUT/part-*" >/dev/null; then
    die "$FARM_OUT holds part-* files of an earlier run: remove them or choose another FARM_OUT"
  fi
}

port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

start_munge() {
  local sock=$STATE/munge/munge.socket
  # A fresh key for this cluster alone; munged refuses a key that others can read.
  (umask 077 && head -c 1024 /dev/urandom >"$STATE/etc/munge.key")
  munged --key-file="$STATE/etc/munge.key" --socket="$sock" --pid-file="$STATE/run/munged.pid" \
    --log-file="$STATE/log/munged.log" --seed-file="$STATE/munge/munged.seed" 9>&- ||
    die "munged did not start (see $STATE/log/munged.log)"
  munge -n -S "$sock" | unmunge -S "$sock" >/dev/null || die "munge cannot decode its own credential"
}

write_config() {
  local node_line node
  # The node as slurmd sees it (name, CPUs, sockets, cores, memory); its address is loopback, so
  # the machine's hostname need not resolve.
  node_line=$(slurmd -C | head -n 1)
  node=$(sed -n 's/^NodeName=\([^ ]*\).*/\1/p' <<<"$node_line")
  [ -n "$node" ] || die "slurmd -C did not describe this node: $node_line"
  NODE=$node
  cat >"$SLURM_CONF" <<EOF
# Written by scripts/slurm-local.sh: a one-node cluster on this machine, for testing.
ClusterName=raylab-local
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$SLURMCTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=$USER_NAME
SlurmdUser=$USER_NAME
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$STATE/munge/munge.socket
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/slurmd
SlurmctldPidFile=$STATE/run/slurmctld.pid
SlurmdPidFile=$STATE/run/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups or systemd in a container: processes are tracked through /proc, tasks not pinned.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
# Start waiting tiles as soon as CPUs free up (the default may wait 3 s to batch them).
SchedulerParameters=batch_sched_delay=0
# Tiles share the node by CPU (each asks for CPUS_PER_TILE); memory is not a consumable here.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
KillWait=5
MailProg=/bin/true
$node_line NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
}

# Starts DAEMON in the foreground mode (-D) in the background; fails if it dies at once.
start_daemon() {
  local name=$1
  shift
  "$name" -D "$@" >"$STATE/log/$name.out" 2>&1 9>&- &
  local pid=$!
  for _ in $(seq 50); do
    kill -0 "$pid" 2>/dev/null || die "$name exited at start (see $STATE/log/$name.out and $name.log)"
    [ "$(daemon_pid "$name")" = "$pid" ] && return 0
    sleep 0.1
  done
  die "$name wrote no pid file in 5 s"
}

wait_node_idle() {
  local state=""
  for _ in $(seq 120); do
    state=$(sinfo -h -N -n "$NODE" -o %T 2>/dev/null || true)
    [ "$state" = idle ] && return 0
    sleep 0.5
  done
  die "node $NODE is '${state:-not reported}' after 60 s: $(scontrol show node "$NODE" | grep -i reason)"
}

# The state of every task of array job ID, one "ID_TASK STATE EXIT" line each (from slurmctld,
# which keeps finished jobs for MinJobAge, 300 s; there is no accounting database here).
array_states() {
  scontrol -o show job "$1" | sed -n 's/.*JobId=\([0-9]*\).*ArrayJobId=\([0-9]*\) ArrayTaskId=\([0-9]*\).*JobState=\([A-Z_]*\).*ExitCode=\([0-9:]*\).*/\2_\3 \4 \5/p' | sort -t_ -k2 -n
}

job_state() { scontrol -o show job "$1" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1; }

run_farm() {
  export FARM_JOB FARM_OUT TILES RAYLAB SCENE
  local array merge
  array=$(sbatch --parsable --array="0-$((TILES - 1))" --cpus-per-task="$CPUS_PER_TILE" \
    --chdir="$FARM_OUT" --output="$STATE/log/tile-%A_%a.out" "$SCRIPTS/slurm-tile.sbatch")
  merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --chdir="$FARM_OUT" --output="$STATE/log/merge-%j.out" "$SCRIPTS/slurm-merge.sbatch")
  say "submitted array job $array (tasks 0-$((TILES - 1))) and merge job $merge (afterok:$array)"

  local last="" now deadline=$((SECONDS + WAIT_SECONDS))
  while :; do
    now=$(squeue -h -j "$array,$merge" -o '%i:%t' 2>/dev/null | sort -t_ -k2 -n | tr '\n' ' ' || true)
    [ -z "$now" ] && break
    [ "$now" != "$last" ] && say "queue: $now"
    last=$now
    [ "$SECONDS" -lt "$deadline" ] || die "jobs not done after $WAIT_SECONDS s"
    sleep 0.5
  done

  local states failed merge_state
  states=$(array_states "$array")
  say "array tasks (job_task state exit):"
  # shellcheck disable=SC2001 # (indents every line)
  sed 's/^/         /' <<<"$states"
  echo "--- log of task 0 ($STATE/log/tile-${array}_0.out):"
  cat "$STATE/log/tile-${array}_0.out"
  failed=$(awk '$2 != "COMPLETED" { sub(/.*_/, "", $1); print $1 }' <<<"$states" | tr '\n' ' ')
  for task in $failed; do
    echo "--- log of failed task $task:"
    cat "$STATE/log/tile-${array}_$task.out" 2>/dev/null
  done
  merge_state=$(job_state "$merge")
  if [ -f "$STATE/log/merge-$merge.out" ]; then
    echo "--- log of the merge job:"
    cat "$STATE/log/merge-$merge.out"
  fi
  [ -z "$failed" ] || die "tiles failed: $failed(merge job $merge ${merge_state:-gone})"
  [ "$merge_state" = COMPLETED ] || die "merge job $merge ended ${merge_state:-unknown}"
  compare_with_single_run
}

# The check that the farm changed nothing: the merged result against one undivided run.
compare_with_single_run() {
  case $FARM_JOB in
    stand-in)
      local expected=$FARM_OUT/single.txt
      for ((i = 0; i < TILES; i++)); do echo "$i/$TILES"; done >"$expected"
      cmp "$FARM_OUT/merged.txt" "$expected" || die "merged.txt differs from $expected"
      say "merged.txt lists all $TILES tiles in order: $(tr '\n' ' ' <"$FARM_OUT/merged.txt")"
      ;;
    raylab)
      # --- One render of the whole frame, same scene and settings; PFM so that only
      # --- pixels are compared (EXR headers carry the share of each file).
      "$RAYLAB" render "$SCENE" -q -o "$FARM_OUT/single.pfm"
      cmp "$FARM_OUT/merged.pfm" "$FARM_OUT/single.pfm" ||
        die "the merged image differs from a single render"
      say "merged image is byte-identical to a single render ($FARM_OUT/merged.pfm)"
      ;;
  esac
}

main() {
  check_settings
  install_packages
  # One run at a time on a state folder; the lock dies with the process, however it ends.
  mkdir -p "$(dirname "$STATE")"
  exec 9>"$STATE.lock"
  # (-w 5: a killed run's last child, e.g. a sleep, may hold it a moment longer)
  flock -w 5 9 || die "another slurm-local.sh is running on $STATE"
  fresh_state
  CLEANUP_ARMED=1
  trap cleanup EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM
  for port in "$SLURMCTLD_PORT" "$SLURMD_PORT"; do
    port_free "$port" || die "port $port on 127.0.0.1 is taken: set SLURMCTLD_PORT/SLURMD_PORT"
  done
  say "Slurm $(slurmctld -V | cut -d' ' -f2), MUNGE $(munged --version | cut -d' ' -f1 | cut -d- -f2); state in $STATE"
  start_munge
  write_config
  say "starting slurmctld and slurmd (node $NODE, ports $SLURMCTLD_PORT/$SLURMD_PORT)"
  start_daemon slurmctld -c -f "$SLURM_CONF"
  start_daemon slurmd -f "$SLURM_CONF" -N "$NODE"
  wait_node_idle
  say "node $NODE idle: $(sinfo -h -N -n "$NODE" -o '%c CPUs, %m MB')"
  if [ ${#RUN[@]} -gt 0 ]; then
    say "running ${RUN[*]} (SLURM_CONF=$SLURM_CONF)"
    "${RUN[@]}"
    return
  fi
  run_farm
  say "done: $TILES tiles, merged and checked, in ${SECONDS} s"
}

main
