#!/bin/sh
# Integration test of the HTTP front end's defences: Host/Origin on every route, read auth, framing, strict ids, FIFOs, idle and slow clients, closed streams.
set -u
. "$(dirname "$0")/daemon_lib.sh"

SHORT='{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.2},"run":{"seed":3,"until":{"time":0.05}},"output":{"every":{"time":0.01}}}'
is() { [ "$1" = "$2" ]; echo $?; }
ecode() { field "$1" 'd["error"]["code"]'; }

# raw HOSTPORT REQUEST: send REQUEST as is to the daemon, print the answer (status line ... body).
raw() {
	/usr/bin/python3 - "$1" "$2" <<'EOF'
import socket, sys
h, p = sys.argv[1].rsplit(":", 1)
s = socket.create_connection((h, int(p)), timeout=10)
s.sendall(sys.argv[2].encode().decode("unicode_escape").encode("latin-1"))   # \r\n written as such
s.shutdown(socket.SHUT_WR)
b = b""
while True:
    try:
        d = s.recv(65536)
    except OSError:
        break
    if not d:
        break
    b += d
sys.stdout.write(b.decode("latin-1"))
EOF
}
status_of() { head -n1 | cut -d' ' -f2; }
body_of() { sed '1,/^\r$/d'; }

S=$tmp/state
gd_start "$S"
HP=${URL#http://}
PORT=${HP##*:}

# 1. Host and Origin are checked on reads and on /advise too (DNS rebinding: a foreign name resolving to us).
for p in /healthz /api/v1/jobs /api/v1/cluster /; do
	b=$(api GET "$p" -H 'Host: attacker.example:'"$PORT")
	ok $([ "$(code)" = 403 ] && [ "$(ecode "$b")" = forbidden ]; echo $?) "GET $p with a foreign Host: 403 JSON"
done
b=$(api POST /api/v1/advise -H 'Host: attacker.example' -H 'Content-Type: application/json' -d '{}')
ok $([ "$(code)" = 403 ] && [ "$(ecode "$b")" = forbidden ]; echo $?) "POST /advise with a foreign Host: 403 JSON"
b=$(api GET /api/v1/jobs -H 'Origin: http://attacker.example')
ok $([ "$(code)" = 403 ] && [ "$(ecode "$b")" = forbidden ]; echo $?) "GET with a foreign Origin: 403 JSON"
api GET /api/v1/jobs -H "Origin: $URL" >/dev/null
ok $(is "$(code)" 200) "GET with our own Origin: 200"
api GET /api/v1/jobs -H "Host: localhost:$PORT" >/dev/null
ok $(is "$(code)" 200) "GET with Host localhost:PORT: 200"

# 2. Repeated Host or Origin: 400 (a proxy and we could disagree on which one counts).
a=$(raw "$HP" 'GET /api/v1/jobs HTTP/1.1\r\nHost: '"$HP"'\r\nHost: attacker.example\r\nConnection: close\r\n\r\n')
ok $([ "$(echo "$a" | status_of)" = 400 ] && [ "$(ecode "$(echo "$a" | body_of)")" = bad_request ]; echo $?) "two Host headers: 400 JSON"
a=$(raw "$HP" 'GET /api/v1/jobs HTTP/1.1\r\nHost: '"$HP"'\r\nOrigin: '"$URL"'\r\nOrigin: http://attacker.example\r\nConnection: close\r\n\r\n')
ok $([ "$(echo "$a" | status_of)" = 400 ] && [ "$(ecode "$(echo "$a" | body_of)")" = bad_request ]; echo $?) "two Origin headers: 400 JSON"

# 3. 414 and 431 are JSON like every other error.
long=$(/usr/bin/python3 -c 'print("a" * 20000)')
b=$(api GET "/$long")
ok $([ "$(code)" = 414 ] && [ "$(ecode "$b")" = uri_too_long ]; echo $?) "a 20 kB URL: 414 JSON"
b=$(api GET /healthz -H "X-Big: $(/usr/bin/python3 -c 'print("a" * 60000)')")
ok $([ "$(code)" = 431 ] && [ "$(ecode "$b")" = header_fields_too_large ]; echo $?) "a 60 kB header: 431 JSON"

# 4. No framing, on pages and API answers alike.
for p in / /api/v1/jobs; do
	curl -s -D "$tmp/h" -o /dev/null "$URL$p"
	grep -qi '^X-Frame-Options: DENY' "$tmp/h" && grep -qi "^Content-Security-Policy:.*frame-ancestors 'none'" "$tmp/h"
	ok $? "GET $p: X-Frame-Options DENY and CSP frame-ancestors 'none'"
done

# 5. One spelling of an id: +3 and 03 are not job 3; nor +5 a limit.
id=$(field "$(post /api/v1/jobs -d "$SHORT")" 'd["id"]')
wait_state "$id" succeeded 60
ok $? "job $id succeeded"
api GET "/api/v1/jobs/$id" >/dev/null
ok $(is "$(code)" 200) "GET /jobs/$id: 200"
for bad in "+$id" "0$id" "%2B$id"; do
	b=$(api GET "/api/v1/jobs/$bad")
	ok $([ "$(code)" = 404 ] && [ "$(ecode "$b")" = not_found ]; echo $?) "GET /jobs/$bad: 404"
done
api GET '/api/v1/jobs?limit=+5' >/dev/null
ok $(is "$(code)" 400) "limit=+5: 400"
api GET '/api/v1/jobs?limit=05' >/dev/null
ok $(is "$(code)" 400) "limit=05: 400"

# 6. A FIFO (or device) in a job directory is not served and hangs nothing.
mkfifo "$S/jobs/$id/trap.fifo"
t0=$(date +%s)
b=$(api GET "/api/v1/jobs/$id/files/trap.fifo" -m 10)
t1=$(date +%s)
ok $([ "$(code)" = 404 ] && [ $((t1 - t0)) -lt 5 ]; echo $?) "GET files/trap.fifo: 404 at once (code $(code), $((t1 - t0)) s)"
b=$(api GET "/api/v1/jobs/$id/files" -m 10)
ok $([ "$(code)" = 200 ] && [ "$(field "$b" '"trap.fifo" in [f["name"] for f in d["files"]]')" = False ]; echo $?) \
	"GET files: 200, the FIFO not listed"
api GET /healthz -m 5 >/dev/null
ok $(is "$(code)" 200) "healthz still answers"

# 7. A closed event stream is noticed within 2 s (the keep-alive comment comes every 15 s): the
# daemon's end of the socket leaves CLOSE_WAIT (read from /proc/net/tcp, no tool needed).
close_wait() {
	/usr/bin/python3 -c '
import sys
port = "%04X" % int(sys.argv[1])
n = 0
for f in ("/proc/net/tcp", "/proc/net/tcp6"):
    try:
        for line in open(f).readlines()[1:]:
            c = line.split()
            n += c[1].endswith(":" + port) and c[3] == "08"
    except OSError:
        pass
print(n)' "$PORT"
}
streams() { api GET /metrics | sed -n 's/^granulard_http_streams //p'; }
curl -sN -m 60 "$URL/api/v1/events" >"$tmp/sse" &
c=$!
i=0; while ! grep -q '^event: hello' "$tmp/sse" && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
ok $(is "$(streams)" 1) "one event stream open (metrics)"
kill $c; wait $c 2>/dev/null
sleep 0.1
i=1; while [ "$(close_wait)" != 0 ] && [ $i -lt 20 ]; do sleep 0.1; i=$((i + 1)); done
ok $(is "$(close_wait)" 0) "closed stream's socket closed by the daemon within 2 s ($((i * 100)) ms)"
ok $(is "$(streams)" 0) "no stream counted any more"

# 8. Idle and slow clients: 1500 idle connections and 530 slow-loris clients (a header line every
# second) do not stop /healthz and the API answering. Default limits, then no per-address limit
# (so that the daemon really holds them all). The client loops are bounded.
load() {
	/usr/bin/python3 - "$HP" "$1" "$2" <<'EOF'
import resource, socket, sys, time, json, urllib.request
h, p = sys.argv[1].rsplit(":", 1); p = int(p)
idle_n, slow_n = int(sys.argv[2]), int(sys.argv[3])
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
if soft != resource.RLIM_INFINITY and soft < idle_n + slow_n + 100:
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, idle_n + slow_n + 100), hard))
socks, slow = [], []
for i in range(idle_n + slow_n):
    try:
        s = socket.create_connection((h, p), timeout=5)
    except OSError:
        continue
    s.setblocking(False)
    if i >= idle_n:
        try:
            s.send(b"GET /healthz HTTP/1.1\r\nHost: %s\r\n" % sys.argv[1].encode())
        except OSError:
            pass
        slow.append(s)
    else:
        socks.append(s)
