#!/bin/sh
# Admission control and "validate means runnable" with the real daemon and engine: memory, replicas, output limits, launch template.
set -u
. "$(dirname "$0")/daemon_lib.sh"

# Stopped by the test, never finished (2e6 records if it ran: within the output limit).
LONG='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e5}},"output":{"every":{"time":0.05}}}'
BIG='{"method":"ed","dimensions":3,"particles":{"count":100000000,"volume_fraction":0.3},"run":{"until":{"time":1}}}'
REPL='{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.2},"run":{"until":{"time":1},"replicas":1000000}}'
# As LONG, with a record every 1000 time units: its estimated output (~4 MB) fits a 20 MB limit.
QUIET='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e5}},"output":{"every":{"time":1000}}}'
TINY='{"method":"dsmc","dimensions":2,"particles":{"count":1000,"volume_fraction":0.1},"run":{"until":{"time":1}},"dsmc":{"cell_size":1e-9}}'
msg() { field "$1" 'd["error"]["message"]'; }

# 1. The launch template is checked when the daemon starts: an unknown placeholder, or one inside a word,
#    and it refuses to start with one line naming the key; its jobs stay as they were.
S=$tmp/state
gd_start "$S" --slots 1
id_run=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
id_q=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$id_run" running 30
gd_stop
for tpl in '{mpirun} --stdin none -np {ranks} {engine} run {scene} --out {dir} {nope}' \
           '{mpirun} -np {ranks} {engine} run {scene} --out={dir}'; do
	# (timeout: a daemon that takes the template serves until stopped; 124 then)
	timeout 20 "$GRANULARD" --state-dir "$S" --listen 127.0.0.1:0 --engine "$ENGINE" --launch "$tpl" >"$tmp/out" 2>"$tmp/err"
	rc=$?
	ok $([ $rc = 2 ] && [ "$(wc -l <"$tmp/err")" = 1 ] && grep -q '^granulard: --launch: ' "$tmp/err" && [ ! -s "$tmp/out" ]; echo $?) \
		"bad template refused at start (exit $rc): $(cat "$tmp/err")"
done
printf 'launch = {mpirun} -np {ranks} {engine} run {scene} {dir} {nope}\n' >"$tmp/bad.conf"
timeout 20 "$GRANULARD" --state-dir "$S" --listen 127.0.0.1:0 --config "$tmp/bad.conf" >/dev/null 2>"$tmp/err"
rc=$?
ok $([ $rc = 2 ] && grep -q "bad.conf:1: launch: unknown placeholder {nope}" "$tmp/err"; echo $?) \
	"in a config file too, with FILE:LINE (exit $rc): $(cat "$tmp/err")"
gd_start "$S" --slots 1
ok $([ "$(field "$(api GET "/api/v1/jobs/$id_q")" 'd["state"]')" = queued ] &&
     [ "$(field "$(api GET "/api/v1/jobs/$id_run")" 'd["attempts"][0]["reason"]')" != None ]; echo $?) \
	"the refused starts touched nothing: job $id_q still queued, job $id_run requeued by the earlier shutdown"
for j in $id_run $id_q; do post "/api/v1/jobs/$j/cancel" >/dev/null; done
wait_state "$id_run" cancelled 30
gd_stop

# 2. What can never fit is refused at submission, naming the key and the estimate (budget 400 MB).
S=$tmp/state2
gd_start "$S" --slots 2 --memory-budget 400000000
b=$(post /api/v1/jobs -d "$BIG")
case "$(msg "$b")" in "particles.count: the job needs an estimated "*" GB ("*" bytes) of memory"*"memory_budget of 400 MB"*)
	ok $([ "$(code)" = 400 ]; echo $?) "1e8 particles: $(code) $(msg "$b")" ;;
*) ok 1 "1e8 particles: $(code) $b" ;; esac
b=$(post /api/v1/jobs -d "$REPL")
ok $([ "$(code)" = 400 ] && [ "$(msg "$b")" = "run.replicas: 1000000 exceeds this server's limit of 1000 (max_replicas)" ]; echo $?) \
	"1e6 replicas: $(code) $(msg "$b")"
v=$(post /api/v1/scenes/validate -d "{\"scene\":$BIG}")
ok $([ "$(code)" = 400 ] && case "$(msg "$v")" in scene.particles.count:*) true ;; *) false ;; esac; echo $?) \
	"POST /scenes/validate refuses it alike: $(code)"

