#!/usr/bin/env bash
# Stop the server .ci/postgres/start.sh started in DIR (default /tmp/demcal-postgres) and
# remove DIR. Safe to call twice or when nothing runs.
set -uo pipefail

DIR="${1:-/tmp/demcal-postgres}"
as_owner() { if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi; }
BIN="$(find /usr/lib/postgresql -maxdepth 2 -name bin -type d 2>/dev/null | sort -V | tail -n 1 || true)"
if [ -n "$BIN" ] && [ -d "$DIR/data" ]; then
  as_owner "$BIN/pg_ctl" -D "$DIR/data" -m fast -w stop >/dev/null 2>&1
fi
rm -rf "$DIR"
