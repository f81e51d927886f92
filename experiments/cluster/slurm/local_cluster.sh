#!/usr/bin/env bash
# A one-node Slurm cluster on this machine (localhost), for testing the suite's Slurm scripts against
# the real scheduler: Debian's slurm-wlm (slurmctld + slurmd) with munge, run as root, without systemd
# and without cgroups.
#
#   bash experiments/cluster/slurm/local_cluster.sh start    # install if missing, configure, start, wait for the node
#   bash experiments/cluster/slurm/local_cluster.sh status   # daemons, sinfo, squeue
#   bash experiments/cluster/slurm/local_cluster.sh stop     # cancel this cluster's jobs, stop the daemons
#   bash experiments/cluster/slurm/local_cluster.sh env      # prints the export line for the Slurm commands
#
# Every file lives in a scratch folder, $MAPS_SLURM_DIR (default /tmp/maps-slurm): slurm.conf, the munge
# key and socket, the controller's state, slurmd's spool, pid files and logs. Nothing is written to /etc
# (the packages' own install does write /etc/munge/munge.key and the users munge and slurm). The Slurm
# commands find this cluster through SLURM_CONF:
#
#   export SLURM_CONF=/tmp/maps-slurm/etc/slurm.conf   # then sinfo, squeue, sbatch, scontrol as usual
#
# The node is `hostname -s` at 127.0.0.1 with CPUs=`nproc`, RealMemory 90% of MemTotal, in one partition
# `debug` (Default=YES). select/cons_tres with CR_Core: every core is one allocatable unit, so 1-CPU
# array tasks run side by side (nproc of them at once). No cgroups (proctrack/linuxproc, task/none),
# no accounting (accounting_storage/none, jobacct_gather/none; so no sacct): finished jobs stay visible
# to `scontrol show job` for MinJobAge=3600 s, and every finished job gets a line in
# $MAPS_SLURM_DIR/log/jobcomp.txt (jobcomp/filetxt).
#
# start and stop are idempotent. start is a no-op for daemons already running; stop is a no-op when
# nothing runs. Environment: MAPS_SLURM_DIR, MAPS_SLURM_CTLD_PORT (default 6817), MAPS_SLURM_SLURMD_PORT
# (default 6818), MAPS_SLURM_WAIT (seconds to wait for the node to be idle, default 60).
set -euo pipefail

DIR="${MAPS_SLURM_DIR:-/tmp/maps-slurm}"
CTLD_PORT="${MAPS_SLURM_CTLD_PORT:-6817}"
SLURMD_PORT="${MAPS_SLURM_SLURMD_PORT:-6818}"
WAIT_S="${MAPS_SLURM_WAIT:-60}"
CONF="$DIR/etc/slurm.conf"
MUNGE_SOCKET="$DIR/run/munge.socket"
NODE="$(hostname -s)"
export SLURM_CONF="$CONF"

say() { echo "[local_cluster] $*"; }
die() { echo "[local_cluster] ERROR: $*" >&2; exit 1; }

# The last lines of a daemon's log (and of its captured stderr), for error messages.
log_tail() {
  local name=$1 f
  for f in "$DIR/log/$name.log" "$DIR/log/$name.stderr"; do
    if [[ -s $f ]]; then
      echo "---- last lines of $f ----" >&2
      tail -n 25 "$f" >&2
    fi
  done
}

pid_of() { # the pid in $DIR/run/$1.pid if that process is alive, else nothing
  local f="$DIR/run/$1.pid" pid
  [[ -f $f ]] || return 1
  pid="$(tr -dc '0-9' < "$f")"
  [[ -n $pid ]] && kill -0 "$pid" 2>/dev/null || return 1
  echo "$pid"
}