res = {"opened": len(socks) + len(slow), "ok": 0, "worst": 0.0}
for rnd in range(3):
    for s in slow:
        try:
            s.send(b"X-a: b\r\n")
        except OSError:
            pass
    for path in ("/healthz", "/api/v1/jobs?limit=5"):
        t = time.monotonic()
        try:
            with urllib.request.urlopen("http://%s%s" % (sys.argv[1], path), timeout=5) as r:
                r.read()
                res["ok"] += r.status == 200
        except Exception as e:
            print("#", path, e, file=sys.stderr)
        res["worst"] = max(res["worst"], time.monotonic() - t)
    time.sleep(1)
with urllib.request.urlopen("http://%s/metrics" % sys.argv[1], timeout=5) as r:
    for line in r.read().decode().splitlines():
        if line.startswith("granulard_http_connections "):
            res["held"] = int(float(line.split()[1]))
print(json.dumps(res))
EOF
}
r=$(load 1500 530)
echo "# default limits: $r"
ok $([ "$(field "$r" 'd["opened"]')" = 2030 ] && [ "$(field "$r" 'd["ok"]')" = 6 ] && [ "$(field "$r" 'd["worst"] < 2')" = True ]; echo $?) \
	"default limits: /healthz and /jobs answer under 1500 idle + 530 slow clients"
