#!/usr/bin/env bash
# A real single-node Slurm cluster on this machine, from Debian's packages,
# for the campaign runner's integration test (`campaign submit --slurm`) and
# for CI (.ci/run runs as root on a fresh Debian 12 machine, so the script
# installs what it needs itself).
#
#   eval "$(scripts/slurm-local.sh start)"   # install if needed, start, wait for the node
#   scripts/slurm-local.sh status            # sinfo; exit 0 if the controller answers
#   scripts/slurm-local.sh env               # the export line again
#   scripts/slurm-local.sh stop              # stop the daemons this script started
#
# Must run as root. `start` prints exactly one line on stdout,
# `export SLURM_CONF=...`, for the caller to eval; everything else goes to
# stderr. It is idempotent: with the daemons already running it only checks
# that the node answers.
#
# Choices:
# - Everything of the cluster lives in one directory, $POLARNAV_SLURM_DIR
#   (default /var/tmp/polarnav-slurm): slurm.conf, controller state, slurmd
#   spool, logs, pid files. `stop` keeps it (queued/finished job records
#   survive a restart); `rm -rf` it after `stop` for a clean slate.
# - The configuration is $POLARNAV_SLURM_DIR/slurm.conf, found by the daemons
#   and the clients through SLURM_CONF, not /etc/slurm/slurm.conf: outside
#   that directory only the packages and munge's files (/etc/munge/munge.key,
#   /run/munge) are touched, and Debian's slurmctld/slurmd systemd units
#   (ConditionPathExists=/etc/slurm/slurm.conf) stay inert on a machine run
#   by systemd, so there is never a second set of daemons. The cost:
#   whoever calls sbatch/squeue/scontrol needs SLURM_CONF in its environment
#   (hence the eval line); batch jobs inherit it.
# - Daemons are started directly, each daemonizing itself, never through
#   systemctl/invoke-rc.d: PID 1 need not be systemd (on the machines this was
#   written on it is a Firecracker init, /process_api; Docker-style images
#   also have a policy-rc.d that forbids starting services from packages).
# - No cgroups: ProctrackType=proctrack/linuxproc, TaskPlugin=task/none,
#   JobAcctGatherType=jobacct_gather/none, no cgroup.conf (Slurm 22.05's
#   slurmd does not ask for one then; 22.05 has no CgroupPlugin=disabled).
#   The CI machines, like the one this was written on, are Firecracker VMs
#   built from a Docker image, without systemd, with a hybrid hierarchy:
#   cgroup v1 controllers (writable by root) plus a v2 "unified" mount
#   holding only hugetlb. Slurm's cgroup/v2
#   plugin wants a real unified hierarchy (and systemd), cgroup/v1 is
#   deprecated; how cgroups are mounted differs between VMs, containers and
#   laptops, and a throwaway test cluster needs no confinement. So nothing
#   here depends on them. Consequence: a job is not confined to the CPUs it
#   was given (nproc in a 1-CPU task says 2: use SLURM_CPUS_PER_TASK), no
#   memory limits, and a job's processes are tracked by parent PID.
# - SelectType=select/cons_tres with CR_Core and CPUs=$(nproc), no sockets/
#   cores/threads: slurmctld then counts every CPU as one core (even with
#   hyperthreads), so a 2-CPU machine runs two 1-CPU tasks at once.
#   Memory is not a consumable resource (jobs need not ask for --mem).
# - No accounting storage (no slurmdbd/MySQL), so sacct has nothing to read.
#   Finished jobs stay visible to `squeue -t all` / `scontrol show job` for
#   MinJobAge=3600 s, and every finished job or array task is appended to
#   the job-completion log $POLARNAV_SLURM_DIR/log/jobcomp.log (jobcomp/filetxt,
#   one line with JobId=... JobState=CANCELLED|COMPLETED|FAILED... ExitCode=...
#   ArrayJobId=... ArrayTaskId=...; 22.05's `sacct -c` cannot parse the
#   Array* fields). An array task cancelled while still PENDING leaves no
#   trace anywhere: it is just gone from the array.
# - SlurmctldHost and NodeAddr carry 127.0.0.1 explicitly, so the cluster
#   does not depend on the host name resolving; the node's name must still
#   be `hostname -s` (slurmd identifies its node by it).
# - munged: an already working munged (e.g. the system's) is used as is;
#   otherwise one is started as user munge on the default socket, key
#   /etc/munge/munge.key (created if missing), and stopped again by `stop`.
set -euo pipefail

DIR=${POLARNAV_SLURM_DIR:-/var/tmp/polarnav-slurm}
CONF=$DIR/slurm.conf
RUN=$DIR/run
LOGS=$DIR/log
MUNGE_DIR=$DIR/munge
MUNGE_KEY=/etc/munge/munge.key
START_TIMEOUT=${POLARNAV_SLURM_TIMEOUT:-60}
export SLURM_CONF=$CONF
# The daemons live in /usr/sbin, not always on a CI user's PATH.
export PATH=$PATH:/usr/sbin:/sbin

