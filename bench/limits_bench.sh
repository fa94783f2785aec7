#!/bin/sh
# Limits and load of granulard's HTTP front end: requests/s on /healthz and the job list, event-stream clients, idle connections held; prints markdown rows.
set -eu
build=$(cd "${1:-.}" && pwd)
CLIENTS=${CLIENTS:-32} SECS=${SECS:-5} SSE=${SSE:-1000} IDLE=${IDLE:-4000}
st=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill $pid 2>/dev/null; wait 2>/dev/null; rm -rf "$st"' EXIT
# Jobs never start (a launcher that holds the only slot without CPU): this measures the HTTP layer and the queue.
# No per-address limit and long head timeouts: every client here comes from 127.0.0.1 and some wait on purpose.
"$build/daemon/granulard" --state-dir "$st" --listen 127.0.0.1:0 --slots 1 --launch "sleep 3600" --log-level warning \
	--per-ip-connections 0 --max-connections 8192 --header-timeout 600 2>"$st/log" &
pid=$!
i=0; while [ ! -s "$st/granulard.addr" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
addr=$(cat "$st/granulard.addr"); port=${addr##*:}; token=$(cat "$st/token")
load=$(cut -d' ' -f1 /proc/loadavg)
printf '{"scene":{"method":"ed","dimensions":2,"particles":{"count":1000,"volume_fraction":0.2},"run":{"until":{"time":1}}},"submission_id":"l-@ID@"}' >"$st/body"
# Some hundreds of jobs in the database for the list.
"$build/bench/http_load" 127.0.0.1 "$port" 4 2 POST /api/v1/jobs "$token" "$st/body" >/dev/null
njobs=$(curl -s "http://$addr/api/v1/cluster" | /usr/bin/python3 -c 'import json,sys; print(sum(json.load(sys.stdin)["jobs"].values()))')
row() { /usr/bin/python3 -c '
import json,sys
d=json.loads(sys.argv[1])
print("| %s | %.0f requests/s (p50 %.2f ms, p99 %.2f ms, %d errors, %d non-2xx) | `%s` |" % (sys.argv[2], d["requests_per_second"],
      d["p50_ms"], d["p99_ms"], d["errors"], d["non_2xx"], sys.argv[3]))' "$1" "$2" "$3"; }
r=$("$build/bench/http_load" 127.0.0.1 "$port" "$CLIENTS" "$SECS" GET /healthz)
row "$r" "GET /healthz, $CLIENTS keep-alive clients" "bench/http_load 127.0.0.1 PORT $CLIENTS $SECS GET /healthz"
r=$("$build/bench/http_load" 127.0.0.1 "$port" "$CLIENTS" "$SECS" GET '/api/v1/jobs?limit=20')
row "$r" "GET /api/v1/jobs?limit=20 ($njobs jobs stored), $CLIENTS clients" "bench/http_load 127.0.0.1 PORT $CLIENTS $SECS GET '/api/v1/jobs?limit=20'"

# Event streams: SSE clients each wait for hello, then one submission must reach every one of them.
# Idle connections: IDLE sockets that send nothing, held while /healthz is timed.
/usr/bin/python3 - "$addr" "$token" "$SSE" "$IDLE" <<'EOF'
import json, resource, selectors, socket, sys, time, urllib.request
addr, token, nsse, nidle = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, max(soft, nsse + nidle + 100)), hard))
h, p = addr.rsplit(":", 1); p = int(p)
def metric(name):
    with urllib.request.urlopen("http://%s/metrics" % addr, timeout=10) as r:
        for l in r.read().decode().splitlines():
            if l.startswith(name + " "):
                return int(float(l.split()[1]))
sel = selectors.DefaultSelector()
buf = {}
for i in range(nsse):
    s = socket.create_connection((h, p), timeout=10)
    s.sendall(b"GET /api/v1/events HTTP/1.1\r\nHost: %s\r\nAccept: text/event-stream\r\n\r\n" % addr.encode())
    s.setblocking(False)
    sel.register(s, selectors.EVENT_READ)
    buf[s] = b""
def pump(needle, until):
    while time.monotonic() < until and sum(needle in b for b in buf.values()) < nsse:
        for k, _ in sel.select(0.2):
            try:
                d = k.fileobj.recv(65536)
            except BlockingIOError:
                continue
            buf[k.fileobj] += d
    return sum(needle in b for b in buf.values())
hello = pump(b"event: hello", time.monotonic() + 60)
t = time.monotonic()
req = urllib.request.Request("http://%s/api/v1/jobs" % addr, method="POST",
                             data=json.dumps({"scene": {"method": "ed", "dimensions": 2, "particles": {"count": 100, "volume_fraction": 0.2},
                                                        "run": {"until": {"time": 1}}}}).encode(),
                             headers={"Authorization": "Bearer " + token, "Content-Type": "application/json"})
urllib.request.urlopen(req, timeout=10).read()
got = pump(b"event: state", time.monotonic() + 30)
fan = time.monotonic() - t
streams = metric("granulard_http_streams")
print("| event-stream clients (`GET /api/v1/events`) | %d of %d streams open (%d counted by the daemon); one submission's `state` event reached %d of them in %.2f s | bench/limits_bench.sh (SSE=%d) |"
      % (hello, nsse, streams, got, fan, nsse))
for s in list(buf):
    s.close()
time.sleep(2)
idle = []
for i in range(nidle):
    try:
        idle.append(socket.create_connection((h, p), timeout=10))
    except OSError:
        break
time.sleep(1.5)
held = metric("granulard_http_connections")
lat = []
for i in range(20):
    t = time.monotonic()
    urllib.request.urlopen("http://%s/healthz" % addr, timeout=10).read()
    lat.append(time.monotonic() - t)
lat.sort()
print("| idle connections (opened, nothing sent) | %d opened, %d held by the daemon; `/healthz` meanwhile: median %.1f ms, worst %.1f ms of 20 | bench/limits_bench.sh (IDLE=%d) |"
      % (len(idle), held, 1e3 * lat[10], 1e3 * lat[-1], nidle))
EOF
rss=$(awk '/VmHWM/ {print $2}' "/proc/$pid/status")
echo
echo "Load average before the run: $load on $(nproc) cores; daemon peak RSS $((rss / 1024)) MiB."
