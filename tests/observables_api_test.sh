#!/bin/sh
# GET /api/v1/jobs/{id}/observables against a real daemon and engine: the curves of a finished job by family,
# first/last N, errors naming the parameter, authorisation as the other GETs (issue 17).
set -u
. "$(dirname "$0")/daemon_lib.sh"
gd_start "$tmp/state" --slots 1 --read-auth token
A="Authorization: Bearer $TOKEN"
SC='{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.2,"initial":{"positions":"random"}},"collisions":{"restitution":0.9},"run":{"seed":3,"until":{"time":2}},"output":{"every":{"time":0.25},"observables":["temperature","impact_parameter","pair_correlation","mean_square_displacement","fields","density_spectrum","flux"],"fields":{"cells":[4,4],"exposure":0.5,"samples":5},"density_spectrum":{"interval":0.05,"slices":8},"snapshots":{"every":{"time":0.5}}}}'
id=$(field "$(post /api/v1/jobs -d "$SC")" 'd["id"]')
wait_state "$id" succeeded 60 || true
ok $([ "$(field "$(api GET "/api/v1/jobs/$id" -H "$A")" 'd["state"]')" = succeeded ]; echo $?) "job $id with curves succeeded"

b=$(api GET "/api/v1/jobs/$id/observables?name=impact_parameter" -H "$A")
ok $([ "$(code)" = 200 ] && [ "$(field "$b" '",".join(str(s["sample"]) for s in d["samples"])')" = 0,1,2,3,4 ] &&
	[ "$(field "$b" 'd["samples"][1]["tables"][0]["x"]')" = b ] && [ "$(field "$b" 'd["truncated"]')" = False ]; echo $?) \
	"name=impact_parameter: samples 0..4 (t = 0, 0.5, ..., 2), table over b: $(code) $(echo "$b" | head -c 150)"
b=$(api GET "/api/v1/jobs/$id/observables?name=fields&last=1" -H "$A")
ok $([ "$(code)" = 200 ] && [ "$(field "$b" '[t["table"] for t in d["samples"][0]["tables"]]')" = "['density', 'velocity', 'temperature']" ] &&
	[ "$(field "$b" 'd["samples"][0]["tables"][0]["shape"]')" = "[4, 4]" ] && [ "$(field "$b" 'd["samples"][0]["samples"]')" = 5 ] &&
	[ "$(field "$b" 'round(sum(d["samples"][0]["tables"][0]["columns"]["count"]), 6)')" = 400.0 ]; echo $?) \
	"name=fields: the last sample's density, velocity and temperature on the 4 x 4 grid, 5 instants, counts summing to N: $(code)"
b=$(api GET "/api/v1/jobs/$id/observables?name=density_spectrum&last=1" -H "$A")
ok $([ "$(code)" = 200 ] && [ "$(field "$b" 'd["samples"][0]["tables"][0]["x"]')" = f ] &&
	[ "$(field "$b" 'len(d["samples"][0]["tables"][0]["columns"]["P"])')" = 4 ] && [ "$(field "$b" 'd["samples"][0]["samples"]')" = 10 ] &&
	[ "$(field "$b" 'type(d["samples"][0]["alpha"]).__name__')" = float ]; echo $?) \
	"name=density_spectrum: the last spectrum over f (m = 10 samples of 0.05, 4 frequencies) with its slope alpha: $(code)"
b=$(api GET "/api/v1/jobs/$id/observables?name=pair_correlation&last=1" -H "$A")
ok $([ "$(field "$b" '[s["sample"] for s in d["samples"]]')" = "[4]" ] && [ "$(field "$b" 'd["next"]')" = 4 ]; echo $?) \
	"last=1: the last sample only, next = 4"
b=$(api GET "/api/v1/jobs/$id/observables?name=pair_correlation&after=1&limit=2" -H "$A")
ok $([ "$(field "$b" '[s["sample"] for s in d["samples"]]')" = "[2, 3]" ] && [ "$(field "$b" 'd["truncated"]')" = True ]; echo $?) \
	"after=1&limit=2: samples 2, 3, truncated (more follow)"