ok $([ "$(field "$r" 'd["held"] <= 64 + 2')" = True ]; echo $?) "default per-address limit: at most 64 held from 127.0.0.1"
gd_stop

gd_start "$S" --per-ip-connections 0 --header-timeout 60
HP=${URL#http://}
r=$(load 1500 530)
echo "# no per-address limit: $r"
ok $([ "$(field "$r" 'd["opened"]')" = 2030 ] && [ "$(field "$r" 'd["ok"]')" = 6 ] && [ "$(field "$r" 'd["worst"] < 2')" = True ]; echo $?) \
	"no per-address limit: /healthz and /jobs answer under 1500 idle + 530 slow clients"
ok $([ "$(field "$r" 'd["held"] >= 2000')" = True ]; echo $?) "the 2030 connections are held, not refused"
gd_stop

# 9. Idle clients are timed out: a connection that sends nothing is closed after header_timeout.
gd_start "$S" --header-timeout 2
HP=${URL#http://}
t=$(/usr/bin/python3 - "$HP" <<'EOF'
import socket, sys, time
h, p = sys.argv[1].rsplit(":", 1)
s = socket.create_connection((h, int(p)), timeout=10)
t = time.monotonic()
try:
    s.recv(100)
except OSError:
    pass
print(int(time.monotonic() - t))
EOF
)
ok $([ "$t" -ge 1 ] && [ "$t" -le 5 ]; echo $?) "a silent connection is closed after header_timeout (${t} s)"
gd_stop

# 10. read_auth token: reads need the token, also from loopback; the event stream takes it as a header.
gd_start "$S" --read-auth token
b=$(api GET /api/v1/jobs)
ok $([ "$(code)" = 401 ] && [ "$(ecode "$b")" = unauthorized ]; echo $?) "read_auth token: GET /jobs without the token: 401"
api GET /api/v1/jobs -H "Authorization: Bearer $TOKEN" >/dev/null
ok $(is "$(code)" 200) "read_auth token: GET /jobs with the token: 200"
api GET /api/v1/events -m 1 >/dev/null
ok $(is "$(code)" 401) "read_auth token: events without the token: 401"
curl -sN -m 2 -H "Authorization: Bearer $TOKEN" "$URL/api/v1/events" >"$tmp/sse2"
grep -q '^event: hello' "$tmp/sse2"
ok $? "read_auth token: events with the token header stream"
api GET / >/dev/null
ok $(is "$(code)" 200) "read_auth token: the dashboard page itself loads (it asks for the token)"
gd_stop
finish
