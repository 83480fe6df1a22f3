#!/usr/bin/env bash
# A throwaway PostgreSQL server for the archive's tests (tests/archive) and its benchmark
# (benchmarks/archive_load.py): a new cluster in DIR (default /tmp/demcal-postgres) that
# listens on 127.0.0.1 only, on a free port, with trust authentication and one database,
# demcal. Prints its URL:
#
#   export DEMCAL_TEST_POSTGRES_URL="$(.ci/postgres/start.sh)"
#   .ci/postgres/stop.sh           # stops it and removes DIR
#
# Installs Debian's postgresql when no server binaries are there. As root the server runs
# as the user postgres (initdb refuses root). A second call while it runs prints the URL.
set -euo pipefail

DIR="${1:-/tmp/demcal-postgres}"
say() { echo "postgres-ci: $*" >&2; }
server_bin() { find /usr/lib/postgresql -maxdepth 2 -name bin -type d 2>/dev/null | sort -V | tail -n 1 || true; }
as_owner() { if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi; }

BIN="$(server_bin)"
if [ -z "$BIN" ]; then
  say "installing postgresql"
  apt=(env DEBIAN_FRONTEND=noninteractive apt-get -q -o DPkg::Lock::Timeout=300)
  as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo -n "$@"; fi; }
  timeout -k 10 600 "${apt[@]}" install -y --no-install-recommends postgresql >/dev/null 2>&1 \
    || { as_root timeout -k 10 600 "${apt[@]}" update >/dev/null \
         && as_root timeout -k 10 600 "${apt[@]}" install -y --no-install-recommends postgresql >/dev/null; }
  BIN="$(server_bin)"
  [ -n "$BIN" ] || { say "ERROR: no PostgreSQL server binaries after installing postgresql"; exit 1; }
fi

if [ -s "$DIR/url" ] && as_owner "$BIN/pg_ctl" -D "$DIR/data" status >/dev/null 2>&1; then
  cat "$DIR/url"
  exit 0
fi
rm -rf "$DIR"
mkdir -p "$DIR"
[ "$(id -u)" -ne 0 ] || chown postgres: "$DIR"
port="$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
as_owner "$BIN/initdb" -D "$DIR/data" -A trust -U postgres >"$DIR/initdb.log" 2>&1 \
  || { say "ERROR: initdb failed"; tail -n 20 "$DIR/initdb.log" >&2; exit 1; }
as_owner "$BIN/pg_ctl" -D "$DIR/data" -l "$DIR/server.log" -w -t 60 start \
  -o "-p $port -k $DIR -c listen_addresses=127.0.0.1" >/dev/null \
  || { say "ERROR: the server did not start"; tail -n 20 "$DIR/server.log" >&2; exit 1; }
as_owner "$BIN/createdb" -h 127.0.0.1 -p "$port" -U postgres demcal
echo "postgresql://postgres@127.0.0.1:$port/demcal" | tee "$DIR/url"
