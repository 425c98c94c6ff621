#!/usr/bin/env bash
# A one-node SLURM cluster on this machine, from Debian's packages, to run tmopt's
# `hydra/launcher=cluster` sweeps for real (experiments/slurm_sweep.sh, docs/sweeps.md).
#
#   experiments/slurm_local.sh up       install what is missing, configure, start, wait for idle
#   experiments/slurm_local.sh down     cancel jobs left on it, stop every daemon this script started
#   experiments/slurm_local.sh status   what runs, and sinfo
#
# Daemons (no systemd needed; each started directly, its pid in $STATE/run):
#   munged (authentication), mariadbd + slurmdbd (accounting), slurmctld, slurmd.
# Accounting is not optional here: submitit, Hydra's SLURM launcher, learns that a job has
# ended without a result (cancelled, killed, out of memory) only from `sacct`, which needs
# slurmdbd; without it the sweep command would wait forever on a cancelled job.
#
# Needs root and apt-get (Debian/Ubuntu), or the packages already installed. Idempotent:
# `up` on a running cluster only checks it. Everything lives in $SLURM_LOCAL_STATE
# (default /var/lib/tmopt-slurm); the files /etc/slurm/slurm.conf and slurmdbd.conf are
# written only when absent or written by this script before (a real site's are left alone).
# SLURM_LOCAL_CPUS (default 2) sets the node's CPUs.
set -euo pipefail

STATE=${SLURM_LOCAL_STATE:-/var/lib/tmopt-slurm}
CPUS=${SLURM_LOCAL_CPUS:-2}
CLUSTER=tmoptlocal
PARTITION=local
MARK="# written by tmopt experiments/slurm_local.sh"
CONF=/etc/slurm/slurm.conf
DBD_CONF=/etc/slurm/slurmdbd.conf
DB_PORT=6821          # our own MariaDB instance, away from a system one on 3306
PACKAGES=(slurm-wlm slurmdbd munge mariadb-server)
NODE=$(hostname -s)

say() { echo "slurm_local: $*"; }
die() { echo "slurm_local: error: $*" >&2; exit 1; }

usage() {
  echo "usage: $0 up|down|status" >&2
  exit 2
}

# ---- prerequisites ------------------------------------------------------------------------
missing_packages() {
  local p
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}

require_root() {
  [[ $(id -u) == 0 ]] || die "needs root (it installs packages, writes /etc/slurm and runs \
the daemons as root); run: sudo $0 $1"
}

install_packages() {
  command -v dpkg-query >/dev/null || die "no dpkg: this script needs a Debian-like system \
with the packages ${PACKAGES[*]}"
  local missing
  missing=$(missing_packages | tr '\n' ' ')
  [[ -z $missing ]] && return 0
  command -v apt-get >/dev/null || die "packages missing (${missing}) and no apt-get to install them"
  say "installing ${missing}(apt-get)"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >/dev/null || die "apt-get update failed (no network or no package source?)"
  # shellcheck disable=SC2086 # word splitting of the package list is wanted
  apt-get install -y -q --no-install-recommends $missing >/dev/null \
    || die "apt-get install ${missing}failed"
}

# ---- configuration --------------------------------------------------------------------------
ours_or_absent() {
  [[ ! -e $1 ]] || head -n 1 "$1" | grep -qF "$MARK"
}

write_if_changed() {  # path mode content -> returns 0 if the file changed
  local path=$1 mode=$2 content=$3
  if [[ -e $path ]] && [[ $(cat "$path") == "$content" ]]; then return 1; fi
  ours_or_absent "$path" || die "$path exists and was not written by this script; \
this machine seems to have its own SLURM set-up (move it aside to use this one)"
  install -m "$mode" /dev/null "$path"
  printf '%s\n' "$content" > "$path"
}

real_memory_mb() {  # what the node offers jobs: all memory but 1 GiB
  awk '/^MemTotal:/ { m = int($2 / 1024) - 1024; print (m > 512 ? m : 512) }' /proc/meminfo
}

slurm_conf() {
  cat <<EOF
$MARK
# A one-node cluster for tests: node $NODE at 127.0.0.1, $CPUS CPUs, one partition.
ClusterName=$CLUSTER
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
# no cgroups in containers: plain process tracking, no CPU binding
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
SlurmdParameters=config_overrides
ReturnToService=2
# seconds between a job's SIGTERM (scancel, time limit) and its SIGKILL (SLURM's default: 30)
KillWait=5
MinJobAge=300
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/spool
SlurmctldPidFile=$STATE/run/slurmctld.pid
SlurmdPidFile=$STATE/run/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=127.0.0.1
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=$(real_memory_mb) State=UNKNOWN
PartitionName=$PARTITION Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
}