# 3. Validate = submit = start: what the engine refuses at start is refused at every door, with its message.
"$ENGINE" validate /dev/stdin <<EOF 2>"$tmp/eng" >/dev/null
$TINY
EOF
erc=$?
v=$(post /api/v1/scenes/validate -d "$TINY"); vc=$(code)
a=$(post /api/v1/advice -d "$TINY"); ac=$(code)
s=$(post /api/v1/jobs -d "$TINY"); sc=$(code)
ok $([ $erc = 2 ] && [ "$vc$ac$sc" = 400400400 ] && [ "$(msg "$v")" = "$(cat "$tmp/eng")" ] && [ "$(msg "$a")" = "$(msg "$v")" ] &&
     [ "$(msg "$s")" = "$(msg "$v")" ]; echo $?) "dsmc cell_size 1e-9: engine validate exit $erc, validate/advice/submit $vc/$ac/$sc, one message: $(cat "$tmp/eng")"
v=$(post /api/v1/scenes/validate -d "$LONG")
M=$(field "$v" 'd["resources"]["memory_bytes"]')
ok $([ "$(code)" = 200 ] && [ "$(field "$v" 'd["valid"]')" = True ] && [ "$M" -gt 40000000 ] && [ "$M" -lt 200000000 ]; echo $?) \
	"a runnable scene validates: 200, method $(field "$v" 'd["method"]'), memory $M bytes, output $(field "$v" 'd["resources"]["output_bytes"]') bytes"
gd_stop

# 4. What fits alone but not beside a running job waits in the queue with slots free, then runs.
S=$tmp/state3
gd_start "$S" --slots 2 --memory-budget $((M * 3 / 2)) --max-job-output 1000000000 --cancel-grace 5
a=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
wait_state "$a" running 30
b=$(field "$(post /api/v1/jobs -d "$LONG")" 'd["id"]')
sleep 2
ok $([ "$(field "$(api GET "/api/v1/jobs/$b")" 'd["state"]')" = queued ] &&
     [ "$(field "$(api GET "/api/v1/jobs/$a")" 'd["state"]')" = running ]; echo $?) \
	"budget 1.5 x one job, 2 slots: job $b waits (a slot free) while job $a runs"
job=$(api GET "/api/v1/jobs/$b")
ok $([ "$(field "$job" 'd["resources"]["memory_bytes"]')" = "$M" ]; echo $?) "the job carries its estimate: resources $(field "$job" 'd["resources"]')"
post "/api/v1/jobs/$a/cancel" >/dev/null
wait_state "$b" running 30
ok $? "when job $a ends, job $b starts"

# 5. Output limits are measured while the job runs: a job directory that outgrows max_output_bytes (here by a
#    file written beside the engine's) stops the job, which fails with the reason. LONG itself would be refused
#    (2e6 progress lines, ~0.7 GB by estimate).
c=$(field "$(post /api/v1/jobs -d "{\"scene\":$QUIET,\"max_output_bytes\":20000000}")" 'd["id"]')
ok $([ "$(code)" = 201 ] && [ "$(field "$(api GET "/api/v1/jobs/$c")" 'd["resources"]["max_output_bytes"]')" = 20000000 ]; echo $?) \
	"a job with its own output limit (20 MB) is queued"
post "/api/v1/jobs/$b/cancel" >/dev/null
wait_state "$c" running 30
dd if=/dev/zero of="$S/jobs/$c/extra.bin" bs=1M count=25 2>/dev/null
wait_state "$c" failed 30
r=$(field "$(api GET "/api/v1/jobs/$c")" 'd["reason"]')
# (measured once a second: dd may still be writing extra.bin then)
case "$r" in "output limit exceeded: the job directory holds "*" bytes (largest: extra.bin, "*" bytes), more than its limit of 20000000 bytes"*)
	ok 0 "the job failed: $r" ;;
*) ok 1 "the job failed: $r" ;; esac
b2=$(post /api/v1/jobs -d "{\"scene\":$LONG,\"max_output_bytes\":100}")
ok $([ "$(code)" = 400 ] && case "$(msg "$b2")" in max_output_bytes:*) true ;; *) false ;; esac; echo $?) "max_output_bytes below 1 MiB: $(code) $(msg "$b2")"
SNAP='{"method":"ed","dimensions":3,"particles":{"count":40000,"volume_fraction":0.3},"run":{"until":{"time":1}},"output":{"snapshots":{"every":{"time":0.001}}}}'
b2=$(post /api/v1/jobs -d "$SNAP")
case "$(msg "$b2")" in "output.snapshots.every: the job would write an estimated "*"1001 frames"*"max_job_output)") ok $([ "$(code)" = 400 ]; echo $?) "1001 frames of 4e4 particles (1.9 GB) above a 1 GB max_job_output: $(msg "$b2")" ;;
*) ok 1 "1001 frames of 4e4 particles: $(code) $b2" ;; esac
gd_stop
finish