# surface_profile (issue 13, the heap): an hsmc job with a particles.source; the last profile counts the particles
# present (2 + 24 inserted by t = 25: the k-th at k / rate, k / rate < 25).
SC2='{"method":"hsmc","dimensions":2,"particles":{"count":2,"box":[30,20],"initial":{"positions":"random","temperature":0},"source":{"count":40,"rate":1,"position":[15],"height":3}},"collisions":{"restitution":0.9},"boundaries":{"y":{"type":"walls","lower":{"type":"specular","restitution":0.5},"upper":{"type":"specular"}}},"gravity":[0,-10],"run":{"seed":3,"until":{"time":25}},"output":{"every":{"time":5},"observables":["kinetic_energy","outflow","surface_profile"],"surface_profile":{"bins":15},"snapshots":{"every":{"time":12.5}}},"hsmc":{"time_step":0.01}}'
id2=$(field "$(post /api/v1/jobs -d "$SC2")" 'd["id"]')
wait_state "$id2" succeeded 60 || true
b=$(api GET "/api/v1/jobs/$id2/observables?name=surface_profile&last=1" -H "$A")
ok $([ "$(code)" = 200 ] && [ "$(field "$b" 'd["samples"][0]["tables"][0]["x"]')" = x ] &&
	[ "$(field "$b" 'len(d["samples"][0]["tables"][0]["columns"]["h"])')" = 15 ] &&
	[ "$(field "$b" 'sum(d["samples"][0]["tables"][0]["columns"]["n"])')" = 26 ]; echo $?) \
	"name=surface_profile: the last h(x) of a job with a source, 15 bins holding its 26 particles: $(code) $(echo "$b" | head -c 120)"

# errors: 400 with a JSON body naming the parameter
errck() {   # QUERY WORD
	b=$(api GET "/api/v1/jobs/$id/observables$1" -H "$A")
	ok $([ "$(code)" = 400 ] && [ "$(field "$b" 'd["error"]["code"]')" = bad_request ] &&
		field "$b" 'd["error"]["message"]' | grep -q "^$2"; echo $?) "$1: 400 naming $2: $(field "$b" 'd["error"]["message"]' | head -c 120)"
}
errck "" "name"
errck "?name=temperature" "name"
errck "?name=clusters&limit=0" "limit"
errck "?name=clusters&last=5000" "last"
errck "?name=clusters&limit=2&last=2" "last"
errck "?name=clusters&after=x" "after"
api GET "/api/v1/jobs/999/observables?name=clusters" -H "$A" >/dev/null
ok $([ "$(code)" = 404 ]; echo $?) "unknown job: 404"
api GET "/api/v1/jobs/$id/observables?name=clusters" >/dev/null
ok $([ "$(code)" = 401 ]; echo $?) "read_auth token: without the token 401, like the other GETs"
# granularctl prints the curves as CSV (the last sample; --after K: every sample after K)
: "${GRANULARCTL:=$BUILDDIR/client/granularctl}"
"$GRANULARCTL" --state-dir "$tmp/state" observables "$id" impact_parameter >"$tmp/pb.csv" 2>"$tmp/ctl.err"
rc=$?
ok $([ $rc = 0 ] && [ "$(sed -n 2p "$tmp/pb.csv")" = "sample,time,table,b,p,n" ] && [ "$(grep -c '^4,2,,' "$tmp/pb.csv")" = 20 ]; echo $?) \
	"granularctl observables ID impact_parameter: CSV of the last sample, 20 bins (rc $rc; $(sed -n 3p "$tmp/pb.csv"))"
"$GRANULARCTL" --state-dir "$tmp/state" observables "$id" fields >"$tmp/f.csv" 2>"$tmp/ctl.err"
ok $([ "$(sed -n 2p "$tmp/f.csv")" = "sample,time,table,cell,n,count" ] && [ "$(grep -c '^4,2,density,' "$tmp/f.csv")" = 16 ] &&
	[ "$(grep -c '^4,2,temperature,' "$tmp/f.csv")" = 16 ]; echo $?) \
	"granularctl observables ID fields: CSV, one row per cell and table ($(sed -n 3p "$tmp/f.csv"))"
"$GRANULARCTL" --state-dir "$tmp/state" observables "$id" pair_correlation --after 2 >"$tmp/g.csv" 2>"$tmp/ctl.err"
ok $([ "$(grep -c '^# pair_correlation sample' "$tmp/g.csv")" = 2 ]; echo $?) "granularctl observables --after 2: samples 3 and 4"
"$GRANULARCTL" --state-dir "$tmp/state" observables "$id" 'clusters&last=2' >/dev/null 2>"$tmp/ctl.err"
ok $([ $? = 2 ] && grep -q "NAME" "$tmp/ctl.err"; echo $?) "granularctl observables: a NAME that is not a family name is a usage error (exit 2)"
gd_stop
finish