say() { echo "slurm-local: $*" >&2; }
die() { echo "slurm-local: error: $*" >&2; exit 1; }

usage() {
  echo "usage: $0 start|stop|status|env   (directory: \$POLARNAV_SLURM_DIR, now $DIR)" >&2
  exit 2
}

# alive PID: the process exists and is not a zombie. (Where PID 1 is not a
# real init, daemons' exited intermediate processes and killed daemons can
# stay zombies for a while: /proc/PID and `kill -0` are not enough.)
alive() {
  local st
  st=$(sed 's/.*) //' "/proc/$1/stat" 2>/dev/null | cut -d' ' -f1) || return 1
  [ -n "$st" ] && [ "$st" != Z ] && [ "$st" != X ]
}

# pid_of NAME PIDFILE: prints the pid if PIDFILE names a live process called NAME.
pid_of() {
  local pid
  [ -s "$2" ] || return 1
  pid=$(<"$2")
  [[ $pid =~ ^[0-9]+$ ]] || return 1
  [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$1" ] || return 1
  alive "$pid" || return 1
  echo "$pid"
}

# other_pid NAME: prints the pid of a live process called NAME, if any.
other_pid() {
  local pid
  for pid in $(pgrep -x "$1" || true); do
    alive "$pid" && { echo "$pid"; return 0; }
  done
  return 1
}

munge_works() { munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; }

node_name() { hostname -s 2>/dev/null || hostname | cut -d. -f1; }

show_logs() {
  local f
  for f in "$LOGS/slurmctld.log" "$LOGS/slurmd.log" "$MUNGE_DIR/munged.log"; do
    [ -f "$f" ] || continue
    # Without Debian's libpmix2 (not needed: MpiDefault=none) every start
    # logs six harmless "error: ... pmix ..." lines: left out here.
    echo "---- last lines of $f" >&2
    grep -v -e 'mpi/pmix' -e 'MPI: Cannot create context' "$f" | tail -n 25 >&2 || true
  done
}

fail() { say "error: $*"; show_logs; exit 1; }

install_packages() {
  local missing=() b
  for b in slurmctld slurmd sbatch sinfo squeue scontrol scancel munged munge unmunge; do
    command -v "$b" >/dev/null || missing+=("$b")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  say "installing slurm-wlm and munge (missing: ${missing[*]})"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >&2 || die "apt-get update failed"
  # --no-install-recommends: slurm-wlm-basic-plugins recommends
  # slurm-wlm-plugins (HDF5, PMIx, ... plugins) that this cluster never loads.
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null \
    || die "apt-get install slurm-wlm munge failed"
  for b in "${missing[@]}"; do
    command -v "$b" >/dev/null || die "$b still missing after installing slurm-wlm and munge"
  done
}

start_munge() {
  if munge_works; then
    if pid_of munged "$MUNGE_DIR/munged.pid" >/dev/null; then
      say "munged already running (pid $(<"$MUNGE_DIR/munged.pid"))"
    else
      say "using the munged already running on this machine"
    fi
    return 0
  fi
  id munge >/dev/null 2>&1 || die "user munge does not exist (the munge package creates it)"
  install -d -o munge -g munge -m 0700 /etc/munge /var/lib/munge /var/log/munge "$MUNGE_DIR"
  # The socket's directory must be reachable by every client (sbatch, slurmd).
  install -d -o munge -g munge -m 0755 /run/munge
  if [ ! -s "$MUNGE_KEY" ]; then
    say "creating munge key $MUNGE_KEY"
    if command -v mungekey >/dev/null; then
      mungekey --create --keyfile="$MUNGE_KEY" || die "mungekey --create failed"
    else
      dd if=/dev/urandom of="$MUNGE_KEY" bs=1024 count=1 status=none || die "writing $MUNGE_KEY failed"
    fi
  fi
  # munged refuses a key readable or writable by anyone but its owner.
  chown munge:munge "$MUNGE_KEY"
  chmod 0400 "$MUNGE_KEY"
  rm -f "$MUNGE_DIR/munged.pid"
  say "starting munged"
  runuser -u munge -- munged --pid-file="$MUNGE_DIR/munged.pid" \
    --log-file="$MUNGE_DIR/munged.log" </dev/null >>"$LOGS/munged.out" 2>&1 \
    || { cat "$LOGS/munged.out" >&2; fail "munged failed to start"; }
  for _ in $(seq 50); do
    munge_works && return 0
    sleep 0.2
  done
  fail "munged started but 'munge -n | unmunge' does not work"
}

write_conf() {
  local node cpus mem_mb margin tmp
  node=$(node_name)
  [ -n "$node" ] || die "cannot determine the host name (hostname -s)"
  cpus=$(nproc)
  mem_mb=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo)
  [ -n "$mem_mb" ] || die "cannot read MemTotal from /proc/meminfo"
  # slurmd drains a node that has less memory than RealMemory says: leave
  # 5 % (at least 512 MB) for rounding and what the kernel keeps.
  margin=$(( mem_mb / 20 > 512 ? mem_mb / 20 : 512 ))
  mem_mb=$(( mem_mb > margin ? mem_mb - margin : 1 ))
  tmp=$CONF.new
  cat >"$tmp" <<EOF
# Written by scripts/slurm-local.sh (polarnav): a single-node test cluster on
# $node. Regenerated by 'start' when no daemon of it runs; edits are lost.
ClusterName=polarnav-local
SlurmctldHost=$node(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
# No mail (Debian has no /usr/bin/mail by default: slurmctld logs an error).
MailProg=/bin/true
# No cgroups (see the script's header).
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$LOGS/jobcomp.log
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
MinJobAge=3600
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$RUN/slurmctld.pid
SlurmdPidFile=$RUN/slurmd.pid
SlurmctldLogFile=$LOGS/slurmctld.log
SlurmdLogFile=$LOGS/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=campaign Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$tmp" "$CONF"
}

# start_daemon NAME: starts slurmctld or slurmd unless its pid file names a
# live one; refuses if one not started by this script is running.
start_daemon() {
  local name=$1 pidfile=$RUN/$1.pid pid
  if pid=$(pid_of "$name" "$pidfile"); then
    say "$name already running (pid $pid)"
    return 0
  fi
  if pid=$(other_pid "$name"); then
    fail "a $name not started by this script runs (pid $pid); stop it first"
  fi
  say "starting $name"
  "$name" -f "$CONF" </dev/null >>"$LOGS/$name.out" 2>&1 \
    || { cat "$LOGS/$name.out" >&2; fail "$name failed to start"; }
  for _ in $(seq 50); do
    pid_of "$name" "$pidfile" >/dev/null && return 0
    sleep 0.2
  done
  cat "$LOGS/$name.out" >&2
  fail "$name exited right after starting (no live pid in $pidfile)"
}

wait_idle() {
  local node=$1 deadline=$((SECONDS + START_TIMEOUT)) state="" last_resume=-100
  while [ $SECONDS -lt $deadline ]; do
    state=$(sinfo -h -n "$node" -o %T 2>/dev/null | head -n 1) || state=""
    case $state in
      idle | mixed | allocated | completing)
        say "node $node is $state ($((SECONDS - t0)) s)"
        return 0
        ;;
      down* | drain* | fail*)
        if [ $((SECONDS - last_resume)) -ge 5 ]; then
          say "node $node is $state: resuming it"
          scontrol update nodename="$node" state=resume >&2 || true
          last_resume=$SECONDS
        fi
        ;;
    esac
    sleep 1
  done
  sinfo -R >&2 || true
  fail "node $node not idle after ${START_TIMEOUT} s (last state: '${state:-no answer}')"
}

