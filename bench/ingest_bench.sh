#!/bin/sh
# Progress ingestion benchmark of granulard: records read, stored and thinned per second for one flooding job; prints a markdown section.
set -eu
build=$(cd "${1:-.}" && pwd)
src=${2:-.}
SECONDS_MEASURED=5
st=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill $pid 2>/dev/null; wait 2>/dev/null; rm -rf "$st"' EXIT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

# A record every 1e-12 time units of a run that does not end while measured (10^9 records): the real engine at its
# fastest output. Admission lets it in only with a max_job_output of its ~0.4 TB estimate (docs/daemon.md).
CHATTY='{"method":"ed","dimensions":2,"particles":{"count":200,"volume_fraction":0.2},"run":{"seed":1,"until":{"time":1e-3}},"output":{"every":{"time":1e-12}}}'
# A launcher that only writes records, as fast as a pipe takes them (the reading side's limit).
printf '#!/bin/sh\nexec yes %s\n' "'{\"type\":\"progress\",\"time\":1,\"events\":1,\"wall_seconds\":1}'" >"$st/flood.sh"
chmod +x "$st/flood.sh"

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
counts() { curl -s "http://$addr/api/v1/jobs/1" | /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin)["progress_records"]; print(d["received"], d["stored"], d["thinned"])'; }

# row LABEL FLAGS...: start a daemon, submit CHATTY, measure SECONDS_MEASURED seconds after a 1 s settle.
row() {
	label=$1; shift
	rm -rf "$st/s"; mkdir -p "$st/s"
	"$build/daemon/granulard" --state-dir "$st/s" --listen 127.0.0.1:0 --slots 1 --engine "$build/engine/granular-engine" \
		--log-level warning --max-job-output 1000000000000 "$@" 2>"$st/log" &
	pid=$!
	i=0; while [ ! -s "$st/s/granulard.addr" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
	addr=$(cat "$st/s/granulard.addr"); token=$(cat "$st/s/token")
	curl -s -o /dev/null -X POST -H "Authorization: Bearer $token" -H "Content-Type: application/json" --data-binary "$CHATTY" "http://$addr/api/v1/jobs"
	sleep 1
	set -- $(counts); r0=$1; s0=$2; t0=$3; c0=$(cpu_ticks "$pid")
	sleep "$SECONDS_MEASURED"
	set -- $(counts); r1=$1; s1=$2; t1=$3; c1=$(cpu_ticks "$pid")
	hz=$(getconf CLK_TCK)
	/usr/bin/python3 -c 'import sys
l, r, s, t, c, T = sys.argv[1], *map(float, sys.argv[2:])
print("| %s | %.0f | %.0f | %.0f | %.0f%% |" % (l, r / T, s / T, t / T, 100 * c / T))' \
		"$label" $((r1 - r0)) $((s1 - s0)) $((t1 - t0)) "$(echo "($c1 - $c0) / $hz" | bc -l)" "$SECONDS_MEASURED"
	kill "$pid"; wait "$pid" 2>/dev/null || true; pid=
}

load=$(cut -d' ' -f1 /proc/loadavg)
echo "## Progress ingestion"
echo
echo "One job floods the daemon with progress records; rates over ${SECONDS_MEASURED} s after a 1 s settle, from the"
echo "job's \`progress_records\` counts (received, stored, thinned per second) and the daemon's CPU time (user +"
echo "system, % of one core), daemon and job on the same 2 cores. Engine: a 2D run of 200 disks with"
echo "\`output.every.time\` 1e-12 (a record per event, as fast as the engine writes). Flood: a launcher that writes"
echo "one record line in a loop (\`yes\`), as fast as the pipe takes it. Command: \`make bench\` (bench/ingest_bench.sh)."
echo
echo "| job, daemon settings | received/s | stored/s | thinned/s | daemon CPU |"
echo "|---|---|---|---|---|"
row "engine, defaults (rate 100/s, burst 1000)"
row "engine, no thinning (progress_rate 1e6, burst 1e8)" --progress-rate 1e6 --progress-burst 100000000 --max-progress-records 100000000
row "flood, defaults" --launch "$st/flood.sh {scene}"
row "flood, no thinning" --launch "$st/flood.sh {scene}" --progress-rate 1e6 --progress-burst 100000000 --max-progress-records 100000000
echo
echo "Load average before the run: $load on $(nproc) cores."
echo
