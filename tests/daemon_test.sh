#!/bin/sh
# Integration test of granulard with the real engine: jobs end to end, cancel, crashes of engine and daemon, limits, auth.
set -u
. "$(dirname "$0")/daemon_lib.sh"

# A short 2D run: until t=0.2, a record every 0.02 -> 11 progress records (t=0..0.2) and one summary.
SHORT='{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.2},"collisions":{"restitution":0.9},"run":{"seed":3,"until":{"time":0.2}},"output":{"every":{"time":0.02},"observables":["kinetic_energy","clusters"]}}'
# A run far longer than the test: it must be stopped (2e6 records if it ran: within the output limit).
LONG='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e5}},"output":{"every":{"time":0.05}}}'

! ldd "$GRANULARD" | grep -Eiq 'libmpi|libhdf5'
ok $? "granulard links neither MPI nor HDF5 (the engine runs them in its own processes)"

S=$tmp/state
gd_start "$S" --slots 2 --cancel-grace 5 --shutdown-grace 5
api GET /healthz >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "healthz answers 200 on $URL"
[ "$(stat -c %a "$S/token")" = 600 ]
ok $? "token file generated with mode 0600"

# 1. submit -> progress -> succeeded, with the expected number of records.
body=$(post /api/v1/jobs -d "$SHORT")
id=$(field "$body" 'd["id"]')
ok $([ "$(code)" = 201 ] && [ "$(field "$body" 'd["state"]')" = queued ]; echo $?) "POST /jobs: 201, job $id queued"
curl -sN -m 60 -H "Last-Event-ID: 0" "$URL/api/v1/jobs/$id/events" >"$tmp/sse" &
sse=$!
wait_state "$id" succeeded 60
ok $? "job $id succeeded"
prog=$(api GET "/api/v1/jobs/$id/progress")
ok $([ "$(field "$prog" 'len([r for r in d["records"] if r["type"]=="progress"])')" = 11 ] &&
     [ "$(field "$prog" 'd["records"][-1]["type"]')" = summary ]; echo $?) "stored series: 11 progress records and the summary"
cl=$(api GET "/api/v1/jobs/$id/clusters")
ok $([ "$(field "$cl" 'len(d["series"])')" = 11 ] && [ "$(field "$cl" 'd["series"][0]["clusters"]["count"] > 0')" = True ]; echo $?) \
	"clusters series: 11 entries with cluster statistics"
wait $sse
grep -q '^event: progress' "$tmp/sse" && grep -q '"state":"succeeded"' "$tmp/sse"
ok $? "event stream carried progress and ended with the succeeded state"
# A client that reconnects after the job ended, with the last id it saw, gets what it missed, then the
# final state, and the stream ends (curl exits 0, not 28 for its time limit).
curl -sN -m 20 -H "Last-Event-ID: 1" "$URL/api/v1/jobs/$id/events" >"$tmp/sse2"
ok $([ $? = 0 ] && grep -q '^event: progress' "$tmp/sse2" && tail -n 3 "$tmp/sse2" | grep -q '"state":"succeeded"'; echo $?) \
	"Last-Event-ID on a finished job: the missed progress, then the final state, then the end"
job=$(api GET "/api/v1/jobs/$id")
ok $([ "$(field "$job" 'd["attempts"][0]["exit_status"]')" = 0 ] && [ "$(field "$job" 'd["progress"]')" = 1.0 ] &&
     [ "$(field "$job" 'd["scene"]["particles"]["count"]')" = 400 ]; echo $?) "job record: attempt exit 0, progress 1.0, scene kept"
[ -f "$S/jobs/$id/progress.jsonl" ] && [ -f "$S/jobs/$id/scene.json" ]
ok $? "job directory holds scene.json and the engine's output"

# Files: listing with checksums, downloads with ranges, no path escapes.
fl=$(api GET "/api/v1/jobs/$id/files")
sum=$(sha256sum "$S/jobs/$id/progress.jsonl" | cut -d' ' -f1)
ok $([ "$(field "$fl" '[f["sha256"] for f in d["files"] if f["name"]=="progress.jsonl"][0]')" = "$sum" ] &&
     [ "$(field "$fl" '[f["size"] for f in d["files"] if f["name"]=="scene.json"][0]')" = "$(stat -c %s "$S/jobs/$id/scene.json")" ]; echo $?) \
	"GET /files lists $(field "$fl" '",".join(f["name"] for f in d["files"])') with sizes and SHA-256"
