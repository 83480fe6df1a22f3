#!/usr/bin/env bash
# Bring up a one-node SLURM on this machine for CI: munge + slurmctld + slurmd,
# no systemd, no slurmdbd (Debian 12's SLURM 22.05). Idempotent: a second call
# with SLURM already up and configured the same way only re-checks it.
#
#   .ci/slurm/start.sh        # as root, or a user with passwordless sudo
#   .ci/slurm/stop.sh         # stops what this script started
#
# The daemons this script starts are listed in $STATE_DIR/started so that
# stop.sh ends only those (a munged the machine already ran is left alone).
# Finished jobs are kept in a plain-text record: `sacct -c` lists them.
set -euo pipefail

STATE_DIR=/run/demcal-slurm
CONF=/etc/slurm/slurm.conf
LOG_DIR=/var/log/slurm
JOBCOMP="$LOG_DIR/jobcomp.log"
PARTITION=main

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo -n "$@"; fi; }
say() { echo "slurm-ci: $*" >&2; }
die() {
  say "ERROR: $*"
  as_root tail -n 20 "$LOG_DIR/slurmctld.log" "$LOG_DIR/slurmd.log" >&2 2>/dev/null || true
  exit 1
}
# alive PIDFILE: the pid in PIDFILE is a live process
alive() { [ -s "$1" ] && as_root kill -0 "$(as_root cat "$1")" 2>/dev/null; }
note_started() { as_root sh -c "grep -qx '$1' '$STATE_DIR/started' 2>/dev/null || echo '$1' >> '$STATE_DIR/started'"; }