slurmdbd_conf() {
  cat <<EOF
$MARK
AuthType=auth/munge
DbdHost=localhost
DbdAddr=127.0.0.1
SlurmUser=root
PidFile=$STATE/run/slurmdbd.pid
LogFile=$STATE/log/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=$DB_PORT
StorageUser=slurm
StoragePass=$(cat "$STATE/db/password")
StorageLoc=slurm_acct_db
EOF
}

configure() {
  mkdir -p "$STATE"/{run,log,ctld,spool,db}
  [[ -s $STATE/db/password ]] || (umask 077; head -c 18 /dev/urandom | base64 | tr -d '/+=' \
    > "$STATE/db/password")
  mkdir -p /etc/slurm
  CONF_CHANGED=0
  if write_if_changed "$CONF" 644 "$(slurm_conf)"; then CONF_CHANGED=1; fi
  if write_if_changed "$DBD_CONF" 600 "$(slurmdbd_conf)"; then CONF_CHANGED=1; fi
  if [[ ! -s /etc/munge/munge.key ]]; then
    say "creating the munge key"
    mungekey --create --keyfile=/etc/munge/munge.key
  fi
  chown munge:munge /etc/munge/munge.key
  chmod 600 /etc/munge/munge.key
}

# ---- daemons --------------------------------------------------------------------------------
pidfile() {
  case $1 in
    munged) [[ -e $STATE/run/munged.ours ]] && echo /run/munge/munged.pid ;;
    mariadbd) echo "$STATE/db/run/mariadbd.pid" ;;
    *) echo "$STATE/run/$1.pid" ;;
  esac
}

pid_of() {  # name -> pid if this script's daemon of that name runs
  local f pid
  f=$(pidfile "$1") || return 1
  [[ -s $f ]] || return 1
  pid=$(tr -dc '0-9' < "$f")
  [[ -n $pid ]] && kill -0 "$pid" 2>/dev/null && echo "$pid"
}

wait_for() {  # seconds description command...
  local t=$1 what=$2
  shift 2
  for ((i = 0; i < t * 2; i++)); do
    if "$@" >/dev/null 2>&1; then return 0; fi
    sleep 0.5
  done
  return 1
}

fail_with_log() {
  echo "slurm_local: error: $1 (last lines of $2):" >&2
  tail -n 15 "$2" >&2 2>/dev/null || true
  exit 1
}

munge_works() { munge -n </dev/null | unmunge >/dev/null; }

start_munge() {
  if munge_works 2>/dev/null; then return 0; fi
  install -d -o munge -g munge -m 755 /run/munge
  install -d -o munge -g munge -m 700 /var/lib/munge /var/log/munge
  runuser -u munge -- /usr/sbin/munged || fail_with_log "munged did not start" \
    /var/log/munge/munged.log
  touch "$STATE/run/munged.ours"  # `down` stops munged only if this script started it
  wait_for 10 munge munge_works || fail_with_log "munge does not answer" /var/log/munge/munged.log
}

mysql_cli() { mariadb --no-defaults --socket="$STATE/db/run/mysqld.sock" -u root "$@"; }

start_mariadb() {
  pid_of mariadbd >/dev/null && return 0
  if [[ ! -d $STATE/db/data/mysql ]]; then
    mkdir -p "$STATE/db/data"
    chown mysql:mysql "$STATE/db/data"
    mariadb-install-db --no-defaults --user=mysql --datadir="$STATE/db/data" \
      --auth-root-authentication-method=socket --skip-test-db >"$STATE/log/mariadb-install.log" 2>&1 \
      || fail_with_log "mariadb-install-db failed" "$STATE/log/mariadb-install.log"
  fi
  install -d -o mysql -g mysql "$STATE/db/run" "$STATE/db/log"
  nohup mariadbd --no-defaults --user=mysql --datadir="$STATE/db/data" \
    --socket="$STATE/db/run/mysqld.sock" --pid-file="$STATE/db/run/mariadbd.pid" \
    --bind-address=127.0.0.1 --port=$DB_PORT --log-error="$STATE/db/log/mariadb.log" \
    --innodb-buffer-pool-size=32M --performance-schema=OFF </dev/null >/dev/null 2>&1 &
  wait_for 60 mariadb mysql_cli -e "SELECT 1" || fail_with_log "mariadbd did not start" \
    "$STATE/db/log/mariadb.log"
  local pass
  pass=$(cat "$STATE/db/password")
  mysql_cli -e "CREATE USER IF NOT EXISTS 'slurm'@'127.0.0.1' IDENTIFIED BY '$pass';
    ALTER USER 'slurm'@'127.0.0.1' IDENTIFIED BY '$pass';
    GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';" \
    || die "cannot create the accounting database user"
}

