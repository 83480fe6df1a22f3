#!/usr/bin/env bash
# Stop the SLURM daemons that .ci/slurm/start.sh started (listed in
# /run/demcal-slurm/started), slurmd first, by the pids in their pid files.
# Safe to call twice or when nothing runs; never stops daemons it did not start.
set -uo pipefail

STATE_DIR=/run/demcal-slurm

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo -n "$@"; fi; }

[ -s "$STATE_DIR/started" ] || exit 0
status=0
for pidfile in /run/slurmd.pid /run/slurmctld.pid /run/munge/munged.pid; do
  grep -qx "$pidfile" "$STATE_DIR/started" || continue
  [ -s "$pidfile" ] || continue
  pid="$(as_root cat "$pidfile")"
  as_root kill "$pid" 2>/dev/null || continue   # already gone
  for _ in $(seq 50); do
    as_root kill -0 "$pid" 2>/dev/null || break
    sleep 0.2
  done
  if as_root kill -0 "$pid" 2>/dev/null; then
    echo "slurm-ci: WARNING: pid $pid ($pidfile) still running after 10 s" >&2
    status=1
  fi
done
[ "$status" -eq 0 ] && as_root rm -f "$STATE_DIR/started"
exit "$status"