api GET "/api/v1/jobs/$id/files/progress.jsonl" >/dev/null
cmp -s "$tmp/body" "$S/jobs/$id/progress.jsonl"
ok $([ $? = 0 ] && [ "$(code)" = 200 ]; echo $?) "download: the whole file, byte for byte"
api GET "/api/v1/jobs/$id/files/progress.jsonl" -H 'Range: bytes=10-19' -D "$tmp/hdr" >/dev/null
ok $([ "$(code)" = 206 ] && [ "$(cat "$tmp/body")" = "$(dd if="$S/jobs/$id/progress.jsonl" bs=1 skip=10 count=10 2>/dev/null)" ] &&
     grep -qi "^Content-Range: bytes 10-19/$(stat -c %s "$S/jobs/$id/progress.jsonl")" "$tmp/hdr"; echo $?) "Range bytes=10-19: 206, 10 bytes, Content-Range"
api GET "/api/v1/jobs/$id/files/progress.jsonl" -H 'Range: bytes=-7' >/dev/null
ok $([ "$(code)" = 206 ] && [ "$(cat "$tmp/body")" = "$(tail -c 7 "$S/jobs/$id/progress.jsonl")" ]; echo $?) "Range bytes=-7: the last 7 bytes"
api GET "/api/v1/jobs/$id/files/progress.jsonl" -H 'Range: bytes=99999999-' >/dev/null; err_ok_early=$(code)
ok $([ "$err_ok_early" = 416 ]; echo $?) "Range past the end: 416"
for bad in ..%2F..%2Ftoken .sha256 '%2E%2E' 'scene.json%00x'; do
	c=$(curl -s --path-as-is -o "$tmp/b2" -w '%{http_code}' "$URL/api/v1/jobs/$id/files/$bad")
	ok $(case $c in 4??) ! grep -q "$TOKEN" "$tmp/b2" ;; *) false ;; esac; echo $?) "file name $bad refused: $c"
done
c=$(curl -s --path-as-is -o /dev/null -w '%{http_code}' "$URL/api/v1/jobs/$id/files/../../../token")
ok $(case $c in 4??) true ;; *) false ;; esac; echo $?) "path with .. segments refused: $c"

# 2. cancel a running job.
id2=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$id2" running 20
sleep 1
c=$(post "/api/v1/jobs/$id2/cancel")
ok $([ "$(code)" = 200 ] && [ "$(field "$c" 'd["cancel_requested"]')" = True ]; echo $?) "POST /cancel on a running job: 200, cancel requested"
wait_state "$id2" cancelled 20
ok $? "the running job ends cancelled"
post "/api/v1/jobs/$id2/cancel" >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "cancelling it again: 200 (idempotent)"
post "/api/v1/jobs/$id/cancel" >/dev/null
ok $([ "$(code)" = 409 ]; echo $?) "cancelling a succeeded job: 409"

# 3. kill -9 the engine: the job fails with a reason, the daemon keeps serving.
id3=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$id3" running 20
i=0; until pkill -9 -f "^$ENGINE run $S/jobs/$id3/" || [ $i -ge 100 ]; do sleep 0.2; i=$((i + 1)); done
wait_state "$id3" failed 20
ok $? "engine killed with SIGKILL: job $id3 failed"
r=$(field "$(api GET "/api/v1/jobs/$id3")" 'd["reason"]')
case "$r" in *"signal"*|*"status"*) ok 0 "failure reason recorded: $r" ;; *) ok 1 "failure reason recorded: $r" ;; esac
api GET /healthz >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "daemon still healthy"

# A scene the engine refuses at run time (random placement exhausts its tries below the jamming coverage,
# which validation refuses: a property of the random sequence, seed 1): the reason is the engine's own message.
jam='{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.53,"initial":{"positions":"random"}},"run":{"seed":1,"until":{"time":0.1}}}'
idj=$(field "$(post /api/v1/jobs -d "$jam")" 'd["id"]')
wait_state "$idj" failed 30
r=$(field "$(api GET "/api/v1/jobs/$idj")" 'd["reason"]')
case "$r" in "engine exited with status 2: "*"particles.initial.positions: random placement failed"*) ok 0 "engine-side failure explained: $r" ;;
*) ok 1 "engine-side failure explained: $r" ;; esac
# An unusable job directory (a file where the directory should go) fails the job with a clear reason.
last=$(field "$(api GET '/api/v1/jobs?limit=1')" 'd["jobs"][0]["id"]')
touch "$S/jobs/$((last + 1))"
idb=$(field "$(post /api/v1/jobs -d "$SHORT")" 'd["id"]')
wait_state "$idb" failed 20
r=$(field "$(api GET "/api/v1/jobs/$idb")" 'd["reason"]')
case "$r" in *"$S/jobs/$idb"*) ok 0 "unusable job directory: job $idb failed: $r" ;; *) ok 1 "unusable job directory: job $idb failed: $r" ;; esac
api GET /healthz >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "daemon healthy after both failures"
rm -f "$S/jobs/$idb"