start_slurmdbd() {
  if ! pid_of slurmdbd >/dev/null; then
    slurmdbd || fail_with_log "slurmdbd did not start" "$STATE/log/slurmdbd.log"
  fi
  wait_for 60 slurmdbd sacctmgr -n list cluster || fail_with_log "slurmdbd does not answer" \
    "$STATE/log/slurmdbd.log"
  if ! sacctmgr -n -P list cluster format=cluster | grep -qx "$CLUSTER"; then
    sacctmgr -i add cluster "$CLUSTER" >/dev/null
  fi
}

start_slurm() {
  if ! pid_of slurmctld >/dev/null; then
    slurmctld || fail_with_log "slurmctld did not start" "$STATE/log/slurmctld.log"
  fi
  wait_for 60 slurmctld scontrol ping || fail_with_log "slurmctld does not answer" \
    "$STATE/log/slurmctld.log"
  if ! pid_of slurmd >/dev/null; then
    slurmd || fail_with_log "slurmd did not start" "$STATE/log/slurmd.log"
  fi
  wait_for 60 node node_ready || {
    local why
    why=$(sinfo -h -N -o "%T %E" 2>&1 | head -n 1)
    fail_with_log "node $NODE is not idle: ${why}" "$STATE/log/slurmd.log"
  }
}

node_state() { sinfo -h -N -n "$NODE" -o %T 2>/dev/null | head -n 1; }

node_ready() {
  local s
  s=$(node_state)
  case $s in
    idle|mixed|allocated) return 0 ;;
    drain*|down*|inval*) scontrol update nodename="$NODE" state=resume >/dev/null 2>&1; return 1 ;;
    *) return 1 ;;
  esac
}

stop_daemon() {  # name: SIGTERM, wait up to 30 s, then SIGKILL
  local pid
  pid=$(pid_of "$1") || return 0
  kill -TERM "$pid" 2>/dev/null || true
  for ((i = 0; i < 60; i++)); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.5
  done
  if kill -0 "$pid" 2>/dev/null; then
    say "$1 ($pid) ignored SIGTERM for 30 s; killing it"
    kill -KILL "$pid" 2>/dev/null || true
  fi
  rm -f "$(pidfile "$1")"
  say "stopped $1 ($pid)"
}

cancel_jobs() {
  scontrol ping >/dev/null 2>&1 || return 0
  local jobs
  jobs=$(squeue -h -o %A 2>/dev/null | tr '\n' ' ')
  [[ -z ${jobs// /} ]] && return 0
  say "cancelling jobs left on the cluster: $jobs"
  # shellcheck disable=SC2086
  scancel $jobs || true
  wait_for 60 jobs no_jobs || say "jobs still listed after 60 s: $(squeue -h -o %A | tr '\n' ' ')"
}

no_jobs() { [[ -z $(squeue -h -o %A 2>/dev/null) ]]; }

# ---- commands ---------------------------------------------------------------------------------
cmd_up() {
  require_root up
  install_packages
  configure
  if [[ $CONF_CHANGED == 1 ]] && pid_of slurmctld >/dev/null; then
    say "configuration changed; restarting the SLURM daemons"
    stop_daemon slurmd; stop_daemon slurmctld; stop_daemon slurmdbd
  fi
  start_munge
  start_mariadb
  start_slurmdbd
  start_slurm
  say "up: node $NODE $(node_state), partition $PARTITION, $CPUS CPUs (logs in $STATE/log)"
  sinfo
}

cmd_down() {
  require_root down
  local d running=0
  for d in slurmd slurmctld slurmdbd mariadbd munged; do
    if pid_of "$d" >/dev/null; then running=1; fi
  done
  if [[ $running == 0 ]]; then
    say "nothing to stop (no daemon of this script runs)"
    return 0
  fi
  cancel_jobs
  for d in slurmd slurmctld slurmdbd mariadbd munged; do stop_daemon "$d"; done
  rm -f "$STATE/run/munged.ours"
  say "down"
}

cmd_status() {
  local d pid
  for d in munged mariadbd slurmdbd slurmctld slurmd; do
    if pid=$(pid_of "$d"); then echo "$d: running ($pid)"; else echo "$d: not running"; fi
  done
  if command -v sinfo >/dev/null && scontrol ping >/dev/null 2>&1; then sinfo; fi
}

case ${1:-} in
  up) cmd_up ;;
  down) cmd_down ;;
  status) cmd_status ;;
  *) usage ;;
esac