cmd_start() {
  [ "$(id -u)" -eq 0 ] || die "must run as root (slurmd runs jobs as their submitters)"
  t0=$SECONDS
  install_packages
  mkdir -p "$DIR" "$RUN" "$LOGS" "$DIR/state" "$DIR/spool"
  chmod 0755 "$DIR" "$RUN" "$LOGS"
  chmod 0700 "$DIR/state" "$DIR/spool"
  start_munge
  if pid_of slurmctld "$RUN/slurmctld.pid" >/dev/null || pid_of slurmd "$RUN/slurmd.pid" >/dev/null; then
    [ -f "$CONF" ] || fail "daemons run but $CONF is gone: run '$0 stop' first"
  else
    write_conf
  fi
  start_daemon slurmctld
  start_daemon slurmd
  wait_idle "$(node_name)"
  echo "export SLURM_CONF=$CONF"
}

# stop_daemon NAME PIDFILE
stop_daemon() {
  local name=$1 pidfile=$2 pid
  if ! pid=$(pid_of "$name" "$pidfile"); then
    rm -f "$pidfile"
    return 0
  fi
  say "stopping $name (pid $pid)"
  kill -TERM "$pid" 2>/dev/null || true
  for _ in $(seq 100); do
    alive "$pid" || break
    sleep 0.2
  done
  if alive "$pid"; then
    say "$name (pid $pid) ignored SIGTERM for 20 s: killing it"
    kill -KILL "$pid" 2>/dev/null || true
  fi
  rm -f "$pidfile"
}

cmd_stop() {
  [ "$(id -u)" -eq 0 ] || die "must run as root"
  # Running jobs' slurmstepd processes outlive slurmd and are picked up again
  # by the next start; `scancel` them first for a clean stop.
  stop_daemon slurmd "$RUN/slurmd.pid"
  stop_daemon slurmctld "$RUN/slurmctld.pid"
  stop_daemon munged "$MUNGE_DIR/munged.pid"
}

cmd_status() {
  local rc=0
  command -v sinfo >/dev/null || { say "sinfo not installed"; return 1; }
  [ -f "$CONF" ] || { say "no $CONF: never started"; return 1; }
  timeout 20 sinfo || rc=1
  [ $rc -eq 0 ] || say "the controller does not answer"
  return $rc
}

case ${1:-} in
  start) cmd_start ;;
  stop) cmd_stop ;;
  status) cmd_status ;;
  env) echo "export SLURM_CONF=$CONF" ;;
  *) usage ;;
esac