# A worker killed after writing checkpoints is retried from the last one, and the result is the one an
# uninterrupted run gives (the engine's resume is bit-exact: docs/output.md), summary value for value.
CK='{"method":"ed","dimensions":2,"particles":{"count":20000,"volume_fraction":0.3},"run":{"seed":7,"until":{"time":100}},"output":{"every":{"time":10},"checkpoint":{"every":{"wall_seconds":0.3}}}}'
# killed_retry LABEL SCENE SUBMISSION_ID: run SCENE once to the end (job $ref), then again (job $idk) with its
# engine killed -9 once a checkpoint exists; checks that attempt 2 resumed from checkpoint.h5 and succeeded.
killed_retry() {
	ref=$(field "$(post /api/v1/jobs -d "$2")" 'd["id"]')
	wait_state "$ref" succeeded 120
	idk=$(field "$(post /api/v1/jobs -d "{\"scene\": $2, \"submission_id\": \"$3\"}")" 'd["id"]')
	i=0; until [ -s "$S/jobs/$idk/checkpoint.h5" ] || [ $i -ge 200 ]; do sleep 0.05; i=$((i + 1)); done
	sleep 0.4
	pkill -9 -f "^$ENGINE run $S/jobs/$idk/"
	wait_state "$idk" succeeded 120
	jk=$(api GET "/api/v1/jobs/$idk")
	ok $([ "$(field "$jk" 'len(d["attempts"])')" = 2 ] && [ "$(field "$jk" 'd["attempts"][1]["checkpoint"]')" = checkpoint.h5 ] &&
	     [ "$(field "$jk" '(d["attempts"][0]["signal"] or d["attempts"][0]["exit_status"]) not in (None, 0)')" = True ]; echo $?) \
		"$1 killed after a checkpoint: attempt 2 resumed from checkpoint.h5 and succeeded ($(field "$jk" 'd["attempts"][0]["reason"]'))"
}
killed_retry engine "$CK" ckpt-retry
refe=$ref; ide=$idk
last() { field "$(api GET "/api/v1/jobs/$1/progress")" '[(r["time"], r["events"], r["collisions"], repr(r["kinetic_energy"])) for r in d["records"] if r["type"]=="summary"][-1]'; }
a1=$(last "$refe"); a2=$(last "$ide")
ok $([ -n "$a1" ] && [ "$a1" = "$a2" ]; echo $?) "resumed job ends exactly as the uninterrupted one: $a2"
# The same for dsmc (random numbers: the generator state is in the checkpoint), comparing every
# field of the summary apart from the wall-clock ones.
CKM='{"method":"dsmc","dimensions":2,"particles":{"count":200000,"volume_fraction":0.1,"initial":{"positions":"random"}},"collisions":{"restitution":0.98},"run":{"seed":7,"until":{"time":300}},"output":{"every":{"time":10},"observables":["kinetic_energy","temperature","pressure","collision_rate"],"checkpoint":{"every":{"wall_seconds":0.3}}}}'
killed_retry "dsmc engine" "$CKM" ckpt-retry-dsmc
refm=$ref; idm=$idk
# (seq is the daemon's record number, not an engine value)
summ() { field "$(api GET "/api/v1/jobs/$1/progress")" 'sorted((k, repr(v)) for k, v in [r for r in d["records"] if r["type"]=="summary"][-1].items() if k not in ("wall_seconds", "events_per_second", "collisions_per_second", "seq"))'; }
m1=$(summ "$refm"); m2=$(summ "$idm")
series() { field "$(api GET "/api/v1/jobs/$1/progress")" '[(r["type"], r["time"], repr(r.get("kinetic_energy"))) for r in d["records"]]'; }
diffm=$(/usr/bin/python3 -c 'import ast,sys; a,b=dict(ast.literal_eval(sys.argv[1])),dict(ast.literal_eval(sys.argv[2])); print(sorted((k,a.get(k),b.get(k)) for k in set(a)|set(b) if a.get(k)!=b.get(k)))' "$m1" "$m2" 2>&1)
ok $([ -n "$m1" ] && [ "$m1" = "$m2" ]; echo $?) "resumed dsmc job ends exactly as the uninterrupted one, every summary field ($(echo "$m2" | wc -c) chars): $(echo "$m2" | cut -c1-160) differing: $diffm"
# The stored series reads as one run: the records the killed attempt sent after its checkpoint are
# dropped when the retry repeats them (jobq), so both jobs hold the same records.
for pair in "$refe $ide" "$refm $idm"; do
	set -- $pair
	s1=$(series "$1"); s2=$(series "$2")
	ok $([ -n "$s1" ] && [ "$s1" = "$s2" ]; echo $?) "job $2 (killed, resumed) stores the same progress series as job $1: $(echo "$s2" | cut -c1-120)"
done

# 3b. A checkpoint.h5 whose stored scene was altered (issue 19.5: exit 2 "different scene" and a failed job
# before): the engine falls back to checkpoint.prev.h5, the job succeeds, and attempt 2 names the file it
# really resumed from. The engine is stopped (SIGSTOP) while the scene's seed digit is changed, so no new
# checkpoint rotates the damaged file away, and killed -9 then.
idc=$(field "$(post /api/v1/jobs -d "$CK")" 'd["id"]')
i=0; until [ -s "$S/jobs/$idc/checkpoint.prev.h5" ] || [ $i -ge 400 ]; do sleep 0.05; i=$((i + 1)); done
for try in 1 2 3 4 5 6 7 8 9 10; do
	pkill -STOP -f "^$ENGINE run $S/jobs/$idc/"
	# not between the rotation's link and rename (checkpoint.h5 and .prev.h5 the same file)
	[ "$(stat -c %i "$S/jobs/$idc/checkpoint.h5")" != "$(stat -c %i "$S/jobs/$idc/checkpoint.prev.h5")" ] && break
	pkill -CONT -f "^$ENGINE run $S/jobs/$idc/"; sleep 0.05
done
/usr/bin/python3 - "$S/jobs/$idc/checkpoint.h5" <<'PYEOF'
import re, sys
with open(sys.argv[1], "r+b") as f:
    data = f.read()
    m = re.search(rb'"seed"\s*:\s*([0-9])', data)
    f.seek(m.start(1)); f.write(b"8" if m.group(1) != b"8" else b"9")
PYEOF
pkill -9 -f "^$ENGINE run $S/jobs/$idc/"; pkill -CONT -f "^$ENGINE run $S/jobs/$idc/"
wait_state "$idc" succeeded 120
st=$?
jc=$(api GET "/api/v1/jobs/$idc")
ok $([ $st = 0 ] && [ "$(field "$jc" 'len(d["attempts"])')" = 2 ] &&
     [ "$(field "$jc" 'd["attempts"][1]["checkpoint"]')" = checkpoint.prev.h5 ]; echo $?) \
	"checkpoint.h5 with an altered stored scene: attempt 2 resumed from $(field "$jc" 'd["attempts"][1]["checkpoint"]'), job $(field "$jc" 'd["state"]')"

# 3c. Inelastic collapse (issue 19.10): the job fails and its reason is the engine's message naming collisions.tc.
COL='{"method":"ed","dimensions":2,"particles":{"count":500,"volume_fraction":0.3,"initial":{"positions":"random","temperature":1}},"collisions":{"restitution":0.3,"tc":0},"run":{"seed":1,"until":{"collisions_per_particle":2000}},"output":{"every":{"collisions_per_particle":100},"checkpoint":{"every":{"time":2}}}}'
idl=$(field "$(post /api/v1/jobs -d "$COL")" 'd["id"]')
wait_state "$idl" failed 60
st=$?
jl=$(api GET "/api/v1/jobs/$idl")
ok $([ $st = 0 ] && field "$jl" 'd["reason"]' | grep -q 'collisions.tc: inelastic collapse at time'; echo $?) \
	"tc 0, e 0.3: job $(field "$jl" 'd["state"]'): $(field "$jl" 'd["reason"]' | cut -c1-160)"
# deterministic: not retried although it left checkpoints (exit 2)
ok $([ $st = 0 ] && [ "$(field "$jl" 'len(d["attempts"])')" = 1 ] && ls "$S/jobs/$idl/checkpoint.h5" >/dev/null; echo $?) \
	"a collapsed job is not retried from its checkpoint: $(field "$jl" 'len(d["attempts"])') attempt(s)"

# 4. kill -9 the daemon mid-run, restart: nothing lost, nothing duplicated, never two copies. The job writes
# no record after its first for a long while: an engine that writes to the dead daemon's pipe dies of it (EPIPE),
# and this is about the orphans that do not.
QUIET='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e9}},"output":{"every":{"time":1e8}}}'
id4=$(field "$(post /api/v1/jobs -d "$QUIET")" 'd["id"]')
wait_state "$id4" running 20
q1=$(field "$(post /api/v1/jobs -d "{\"scene\": $LONG, \"priority\": -5}")" 'd["id"]')
q2=$(field "$(post /api/v1/jobs -d "{\"scene\": $LONG, \"priority\": -5}")" 'd["id"]')
sleep 0.5
old=$(field "$(api GET "/api/v1/jobs/$id4")" 'd["attempts"][-1]["pid"]')
i=0; until eng=$(pgrep -f "^$ENGINE run $S/jobs/$id4/") || [ $i -ge 100 ]; do sleep 0.2; i=$((i + 1)); done
before=$(field "$(api GET '/api/v1/jobs?limit=1000')" 'len(d["jobs"])')
kill -9 "$GD_PID"; wait "$GD_PID" 2>/dev/null; GD_PID=
alive "$old" && alive "$eng"
ok $? "after kill -9 of the daemon its launcher $old and engine $eng still run (orphaned)"
gd_start "$S" --slots 2 --cancel-grace 5 --shutdown-grace 5
! alive "$old" && ! alive "$eng"
ok $? "restart stopped the orphans before serving"
after=$(field "$(api GET '/api/v1/jobs?limit=1000')" 'len(d["jobs"])')
ok $([ "$before" = "$after" ]; echo $?) "all $after jobs still there"
wait_state "$id4" running 20
j4=$(api GET "/api/v1/jobs/$id4")
ok $([ "$(field "$j4" 'len(d["attempts"])')" = 2 ] && [ "$(field "$j4" 'd["attempts"][0]["reason"]')" != None ]; echo $?) \
	"job $id4 requeued and relaunched as attempt 2; attempt 1 says why: $(field "$j4" 'd["attempts"][0]["reason"]')"
ok $([ "$(pgrep -fc "^$ENGINE run $S/jobs/$id4/")" = 1 ]; echo $?) "exactly one engine runs job $id4"
for j in $id4 $q1 $q2; do post "/api/v1/jobs/$j/cancel" >/dev/null; done
wait_state "$id4" cancelled 20 && wait_state "$q1" cancelled 5 && wait_state "$q2" cancelled 5
ok $? "jobs queued before the crash ($q1, $q2) were kept and can be cancelled"

# 5. 200 concurrent submissions give 200 distinct jobs; retries with the same submission_id do not duplicate.
ids=$tmp/ids
seq 1 200 | xargs -P 32 -I{} curl -s -X POST -H "Authorization: Bearer $TOKEN" -H 'Content-Type: application/json' \
	-d "{\"scene\": $SHORT, \"priority\": -10, \"submission_id\": \"c-{}\"}" "$URL/api/v1/jobs" >"$ids.raw"
/usr/bin/python3 -c 'import json,sys; [print(json.loads(l)["id"]) for l in open(sys.argv[1])]' "$ids.raw" | sort -u >"$ids" 2>/dev/null
ok $([ "$(wc -l <"$ids")" = 200 ]; echo $?) "200 concurrent submissions: $(wc -l <"$ids") distinct ids"
seq 1 200 | xargs -P 32 -I{} curl -s -X POST -H "Authorization: Bearer $TOKEN" -H 'Content-Type: application/json' \
	-d "{\"scene\": $SHORT, \"priority\": -10, \"submission_id\": \"c-{}\"}" "$URL/api/v1/jobs" >"$ids.raw2"
/usr/bin/python3 -c 'import json,sys; [print(json.loads(l)["id"]) for l in open(sys.argv[1])]' "$ids.raw2" | sort -u >"$ids.2"
cmp -s "$ids" "$ids.2"
ok $? "the same 200 submissions retried return the same 200 jobs"
for i in $(cat "$ids"); do post "/api/v1/jobs/$i/cancel" >/dev/null; done

# 6. Bad requests: status and a JSON error body each.
err_ok() { # err_ok CODE DESCRIPTION: checks CODE and the {"error":{"code","message"}} body
	ok $([ "$(code)" = "$1" ] && [ -n "$(field "$(cat "$tmp/body")" 'd["error"]["message"]')" ]; echo $?) \
		"$2: $CODE $(field "$(cat "$tmp/body")" 'd["error"]["message"]')"
}
post /api/v1/jobs -d '{"method":' >/dev/null; err_ok 400 "broken JSON"
post /api/v1/jobs -d '{"method":"ed","dimensions":2,"particles":{"count":10,"volume_fraction":0.95},"run":{"until":{"time":1}}}' >/dev/null
err_ok 400 "volume fraction above close packing"
case "$(field "$(cat "$tmp/body")" 'd["error"]["message"]')" in particles.volume_fraction*) ok 0 "the message starts with the key path" ;; *) ok 1 "the message starts with the key path" ;; esac
api POST /api/v1/jobs -H 'Content-Type: application/json' -d "$SHORT" >/dev/null; err_ok 401 "no token"
api POST /api/v1/jobs -H 'Authorization: Bearer nope' -H 'Content-Type: application/json' -d "$SHORT" >/dev/null; err_ok 401 "wrong token"
api DELETE "/api/v1/jobs/$id" -H 'Authorization: Bearer nope' >/dev/null; err_ok 401 "DELETE with a wrong token"
post /api/v1/jobs -H 'Host: evil.example:80' -d "$SHORT" >/dev/null; err_ok 403 "foreign Host (DNS rebinding)"
post /api/v1/jobs -H 'Origin: http://evil.example' -d "$SHORT" >/dev/null; err_ok 403 "cross-site Origin"
api GET /api/v1/nothing >/dev/null; err_ok 404 "unknown path"
api GET /api/v1/jobs/99999 >/dev/null; err_ok 404 "unknown job"
api GET /api/v1/jobs/abc >/dev/null; err_ok 404 "malformed job id"
api PUT /api/v1/jobs -H "Authorization: Bearer $TOKEN" >/dev/null; err_ok 405 "PUT on /jobs"
allow=$(curl -s -D - -o /dev/null -X PUT "$URL/api/v1/jobs" | tr -d '\r' | sed -n 's/^Allow: //p')
ok $([ "$allow" = "POST, GET" ]; echo $?) "405 lists Allow: $allow"
id5=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
api DELETE "/api/v1/jobs/$id5" -H "Authorization: Bearer $TOKEN" >/dev/null; err_ok 409 "DELETE of an unfinished job"
post /api/v1/jobs -d "{\"scene\": $(echo "$SHORT" | sed 's/"seed":3/"seed":4/'), \"submission_id\": \"c-1\"}" >/dev/null
err_ok 409 "a used submission_id with another scene"
post "/api/v1/jobs/$id5/cancel" >/dev/null
head -c 5000000 /dev/zero | tr '\0' ' ' >"$tmp/big"
post /api/v1/jobs --data-binary @"$tmp/big" >/dev/null; err_ok 413 "5 MB body (Content-Length over max_body)"
post /api/v1/jobs -H 'Transfer-Encoding: chunked' --data-binary @"$tmp/big" >/dev/null; err_ok 413 "5 MB chunked body"
api POST /api/v1/jobs -H "Authorization: Bearer $TOKEN" -H 'Content-Type: text/plain' -d "$SHORT" >/dev/null; err_ok 415 "text/plain body"
deep=$(/usr/bin/python3 -c 'print("["*100 + "]"*100)')
post /api/v1/jobs -d "{\"scene\": $deep}" >/dev/null; err_ok 400 "JSON nested 100 deep"
api GET '/api/v1/jobs?state=bogus' >/dev/null; err_ok 400 "bad state filter"
api GET '/api/v1/jobs?limit=0' >/dev/null; err_ok 400 "bad limit"

# 7. Listing: filters and cursor pagination.
p1=$(api GET '/api/v1/jobs?limit=50&state=cancelled')
cur=$(field "$p1" 'd["next_cursor"]')
p2=$(api GET "/api/v1/jobs?limit=50&state=cancelled&cursor=$cur")
ok $([ "$(field "$p1" 'len(d["jobs"])')" = 50 ] && [ "$(field "$p2" 'd["jobs"][0]["id"] < d["jobs"][-1]["id"] or len(d["jobs"])==1')" = False ] &&
     [ "$(field "$p2" 'all(j["state"]=="cancelled" for j in d["jobs"])')" = True ]; echo $?) "state filter and cursor pages (next_cursor $cur)"
cl=$(api GET /api/v1/cluster)
ok $([ "$(field "$cl" 'd["slots"]["total"]')" = 2 ] && [ "$(field "$cl" '"finished_last_hour" in d and "events_per_second" in d and "uptime_seconds" in d')" = True ]; echo $?) \
	"GET /cluster: slots, queue, throughput, uptime"
api GET /metrics >/dev/null
ok $([ "$(code)" = 200 ] && grep -q '^granulard_jobs{state="cancelled"} [1-9]' "$tmp/body"; echo $?) "GET /metrics in Prometheus text format"

# 8. DELETE a finished job removes its row and files.
api DELETE "/api/v1/jobs/$id" -H "Authorization: Bearer $TOKEN" >/dev/null
ok $([ "$(code)" = 200 ] && [ ! -d "$S/jobs/$id" ]; echo $?) "DELETE a finished job: 200 and its directory is gone"
api GET "/api/v1/jobs/$id" >/dev/null
ok $([ "$(code)" = 404 ]; echo $?) "then it is 404"

# 9. Graceful stop: SIGTERM interrupts running jobs and requeues them; mutations get 503 while draining.
id6=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$id6" running 30
sleep 0.5
gd_stop
ok $([ "$GD_RC" = 0 ]; echo $?) "SIGTERM: the daemon exits 0"
gd_start "$S" --slots 2 --cancel-grace 5
r=$(field "$(api GET "/api/v1/jobs/$id6")" 'd["attempts"][0]["reason"]')
case "$r" in *shutdown*) ok 0 "the running job was requeued: $r" ;; *) ok 1 "the running job was requeued: $r" ;; esac
post "/api/v1/jobs/$id6/cancel" >/dev/null
wait_state "$id6" cancelled 20
gd_stop