install_packages() {
  local missing=()
  for cmd in slurmctld slurmd sbatch munged; do
    command -v "$cmd" >/dev/null 2>&1 || missing+=("$cmd")
  done
  [ ${#missing[@]} -eq 0 ] && return
  say "installing slurmctld slurmd slurm-client munge (missing: ${missing[*]})"
  local apt=(env DEBIAN_FRONTEND=noninteractive apt-get -q -o DPkg::Lock::Timeout=300)
  if ! as_root timeout -k 10 600 "${apt[@]}" install -y --no-install-recommends \
      slurmctld slurmd slurm-client munge >/dev/null; then
    as_root timeout -k 10 300 "${apt[@]}" update >/dev/null
    as_root timeout -k 10 600 "${apt[@]}" install -y --no-install-recommends \
      slurmctld slurmd slurm-client munge >/dev/null
  fi
}

munge_works() { timeout 10 munge -n 2>/dev/null | timeout 10 unmunge >/dev/null 2>&1; }

start_munge() {
  if [ ! -s /etc/munge/munge.key ]; then
    as_root timeout 30 mungekey --create --keyfile=/etc/munge/munge.key
  fi
  as_root chown munge:munge /etc/munge/munge.key
  as_root chmod 0400 /etc/munge/munge.key
  munge_works && return
  say "starting munged"
  as_root install -d -o munge -g munge -m 0755 /run/munge
  as_root timeout 30 runuser -u munge -- /usr/sbin/munged
  note_started /run/munge/munged.pid
  for _ in $(seq 50); do munge_works && return; sleep 0.2; done
  die "munge does not authenticate (munge -n | unmunge fails)"
}

# The whole slurm.conf on stdout. Only stable facts of the machine go in, so
# that the same machine always gets the same file (and no needless restart).
render_config() {
  local host cpus mem_mb
  host="$(hostname -s)"
  cpus="$(nproc)"
  # 80 % of the installed memory, whole GiB: slurmd refuses a node with less
  mem_mb=$(awk '/^MemTotal:/ {print int($2 / 1024 * 0.8 / 1024) * 1024}' /proc/meminfo)
  cat <<EOF
# Written by demcal's .ci/slurm/start.sh: one node, this machine.
ClusterName=demcal-ci
SlurmctldHost=${host}(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
MpiDefault=none
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
ReturnToService=2
SlurmdParameters=config_overrides
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=${LOG_DIR}/slurmctld.log
SlurmdLogFile=${LOG_DIR}/slurmd.log
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SchedulerType=sched/backfill
# Start a batch job about 1 s after submission (default delay 3 s).
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
# A job that asks no memory gets this much per CPU instead of the whole node.
DefMemPerCPU=256
# Snakemake polls squeue; a finished job must stay listed well beyond its poll
# interval or the executor plugin falls back to sacct, which has no database here.
MinJobAge=600
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
# No slurmdbd: finished jobs go to a text file, read by 'sacct -c'.
JobCompType=jobcomp/filetxt
JobCompLoc=${JOBCOMP}
NodeName=${host} NodeAddr=127.0.0.1 CPUs=${cpus} RealMemory=${mem_mb} State=UNKNOWN
PartitionName=${PARTITION} Nodes=${host} Default=YES MaxTime=INFINITE State=UP
EOF
}

# Write slurm.conf; succeed (0) if it changed.
write_config() {
  local new
  new="$(render_config)"
  as_root mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd "$LOG_DIR"
  as_root touch "$JOBCOMP"
  if [ -f "$CONF" ] && [ "$(as_root cat "$CONF")" = "$new" ]; then
    return 1
  fi
  printf '%s\n' "$new" | as_root tee "$CONF" >/dev/null
  say "wrote $CONF"
}

stop_daemon() {  # stop_daemon NAME: by its pid file, wait up to 10 s
  local pidfile=/run/$1.pid pid
  alive "$pidfile" || return 0
  pid="$(as_root cat "$pidfile")"
  as_root kill "$pid"
  for _ in $(seq 50); do as_root kill -0 "$pid" 2>/dev/null || return 0; sleep 0.2; done
  die "$1 (pid $pid) did not stop"
}

start_daemons() {
  local config_changed=$1
  for d in slurmctld slurmd; do
    if [ "$config_changed" = yes ]; then stop_daemon "$d"; fi
  done
  for d in slurmctld slurmd; do   # both daemonize and write /run/$d.pid
    alive "/run/$d.pid" && continue
    say "starting $d"
    as_root timeout 30 "$d" || die "$d did not start"
    note_started "/run/$d.pid"
  done
}

wait_node_idle() {
  local host state
  host="$(hostname -s)"
  for _ in $(seq 120); do
    state="$(timeout 5 sinfo -h -n "$host" -o %T 2>/dev/null || true)"
    case "$state" in
      idle|mixed|allocated) return ;;
      down*|drain*) timeout 10 scontrol update NodeName="$host" State=RESUME 2>/dev/null || true ;;
    esac
    sleep 0.5
  done
  timeout 5 sinfo -R >&2 || true
  die "node $host is not usable after 60 s (state: ${state:-none})"
}

# A batch job must run to COMPLETED and stay visible to squeue (what the
# Snakemake executor plugin relies on). 'sbatch --wait' is avoided: it polls slowly.
smoke_test() {
  local job state
  timeout 30 srun --quiet -p "$PARTITION" true || die "srun true failed"
  job="$(timeout 30 sbatch --parsable -p "$PARTITION" -o /dev/null --wrap true)" \
    || die "sbatch failed"
  for _ in $(seq 120); do
    state="$(timeout 5 squeue -h -j "$job" --states=all -o %T 2>/dev/null || true)"
    case "$state" in
      COMPLETED) return ;;
      *FAIL*|*CANCEL*|TIMEOUT|OUT_OF_MEMORY) die "test job $job ended $state" ;;
    esac
    sleep 0.5
  done
  die "test job $job did not complete in 60 s (state: ${state:-not listed})"
}

main() {
  local t0=$SECONDS changed=no
  export PATH="$PATH:/usr/sbin:/sbin"
  install_packages
  as_root mkdir -p "$STATE_DIR"
  start_munge
  if write_config; then changed=yes; fi
  start_daemons "$changed"
  wait_node_idle
  smoke_test
  say "up in $((SECONDS - t0)) s: partition $PARTITION, $(timeout 5 sinfo -h -o '%D node(s), %c CPUs, %m MB')," \
      "slurmctld pid $(as_root cat /run/slurmctld.pid), slurmd pid $(as_root cat /run/slurmd.pid)"
}

main "$@"