# ---------------------------------------------------------------------------------------------------
install_if_missing() {
  local missing=()
  command -v munged >/dev/null || missing+=(munge)
  [[ -x /usr/sbin/slurmctld ]] || missing+=(slurmctld)
  [[ -x /usr/sbin/slurmd ]] || missing+=(slurmd)
  command -v sbatch >/dev/null || missing+=(slurm-client)
  ((${#missing[@]} == 0)) && return 0
  [[ $(id -u) -eq 0 ]] || die "needs root to install ${missing[*]} (apt-get)"
  say "installing ${missing[*]} (apt-get, --no-install-recommends)"
  # Debian's maintainer scripts would start the daemons through invoke-rc.d; this cluster starts its
  # own, so forbid that while installing (only if no policy is in place already).
  local made_policy=0
  if [[ ! -e /usr/sbin/policy-rc.d ]]; then
    printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d
    chmod 755 /usr/sbin/policy-rc.d
    made_policy=1
  fi
  local rc=0
  {
    if ! apt-cache show slurmctld >/dev/null 2>&1; then apt-get update -q; fi
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
      munge slurmctld slurmd slurm-client
  } || rc=$?
  ((made_policy)) && rm -f /usr/sbin/policy-rc.d
  ((rc == 0)) || die "apt-get install ${missing[*]} failed (exit $rc)"
}

# ---------------------------------------------------------------------------------------------------
write_config() {
  mkdir -p "$DIR"/{etc,run,log,state,spool/slurmd,munge}
  chmod 755 "$DIR" "$DIR"/{etc,run,log,state,spool,spool/slurmd}
  chmod 700 "$DIR/munge"
  local cpus mem_mb real_mb
  cpus="$(nproc)"
  mem_mb="$(awk '/^MemTotal:/ {print int($2 / 1024)}' /proc/meminfo)"
  real_mb=$((mem_mb * 9 / 10))
  cat > "$CONF.tmp" <<EOF
# Written by experiments/cluster/slurm/local_cluster.sh: a one-node test cluster on localhost.
ClusterName=maps-local
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$MUNGE_SOCKET
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool/slurmd
SlurmctldPidFile=$DIR/run/slurmctld.pid
SlurmdPidFile=$DIR/run/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups: processes tracked through /proc, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$DIR/log/jobcomp.txt
MpiDefault=none
MailProg=/bin/true
SwitchType=switch/none
# Every core an allocatable unit: 1-CPU array tasks run side by side.
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
# Jobs whose dependency can never be met (e.g. the array after a failed prepare job) are cancelled
# instead of pending forever.
SchedulerParameters=kill_invalid_depend
# Finished jobs stay in scontrol show job for an hour (there is no sacct without accounting).
MinJobAge=3600
ReturnToService=2
SlurmdParameters=config_overrides
SlurmctldTimeout=60
SlurmdTimeout=120
InactiveLimit=0
KillWait=10
Waittime=0
NodeName=$NODE NodeAddr=127.0.0.1 NodeHostname=$NODE CPUs=$cpus RealMemory=$real_mb State=UNKNOWN
PartitionName=debug Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$CONF.tmp" "$CONF"
  if [[ ! -s $DIR/munge/munge.key ]]; then
    dd if=/dev/urandom of="$DIR/munge/munge.key.tmp" bs=1024 count=1 status=none
    chmod 400 "$DIR/munge/munge.key.tmp"
    mv "$DIR/munge/munge.key.tmp" "$DIR/munge/munge.key"
  fi
}

log_size() { stat -c %s "$DIR/log/$1.log" 2>/dev/null || echo 0; }

# wait_daemon NAME LOG_OFFSET SECONDS COMMAND...: polls COMMAND until it succeeds; fails at once when the
# daemon has logged a fatal error since LOG_OFFSET or its pid file names a dead process.
wait_daemon() {
  local name=$1 offset=$2 secs=$3
  shift 3
  local deadline=$((SECONDS + secs)) f="$DIR/run/$name.pid" fatal
  while ! "$@" >/dev/null 2>&1; do
    fatal="$(tail -c +$((offset + 1)) "$DIR/log/$name.log" 2>/dev/null | grep -m3 -E 'fatal|Unable to bind' || true)"
    if [[ -n $fatal ]] || { [[ -s $f ]] && ! pid_of "$name" >/dev/null; }; then
      log_tail "$name"
      [[ -n $fatal ]] && echo "[local_cluster] $name: $fatal" >&2
      grep -qE "Address already in use|Unable to bind" <<< "$fatal" &&
        echo "[local_cluster] a port is taken (another Slurm?): set MAPS_SLURM_CTLD_PORT / MAPS_SLURM_SLURMD_PORT" >&2
      die "$name exited during start-up"
    fi
    if ((SECONDS >= deadline)); then
      log_tail "$name"
      die "$name does not answer after ${secs}s ($*)"
    fi
    sleep 0.5
  done
}

start_munged() {
  if pid_of munged >/dev/null; then say "munged already running (pid $(pid_of munged))"; return 0; fi
  rm -f "$MUNGE_SOCKET" "$MUNGE_SOCKET.lock"
  say "starting munged"
  # --force: munged as root, with its files in a scratch folder.
  if ! munged --force --key-file="$DIR/munge/munge.key" --socket="$MUNGE_SOCKET" \
      --pid-file="$DIR/run/munged.pid" --log-file="$DIR/log/munged.log" \
      --seed-file="$DIR/munge/munged.seed" 2> "$DIR/log/munged.stderr"; then
    log_tail munged
    die "munged failed to start"
  fi
  wait_daemon munged 0 15 munge --socket="$MUNGE_SOCKET" -n
  munge --socket="$MUNGE_SOCKET" -n | unmunge --socket="$MUNGE_SOCKET" >/dev/null ||
    { log_tail munged; die "munge credential round trip failed"; }
}

start_slurmctld() {
  if pid_of slurmctld >/dev/null; then say "slurmctld already running (pid $(pid_of slurmctld))"; return 0; fi
  say "starting slurmctld"
  local offset
  offset="$(log_size slurmctld)"
  if ! /usr/sbin/slurmctld -f "$CONF" 2> "$DIR/log/slurmctld.stderr"; then
    log_tail slurmctld
    die "slurmctld failed to start"
  fi
  wait_daemon slurmctld "$offset" 30 scontrol ping
}

start_slurmd() {
  if pid_of slurmd >/dev/null; then say "slurmd already running (pid $(pid_of slurmd))"; return 0; fi
  say "starting slurmd (node $NODE)"
  local offset
  offset="$(log_size slurmd)"
  if ! /usr/sbin/slurmd -f "$CONF" -N "$NODE" 2> "$DIR/log/slurmd.stderr"; then
    log_tail slurmd
    die "slurmd failed to start"
  fi
  wait_daemon slurmd "$offset" 15 pid_of slurmd
}

node_state() { sinfo -h -N -n "$NODE" -o '%T' 2>/dev/null | head -n1; }

wait_node_idle() {
  local deadline=$((SECONDS + WAIT_S)) state resumed=0
  while :; do
    state="$(node_state || true)"
    case "$state" in
      idle | mixed | allocated | completing) say "node $NODE is $state"; return 0 ;;
      down* | drain*)
        # A node left down by an earlier run (state kept in $DIR/state): put it back once.
        if ((!resumed)); then
          scontrol update NodeName="$NODE" State=RESUME >/dev/null 2>&1 || true
          resumed=1
        fi
        ;;
    esac
    if ((SECONDS >= deadline)); then
      echo "[local_cluster] node state after ${WAIT_S}s: '${state:-none}'" >&2
      scontrol show node "$NODE" >&2 || true
      log_tail slurmd
      log_tail slurmctld
      die "the node did not become idle"
    fi
    pid_of slurmd >/dev/null || { log_tail slurmd; die "slurmd died while the node was registering"; }
    sleep 1
  done
}

cmd_start() {
  [[ $(id -u) -eq 0 ]] || die "run as root (the daemons run as root: SlurmUser=root)"
  install_if_missing
  if ! pid_of slurmctld >/dev/null && ! pid_of slurmd >/dev/null; then
    write_config
  else
    [[ -f $CONF ]] || die "daemons run but $CONF is missing; stop them first"
  fi
  start_munged
  start_slurmctld
  start_slurmd
  wait_node_idle
  say "ready: export SLURM_CONF=$CONF"
  sinfo
}

cmd_stop() {
  local name pid any=0
  if pid_of slurmctld >/dev/null; then
    # Cancel this cluster's jobs first, so that no job step outlives slurmd.
    local jobs
    jobs="$(squeue -h -o '%A' 2>/dev/null | sort -u | tr '\n' ' ')"
    if [[ -n ${jobs// /} ]]; then
      say "cancelling jobs: $jobs"
      # shellcheck disable=SC2086
      scancel $jobs 2>/dev/null || true
      local deadline=$((SECONDS + 30))
      while [[ -n $(squeue -h -o '%A' 2>/dev/null) ]] && ((SECONDS < deadline)); do sleep 1; done
    fi
  fi
  for name in slurmd slurmctld munged; do
    if pid="$(pid_of "$name")"; then
      any=1
      say "stopping $name (pid $pid)"
      kill -TERM "$pid" 2>/dev/null || true
      local deadline=$((SECONDS + 20))
      while kill -0 "$pid" 2>/dev/null && ((SECONDS < deadline)); do sleep 0.3; done
      if kill -0 "$pid" 2>/dev/null; then
        say "$name (pid $pid) did not stop in 20 s: SIGKILL"
        kill -KILL "$pid" 2>/dev/null || true
      fi
    fi
  done
  ((any)) || say "nothing running"
}

cmd_status() {
  local name pid rc=0
  for name in munged slurmctld slurmd; do
    if pid="$(pid_of "$name")"; then echo "$name: running (pid $pid)"; else echo "$name: not running"; rc=1; fi
  done
  echo "SLURM_CONF=$CONF"
  if ((rc == 0)); then
    sinfo || true
    squeue || true
  fi
  return $rc
}

case "${1:-}" in
  start) cmd_start ;;
  stop) cmd_stop ;;
  status) cmd_status ;;
  env) echo "export SLURM_CONF=$CONF" ;;
  *) echo "usage: $0 start|stop|status|env" >&2; exit 2 ;;
esac