# 10. 429 when the queue is full; 503 for changes while the daemon drains.
printf '#!/bin/sh\n# a job that ignores SIGTERM (it must be killed)\ntrap "" TERM\nexec sleep 3600\n' >"$tmp/stubborn.sh"
chmod +x "$tmp/stubborn.sh"
S2=$tmp/state2
gd_start "$S2" --slots 1 --max-queued 1 --launch "$tmp/stubborn.sh {scene}" --shutdown-grace 8
a=$(field "$(post /api/v1/jobs -d "$SHORT")" 'd["id"]'); wait_state "$a" running 10
post /api/v1/jobs -d "$SHORT" >/dev/null
post /api/v1/jobs -D "$tmp/hdr" -d "$SHORT" >/dev/null; err_ok 429 "queue full (max_queued 1)"
grep -qi '^Retry-After: ' "$tmp/hdr"
ok $? "429 carries Retry-After"
kill -TERM "$GD_PID"; sleep 0.7
post /api/v1/jobs -d "$SHORT" >/dev/null; err_ok 503 "submission while the daemon drains its jobs"
h=$(api GET /healthz)
ok $([ "$(field "$h" 'd["status"]')" = stopping ]; echo $?) "healthz says stopping meanwhile"
wait "$GD_PID"; GD_PID=
gd_start "$S2" --slots 1 --max-queued 1 --launch "/bin/true"
ok $([ "$(field "$(api GET "/api/v1/jobs/$a")" 'd["attempts"][0]["signal"]')" = 9 ]; echo $?) \
	"a job that ignores SIGTERM was killed (SIGKILL) after shutdown_grace and requeued"
