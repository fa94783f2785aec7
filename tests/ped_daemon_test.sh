#!/bin/sh
# A 2-rank split ed job through the real daemon (TAP): the engine's per-rank load, rollbacks, syncs, sync interval
# and rebalances reach the stored progress series and the job resource ("split") over REST; a serial job has none.
. "$(dirname "$0")/daemon_lib.sh"
if ! command -v mpirun >/dev/null 2>&1; then
	echo "1..0 # SKIP no mpirun"
	exit 0
fi
S=$tmp/state
mkdir -p "$S"
gd_start "$S" --slots 2
[ -n "$TOKEN" ] && [ "$URL" != "http://" ]
ok $? "granulard started"

# A gas started in the lower 40% of its box, balanced (run.balance "events"), on 2 ranks: 2000 disks to t = 2.
STEP='{"method":"ed","dimensions":2,"particles":{"count":2000,"box":[100,100],"initial":{"positions":"random","region":{"upper":[100,40]}}},"run":{"until":{"time":2},"balance":"events"},"output":{"every":{"time":0.2}}}'
id=$(field "$(post /api/v1/jobs -d "{\"scene\":$STEP,\"ranks\":2}")" 'd["id"]')
wait_state "$id" succeeded 120
ok $? "split job $id on 2 ranks succeeded"

job=$(api GET "/api/v1/jobs/$id")
chk=$(field "$job" '(lambda s: s["ranks"] == 2 and len(s["rank_events"]) == 2 and len(s["rank_particles"]) == 2 and sum(s["rank_particles"]) == 2000 and min(s["rank_events"]) > 0 and s["syncs"] > 0 and s["rollbacks"] >= 0 and s["sync_interval"] > 0 and s["rebalances"] >= 1 and s["time"] == 2)(d["split"])')
ok $([ "$chk" = True ]; echo $?) "GET /jobs/$id: split = $(field "$job" 'json.dumps(d["split"])') (2 ranks, their events and particles, syncs, sync interval, a rebalance)"

# The stored series: every progress record carries the fields, and the job's split is its newest record's.
ser=$(api GET "/api/v1/jobs/$id/progress")
chk=$(field "$ser" '(lambda R: len(R) >= 11 and all(r["ranks"] == 2 and len(r["rank_events"]) == 2 and "rollbacks" in r and "sync_interval" in r for r in R))([r for r in d["records"] if r["type"] == "progress"])')
ok $([ "$chk" = True ]; echo $?) "GET /jobs/$id/progress: every progress record has ranks, rank_events, rollbacks, sync_interval"
last=$(field "$ser" 'json.dumps([d["records"][-1][k] for k in ("rank_events", "rank_particles", "rollbacks", "syncs", "sync_interval", "rebalances")])')
mine=$(field "$job" 'json.dumps([d["split"][k] for k in ("rank_events", "rank_particles", "rollbacks", "syncs", "sync_interval", "rebalances")])')
ok $([ -n "$last" ] && [ "$last" = "$mine" ]; echo $?) "the job's split equals the newest stored record's fields ($mine)"

# A serial job: no split fields anywhere.
SER='{"method":"ed","dimensions":2,"particles":{"count":500,"volume_fraction":0.2},"run":{"until":{"time":1}}}'
id2=$(field "$(post /api/v1/jobs -d "{\"scene\":$SER}")" 'd["id"]')
wait_state "$id2" succeeded 60
ok $? "serial job $id2 succeeded"
job2=$(api GET "/api/v1/jobs/$id2")
ser2=$(api GET "/api/v1/jobs/$id2/progress")
ok $([ "$(field "$job2" 'd["split"] is None')" = True ] && [ "$(field "$ser2" 'any("ranks" in r for r in d["records"])')" = False ]; echo $?) \
	"serial job: split null, no record with ranks"
gd_stop
finish
