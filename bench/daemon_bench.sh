#!/bin/sh
# Load benchmark of granulard: POST /jobs and GET /jobs under 64 keep-alive clients; prints a markdown section.
set -eu
build=${1:-.}
src=${2:-.}
st=$(mktemp -d)
trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null; rm -rf "$st"' EXIT
# The jobs must not run (that would measure the engine): a launcher that holds the only slot without CPU.
"$build/daemon/granulard" --state-dir "$st" --listen 127.0.0.1:0 --slots 1 --launch "sleep 3600" \
	--max-connections 512 --log-level warning 2>"$st/log" &
pid=$!
i=0; while [ ! -s "$st/granulard.addr" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
addr=$(cat "$st/granulard.addr"); port=${addr##*:}; token=$(cat "$st/token")
printf '{"scene":{"method":"ed","dimensions":2,"particles":{"count":1000,"volume_fraction":0.2},"run":{"until":{"time":1}}},"submission_id":"load-@ID@"}' >"$st/body"
post=$("$build/bench/http_load" 127.0.0.1 "$port" 64 10 POST /api/v1/jobs "$token" "$st/body")
echo "$post" >&2
jobs=$(curl -s "http://$addr/api/v1/cluster" | /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); print(sum(d["jobs"].values()))')
get=$("$build/bench/http_load" 127.0.0.1 "$port" 64 10 GET "/api/v1/jobs?limit=20")
echo "$get" >&2
getone=$("$build/bench/http_load" 127.0.0.1 "$port" 64 10 GET /api/v1/jobs/1)
echo "$getone" >&2
rss=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status"); hwm=$(awk '/VmHWM/ {print $2}' "/proc/$pid/status")
db=$(du -k "$st/granulard.db" "$st/granulard.db-wal" 2>/dev/null | awk '{s+=$1} END {print s}')
echo "## Daemon (granulard) under load"
echo
echo "64 concurrent keep-alive clients for 10 s per row (bench/http_load.c), daemon and clients on the same 2 cores,"
echo "loopback. The jobs never start (launcher \`sleep 3600\` holds the only slot), so this measures the HTTP layer"
echo "and the SQLite queue (WAL, synchronous=FULL: every submission is fsynced before 201)."
echo "Command: \`make bench\` (bench/daemon_bench.sh); \`http_load HOST PORT 64 10 METHOD PATH [TOKEN BODY]\`."
echo
echo "| request | requests/s | p50 ms | p99 ms | max ms | errors | non-2xx |"
echo "|---|---|---|---|---|---|---|"
for r in "$post" "$get" "$getone"; do
	echo "$r" | /usr/bin/python3 -c '
import json,sys
d=json.loads(sys.stdin.read())
print("| %s %s | %.0f | %.2f | %.2f | %.1f | %d | %d |" % (d["method"], d["path"], d["requests_per_second"], d["p50_ms"], d["p99_ms"], d["max_ms"], d["errors"], d["non_2xx"]))'
done
echo
echo "Daemon memory after the run: RSS $((rss / 1024)) MiB (peak $((hwm / 1024)) MiB) with $jobs jobs in the database ($((db / 1024)) MiB)."
echo