gd_stop

# 11. The per-attempt wall-time limit stops a job and says so.
gd_start "$tmp/state3" --slots 1 --max-wall-seconds 1 --cancel-grace 2
w=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$w" failed 30
r=$(field "$(api GET "/api/v1/jobs/$w")" 'd["reason"]')
case "$r" in "wall-time limit of 1 s exceeded"*) ok 0 "max_wall_seconds: $r" ;; *) ok 1 "max_wall_seconds: $r" ;; esac
gd_stop

# 12. systemd readiness: READY=1 on $NOTIFY_SOCKET once the listener is up, STOPPING=1 at the end.
/usr/bin/python3 - "$tmp/notify.sock" >"$tmp/notify.txt" <<'PYEOF' &
import socket, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.bind(sys.argv[1]); s.settimeout(20)
try:
    for _ in range(2):
        print(s.recv(4096).decode().replace("\n", " | "), flush=True)
except socket.timeout:
    pass
PYEOF
npid=$!
i=0; while [ ! -S "$tmp/notify.sock" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
export NOTIFY_SOCKET="$tmp/notify.sock"; gd_start "$tmp/state4" --slots 1; unset NOTIFY_SOCKET
api GET /healthz >/dev/null
gd_stop
wait $npid
grep -q '^READY=1' "$tmp/notify.txt" && grep -q 'STOPPING=1' "$tmp/notify.txt"
ok $? "sd_notify: $(tr '\n' ';' <"$tmp/notify.txt")"

# 13. A second daemon on the same state directory is refused; bad flags exit 2 with one line.
gd_start "$S" --slots 1
"$GRANULARD" --state-dir "$S" --listen 127.0.0.1:0 2>"$tmp/err2"
ok $([ $? -ne 0 ] && grep -q "another granulard" "$tmp/err2"; echo $?) "second daemon on the same state dir refused: $(cat "$tmp/err2")"
gd_stop
"$GRANULARD" --slots many 2>"$tmp/err3"
ok $([ $? = 2 ] && [ "$(wc -l <"$tmp/err3")" = 1 ]; echo $?) "bad flag: exit 2, one line: $(cat "$tmp/err3")"
printf 'slots = 4\nfrobs = 1\n' >"$tmp/conf"
"$GRANULARD" --config "$tmp/conf" 2>"$tmp/err4"
ok $([ $? = 2 ] && grep -q "conf:2: frobs" "$tmp/err4"; echo $?) "bad config key names file and line: $(cat "$tmp/err4")"

# 14. Advice and "method": "auto": estimates without a job, the decision stored in the job, its concrete scene run.
AUTO='{"method":"auto","accuracy":{"temperature":0.05},"dimensions":2,"particles":{"count":400,"volume_fraction":0.1,"initial":{"positions":"random","relax":{"collisions_per_particle":2}}},"collisions":{"restitution":0.9},"run":{"seed":5,"until":{"time":2},"replicas":2},"output":{"every":{"time":0.5},"observables":["temperature"]}}'
gd_start "$tmp/state5" --slots 2
adv=$(api POST /api/v1/advice -H 'Content-Type: application/json' -d "$AUTO")
choice=$(field "$adv" 'd["choice"]')
ok $([ "$(code)" = 200 ] && [ "$(field "$adv" '",".join(sorted({e["method"] for e in d["estimates"]}))')" = dsmc,ed,hsmc ] &&
     [ "$(field "$adv" 'all(e["cpu_seconds"] > 0 and e["error"]["temperature"] > 0 for e in d["estimates"])')" = True ] &&
     [ -n "$(field "$adv" 'd["reason"]')" ]; echo $?) "POST /advice (no token needed on loopback): 200, estimates for ed, dsmc, hsmc; choice $choice"
adv2=$(api POST /api/v1/advice -H 'Content-Type: application/json' -d "{\"scene\":$AUTO,\"ranks\":2}")
ok $([ "$(field "$adv2" 'd["scene"]["ranks"]')" = 2 ] && [ "$(field "$adv2" 'd["choice"]')" = "$choice" ] &&
     [ "$(field "$adv2" 'd["estimates"][0]["wall_seconds"] < d["estimates"][0]["cpu_seconds"]')" = True ]; echo $?) \
	"wrapper form with ranks 2: same choice, ed's wall time below its CPU time (2 replicas on 2 ranks)"
api POST /api/v1/advice -H 'Content-Type: application/json' -d "$(echo "$AUTO" | sed 's/"temperature":0.05/"temperature":-1/')" >/dev/null
ok $([ "$(code)" = 400 ] && grep -q '"accuracy.temperature: must be between 0 and 1' "$tmp/body"; echo $?) "bad target: 400 naming accuracy.temperature"
api POST /api/v1/advice -H 'Content-Type: application/json' -d "{\"scene\":$(echo "$AUTO" | sed 's/"count":400/"count":"many"/')}" >/dev/null
ok $([ "$(code)" = 400 ] && grep -q '"scene.particles.count: ' "$tmp/body"; echo $?) "bad scene in the wrapper: 400 naming scene.particles.count"
body=$(post /api/v1/jobs -d "$AUTO")
aid=$(field "$body" 'd["id"]')
ok $([ "$(code)" = 201 ] && [ "$(field "$body" 'd["method"]')" = "$choice" ] &&
     [ "$(field "$body" 'd["advice"]["choice"]')" = "$choice" ]; echo $?) "auto job $aid: method $choice, the decision in advice"
wait_state "$aid" succeeded 60
ok $? "auto job $aid succeeded"
job=$(api GET "/api/v1/jobs/$aid")
ok $([ "$(field "$job" 'd["scene"]["method"]')" = "$choice" ] && [ "$(field "$job" '"accuracy" in d["scene"]')" = False ] &&
     [ "$(field "$job" 'd["advice"]["scene"]["method"]')" = auto ] && [ "$(field "$job" 'd["advice"]["target"]["temperature"]')" = 0.05 ] &&
     grep -q "\"method\":\"$choice\"" "$tmp/state5/jobs/$aid/scene.json" &&
     [ "$(field "$job" 'all(d["scene"].get(k) == v for k, v in d["advice"]["resolved"].items())')" = True ]; echo $?) \
	"GET /jobs/$aid: the concrete scene ran (method $choice with the chosen settings, no accuracy); advice keeps the request"
cj=$(post /api/v1/jobs -d "$SHORT")
ok $([ "$(code)" = 201 ] && [ "$(field "$cj" 'd["advice"]')" = None ] && [ "$(field "$cj" 'd["method"]')" = ed ]; echo $?) "a job with a concrete method carries advice null"
gd_stop

# 15. A version-1 database (before advice) is upgraded in place and its jobs kept.
mkdir -p "$tmp/state6"
/usr/bin/python3 - "$SRCDIR/schema/001_jobs.sql" "$tmp/state6/granulard.db" <<'PYEOF'
import sqlite3, sys
db = sqlite3.connect(sys.argv[2])
db.executescript(open(sys.argv[1]).read())
db.execute("PRAGMA user_version=1")
db.execute("INSERT INTO jobs(scene, scene_hash, method, particles, state, created_at, updated_at, finished_at, "
           "progress_seq) VALUES ('{\"method\":\"ed\"}', '0', 'ed', 400, 'succeeded', 1, 1, 1, 5)")
for seq in (0, 2, 4):   # 5 records received, downsampled to 3
    db.execute("INSERT INTO progress(job_id, seq, attempt, time, record) VALUES (1, ?, 1, ?, ?)",
               (seq, seq, '{"type":"progress","time":%d}' % seq))
db.commit()
PYEOF
gd_start "$tmp/state6" --slots 1
old=$(api GET /api/v1/jobs/1)
ok $([ "$(code)" = 200 ] && [ "$(field "$old" 'd["state"]')" = succeeded ] && [ "$(field "$old" 'd["advice"]')" = None ]; echo $?) \
	"version-1 database: job 1 still there after the upgrade, advice null"
ok $([ "$(field "$old" 'd["progress_records"]["received"] == 5 and d["progress_records"]["stored"] == 3 and d["progress_records"]["thinned"] == 0')" = True ]; echo $?) \
	"its progress counts are filled in by the upgrade: $(field "$old" 'd["progress_records"]')"
new=$(field "$(post /api/v1/jobs -d "$AUTO")" 'd["advice"]["choice"]')
ok $([ "$new" = "$choice" ]; echo $?) "the upgraded database takes auto jobs (choice $new)"
gd_stop
v=$(/usr/bin/python3 -c 'import sqlite3,sys; print(sqlite3.connect(sys.argv[1]).execute("PRAGMA user_version").fetchone()[0])' "$tmp/state6/granulard.db")
latest=$(ls "$SRCDIR"/schema/[0-9][0-9][0-9]_*.sql | wc -l)
ok $([ "$v" = "$latest" ]; echo $?) "database schema version is now $v (the latest, $latest)"

finish
