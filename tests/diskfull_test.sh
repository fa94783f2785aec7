#!/bin/sh
# granulard on a full disk: jobs fail with a clear reason, the database stays consistent, the daemon keeps serving.
set -u
. "$(dirname "$0")/daemon_lib.sh"
M=$tmp/small
mkdir -p "$M"
if [ "$(id -u)" != 0 ] || ! mount -t tmpfs -o size=16m tmpfs "$M" 2>/dev/null; then
	echo "1..0 # SKIP needs root to mount a small tmpfs"
	exit 0
fi
trap 'kill -9 $GD_PID 2>/dev/null; pkill -9 -f "$M/" 2>/dev/null; sleep 0.2; umount "$M"; rm -rf "$tmp"' EXIT
gd_start "$M/state" --slots 1 --disk-reserve 524288 --max-progress-records 16
# A job whose output (progress.jsonl, every record with cluster histograms) outgrows the 4 MB file system.
BIG='{"method":"ed","dimensions":2,"particles":{"count":2000,"volume_fraction":0.3},"run":{"until":{"time":1000}},"output":{"every":{"time":0.001},"observables":["kinetic_energy","pressure","collision_rate","clusters"]}}'
# Fill the disk to within ~1 MB, so the job's files quickly take the rest.
sleep 0.5
free=$(df -k --output=avail "$M" | tail -n 1)
dd if=/dev/zero of="$M/filler" bs=1k count=$((free - 1024)) 2>/dev/null
id=$(field "$(post /api/v1/jobs -d "$BIG")" 'd["id"]')
wait_state "$id" failed 60 || { echo "# state: $(api GET "/api/v1/jobs/$id?scene=0" | head -c 600)"; tail -5 "$M/state.log" | sed "s/^/# /"; df -k "$M" | sed "s/^/# /"; ls -la "$M/state" | sed "s/^/# /"; }
ok $? "the job failed when the disk filled"
j=$(api GET "/api/v1/jobs/$id")
r=$(field "$j" 'd["reason"]')
case "$r" in *"No space left"*|*"space"*|*"write"*) ok 0 "reason names the cause: $r" ;; *) ok 1 "reason names the cause: $r" ;; esac
h=$(api GET /healthz)
ok $([ "$(code)" = 200 ] && [ "$(field "$h" 'd["status"]')" = disk_full ]; echo $?) "healthz still 200 on a full disk, status disk_full"
# Submissions either succeed or are refused cleanly (503) while the disk is full; never a crash.
codes=""
for i in 1 2 3 4 5; do post /api/v1/jobs -d '{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.2},"run":{"until":{"time":0.01}}}' >/dev/null; codes="$codes $(code)"; done
ok $(for c in $codes; do case $c in 201|503) ;; *) exit 1 ;; esac; done; echo $?) "submissions on a full disk answer 201 or 503: $codes"
kill -0 "$GD_PID"
ok $? "the daemon is still running"
# Free the space: the service recovers.
api DELETE "/api/v1/jobs/$id" -H "Authorization: Bearer $TOKEN" >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "deleting the failed job works on a full disk"
rm -f "$M/filler"
i=0; until [ "$(field "$(api GET /healthz)" 'd["status"]')" = ok ] || [ $i -ge 150 ]; do sleep 0.1; i=$((i + 1)); done
ok $([ $i -lt 150 ]; echo $?) "once space is free the daemon lifts the stop by itself (healthz ok)"
n2=$(field "$(post /api/v1/jobs -d '{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.2},"run":{"until":{"time":0.01}}}')" 'd["id"]')
wait_state "$n2" succeeded 30
ok $? "after freeing space a new job runs to success"
gd_stop
gd_start "$M/state" --slots 1 --disk-reserve 524288 --max-progress-records 16
api GET "/api/v1/jobs/$n2" >/dev/null
ok $([ "$(code)" = 200 ]; echo $?) "database intact after restart"
gd_stop
finish
