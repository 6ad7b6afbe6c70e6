#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for trying `mapbench submit` on a laptop and
# for CI's live-cluster test (harness/tests/slurm.rs).
#
#   scripts/slurm/local_cluster.sh up       install slurm-wlm and munge when missing, write a
#                                           one-node slurm.conf (cores and memory of this
#                                           machine), start munged, slurmctld and slurmd, and
#                                           wait until the node is idle
#   scripts/slurm/local_cluster.sh status   which daemons run, and sinfo
#   scripts/slurm/local_cluster.sh down     stop the daemons `up` started (only those)
#
# Needs root (or sudo). `up` is idempotent: daemons already running are left as they are.
# A slurm.conf that this script did not write is never replaced: the script refuses, so a
# real cluster's configuration is safe.
#
# The configuration suits a container or VM without systemd or cgroup delegation:
# ProctrackType=proctrack/linuxproc, TaskPlugin=task/none and a cgroup.conf of
# CgroupPlugin=cgroup/v1 with no constraints (Slurm 22.05 has no `disabled` plugin).
set -euo pipefail

CONF_DIR=/etc/slurm
MARK="# written by mapbench scripts/slurm/local_cluster.sh"
STATE_DIR=/run/mapbench-local-cluster
WAIT_S=${LOCAL_CLUSTER_WAIT_S:-60}

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

say() { echo "local_cluster: $*" >&2; }
die() { say "$*"; exit 1; }

running() { pgrep -x "$1" >/dev/null 2>&1; }

# The daemons live in /usr/sbin, which a user's PATH may lack.
have() { command -v "$1" >/dev/null 2>&1 || [ -x "/usr/sbin/$1" ]; }

# Where each daemon writes its pid (slurm.conf below and munged's default).
pidfile() {
  case "$1" in
    munged) echo /run/munge/munged.pid ;;
    slurmctld) echo /run/slurmctld.pid ;;
    slurmd) echo /run/slurmd.pid ;;
  esac
}

install_packages() {
  local missing=()
  have slurmctld || missing+=(slurmctld slurmd slurm-client)
  have munged || missing+=(munge)
  if [ ${#missing[@]} -gt 0 ]; then
    say "installing ${missing[*]} (apt)"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
}

# The node line as slurmd sees this machine (CPUs, sockets, cores, threads, memory).
node_line() {
  local detected
  detected=$($SUDO slurmd -C | head -n 1)
  case "$detected" in
    NodeName=*) ;;
    *) die "slurmd -C printed no node line: $detected" ;;
  esac
  # The node is named as slurmd names itself (the short host name).
  echo "$detected State=UNKNOWN"
}

write_config() {
  local host node
  host=$(hostname -s)
  local f
  for f in slurm.conf cgroup.conf; do
    if [ -f "$CONF_DIR/$f" ] && ! grep -qF "$MARK" "$CONF_DIR/$f"; then
      die "$CONF_DIR/$f exists and was not written by this script: not replacing it"
    fi
  done
  node=$(node_line)
  $SUDO mkdir -p "$CONF_DIR" /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
  $SUDO tee "$CONF_DIR/slurm.conf" >/dev/null <<EOF
$MARK
ClusterName=mapbench-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
# A job's processes get SIGTERM, then SIGKILL this many seconds later.
KillWait=30
$node
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  $SUDO tee "$CONF_DIR/cgroup.conf" >/dev/null <<EOF
$MARK
CgroupPlugin=cgroup/v1
ConstrainCores=no
ConstrainRAMSpace=no
ConstrainSwapSpace=no
ConstrainDevices=no
EOF
}

start_munge() {
  if running munged; then
    return
  fi
  $SUDO mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
  if [ ! -s /etc/munge/munge.key ]; then
    say "creating /etc/munge/munge.key"
    $SUDO dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
  fi
  $SUDO chown munge:munge /etc/munge /etc/munge/munge.key /var/lib/munge /var/log/munge /run/munge
  $SUDO chmod 0700 /etc/munge
  $SUDO chmod 0400 /etc/munge/munge.key
  $SUDO runuser -u munge -- munged
  remember munged
}

# Note a daemon `up` started, with the pid from its pid file, so `down` stops that process.
remember() {
  local name=$1 pid="" i
  for ((i = 0; i < 40; i++)); do
    pid=$($SUDO cat "$(pidfile "$name")" 2>/dev/null || true)
    [ -n "$pid" ] && break
    sleep 0.25
  done
  [ -n "$pid" ] || die "$name started but wrote no pid file ($(pidfile "$name"))"
  echo "$name $pid" | $SUDO tee -a "$STATE_DIR/started" >/dev/null
  say "started $name (pid $pid)"
}

start_daemon() {
  local name=$1
  if running "$name"; then
    return
  fi
  $SUDO "$name"
  remember "$name"
}

# The node's state, empty while the controller does not answer yet.
node_state() {
  { sinfo -h -N -o '%T' 2>/dev/null || true; } | head -n 1 | tr -d '*~#'
}

wait_idle() {
  local state="" i
  for ((i = 0; i < WAIT_S * 2; i++)); do
    state=$(node_state)
    case "$state" in
      idle | mixed | allocated) return 0 ;;
      down | drained | draining)
        # A node left down by an earlier cluster on this machine.
        $SUDO scontrol update NodeName="$(hostname -s)" State=RESUME >/dev/null 2>&1 || true
        ;;
    esac
    sleep 0.5
  done
  die "the node is not idle after ${WAIT_S} s (state: ${state:-none}); see /var/log/slurm/"
}

up() {
  install_packages
  $SUDO mkdir -p "$STATE_DIR"
  $SUDO touch "$STATE_DIR/started"
  if ! running slurmctld; then
    write_config
  fi
  start_munge
  start_daemon slurmctld
  start_daemon slurmd
  wait_idle
  say "up: $(sinfo -h -N -o '%N %c CPUs %m MiB %T')"
}

down() {
  local lines=() line name pid i
  if [ -f "$STATE_DIR/started" ]; then
    mapfile -t lines < "$STATE_DIR/started"
  fi
  # Slurm before munge, which its daemons authenticate with; only the processes `up` started.
  for name in slurmd slurmctld munged; do
    for line in "${lines[@]}"; do
      [ "${line%% *}" = "$name" ] || continue
      pid=${line#* }
      # the pid is still that daemon (not reused by another process)
      [ "$(ps -o comm= -p "$pid" 2>/dev/null || true)" = "$name" ] || continue
      $SUDO kill -TERM "$pid" || true
      for ((i = 0; i < 40; i++)); do
        $SUDO kill -0 "$pid" 2>/dev/null || break
        sleep 0.25
      done
      if $SUDO kill -0 "$pid" 2>/dev/null; then
        say "$name ($pid) did not stop on SIGTERM: killing it"
        $SUDO kill -KILL "$pid" || true
      fi
      say "stopped $name (pid $pid)"
    done
  done
  $SUDO rm -f "$STATE_DIR/started"
}

status() {
  local name up=0
  for name in munged slurmctld slurmd; do
    if running "$name"; then
      echo "$name: running (pid $(pgrep -x "$name" | tr '\n' ' ' | sed 's/ $//'))"
    else
      echo "$name: not running"
      up=1
    fi
  done
  if [ $up = 0 ]; then
    sinfo -N -o '%N %c %m %T'
  fi
  return $up
}

case "${1:-}" in
  up) up ;;
  down) down ;;
  status) status ;;
  *)
    echo "usage: $0 up|down|status" >&2
    exit 2
    ;;
esac
