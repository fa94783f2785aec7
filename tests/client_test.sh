#!/bin/sh
# Integration test of granularctl against a real granulard and engine: every command, --json, exit codes, messages.
set -u
. "$(dirname "$0")/daemon_lib.sh"
: "${GRANULARCTL:=$BUILDDIR/client/granularctl}"
PY=/usr/bin/python3

# ctl ARGS...: run granularctl; stdout in $tmp/out, stderr in $tmp/err, status in RC.
ctl() { "$GRANULARCTL" "$@" >"$tmp/out" 2>"$tmp/err"; RC=$?; }
out() { cat "$tmp/out"; }
err() { cat "$tmp/err"; }
# jsonok EXPR: the last stdout is JSON and EXPR (python, on d) holds.
jsonok() { "$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(0 if eval(sys.argv[2]) else 1)' "$tmp/out" "$1" 2>/dev/null; }
# one_line: stderr is exactly one line starting "granularctl: " (a usage hint may follow on a "Try" line).
one_line() { [ "$(grep -vc '^Try ' "$tmp/err")" = 1 ] && grep -q '^granularctl: ' "$tmp/err"; }

SHORT='{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.2},"collisions":{"restitution":0.9},"run":{"seed":3,"until":{"time":0.5}},"output":{"every":{"time":0.05},"observables":["kinetic_energy","temperature","collision_rate","clusters"]}}'
LONG='{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},"run":{"seed":1,"until":{"time":1e5}},"output":{"every":{"time":0.05}}}'
echo "$SHORT" >"$tmp/short.json"
echo "$LONG" >"$tmp/long.json"

# 1. Offline: help and usage errors (exit 2, one line naming the argument).
ctl --help
ok $([ $RC = 0 ] && grep -q '^  submit' "$tmp/out" && grep -q 'Exit status' "$tmp/out"; echo $?) "--help lists the commands and exit statuses"
bad=
for c in submit advise validate list show watch cancel delete progress clusters files download cluster presets; do
	ctl "$c" --help
	[ $RC = 0 ] && grep -q "^usage: granularctl $c" "$tmp/out" || bad="$bad $c"
done
ok $([ -z "$bad" ]; echo $?) "every command has --help${bad:+ (not:$bad)}"
ctl; ok $([ $RC = 2 ]; echo $?) "no command: exit 2"
ctl frobnicate; ok $([ $RC = 2 ] && one_line && grep -q "unknown command 'frobnicate'" "$tmp/err"; echo $?) "unknown command: exit 2, named"
ctl show abc; ok $([ $RC = 2 ] && one_line && grep -q "ID 'abc'" "$tmp/err"; echo $?) "non-numeric id: exit 2, $(head -1 "$tmp/err")"
ctl list --wait; ok $([ $RC = 2 ] && grep -q -- "--wait: not an option of 'list'" "$tmp/err"; echo $?) "option of another command: exit 2"
ctl list --limit zero; ok $([ $RC = 2 ] && grep -q -- "--limit 'zero'" "$tmp/err"; echo $?) "bad --limit: exit 2"
ctl submit; ok $([ $RC = 2 ]; echo $?) "submit without a scene: exit 2"
ctl submit "$tmp/none.json" --url http://127.0.0.1:1; ok $([ $RC = 2 ] && grep -q 'none.json' "$tmp/err"; echo $?) "missing scene file: exit 2, named"
ctl submit "$tmp/short.json" --set novalue --url http://127.0.0.1:1; ok $([ $RC = 2 ] && grep -q "'novalue'" "$tmp/err"; echo $?) "bad --set: exit 2"

# 2. Daemon down or absent: exit 3, the URL is named.
ctl list --url http://127.0.0.1:1
ok $([ $RC = 3 ] && one_line && grep -q 'http://127.0.0.1:1/api/v1/jobs' "$tmp/err"; echo $?) "daemon down: exit 3, $(cat "$tmp/err")"
ctl list --state-dir "$tmp/nowhere"
ok $([ $RC = 3 ] && grep -q 'nowhere/granulard.addr' "$tmp/err"; echo $?) "no daemon in the state dir: exit 3, the file is named"

# 3. A real daemon with its default state directory ./var: the client finds it with no set-up at all.
cd "$tmp" || exit 1
unset GRANULAR_URL GRANULAR_TOKEN GRANULAR_STATE_DIR
gd_start var --slots 2 --cancel-grace 5
ctl cluster
ok $([ $RC = 0 ] && grep -q "at $URL" "$tmp/out" && grep -q 'slots *0 used of 2' "$tmp/out"; echo $?) "cluster: found the daemon via STATE_DIR/granulard.addr"
ctl cluster --json; ok $([ $RC = 0 ] && jsonok 'd["slots"]["total"] == 2 and "uptime_seconds" in d'; echo $?) "cluster --json"
ctl presets
ok $([ $RC = 0 ] && grep -q '^cooling-2d ' "$tmp/out" && grep -q '^clustering-3d ' "$tmp/out"; echo $?) "presets: table"
ctl presets --json
ok $([ $RC = 0 ] && jsonok 'len(d["presets"]) >= 4 and {p["dimensions"] for p in d["presets"]} == {2, 3}'; echo $?) "presets --json: 2D and 3D"

# 4. submit (file), watch to the end, show, progress, clusters.
ctl submit "$tmp/short.json"
id=$(sed -n 's/^job \([0-9]*\) submitted.*/\1/p' "$tmp/out")
ok $([ $RC = 0 ] && [ -n "$id" ]; echo $?) "submit FILE: $(out)"
ctl watch "$id"
ok $([ $RC = 0 ] && grep -q "job $id succeeded" "$tmp/out" && grep -q '100.0%' "$tmp/out" && grep -q 'ETA' "$tmp/out" && grep -q 'T=' "$tmp/out"; echo $?) \
	"watch follows job $id to success: exit 0, percent, ETA, temperature"
ctl show "$id"; ok $([ $RC = 0 ] && grep -q "job $id  succeeded" "$tmp/out" && grep -q 'attempt 1 .*exit 0' "$tmp/out"; echo $?) "show: state and attempt"
ctl show "$id" --json; ok $([ $RC = 0 ] && jsonok 'd["state"] == "succeeded" and d["scene"]["particles"]["count"] == 400'; echo $?) "show --json: the record with its scene"
ctl progress "$id"; ok $([ $RC = 0 ] && [ "$(grep -c ' progress ' "$tmp/out")" = 11 ] && grep -q ' summary ' "$tmp/out"; echo $?) "progress: 11 records and the summary"
ctl progress "$id" --after 9 --json; ok $([ $RC = 0 ] && jsonok 'all(r["seq"] > 9 for r in d["records"]) and len(d["records"]) > 0'; echo $?) "progress --after --json"
ctl clusters "$id"; ok $([ $RC = 0 ] && [ "$(grep -c '^[0-9]' "$tmp/out")" = 11 ]; echo $?) "clusters: 11 rows"
ctl clusters "$id" --json; ok $([ $RC = 0 ] && jsonok 'd["series"][0]["clusters"]["count"] > 0'; echo $?) "clusters --json"

# 5. submit --preset --set --wait, --json; idempotent resubmission; list.
ctl submit --preset cooling-2d --set run.until.time=2 --set output.every.time=0.5 --set particles.count=900 --wait
ok $([ $RC = 0 ] && grep -q 'succeeded' "$tmp/out"; echo $?) "submit --preset cooling-2d --set run.until.time=2 --wait: exit 0"
pid=$(sed -n 's/^job \([0-9]*\) submitted.*/\1/p' "$tmp/out")
ctl show "$pid" --json
ok $(jsonok 'd["scene"]["run"]["until"] == {"time": 2} and d["particles"] == 900'; echo $?) "--set replaced the stop clock and typed the count"
ctl submit "$tmp/short.json" --submission-id s-1 --priority 3 --json
ok $([ $RC = 0 ] && jsonok 'd["submission_id"] == "s-1" and d["priority"] == 3'; echo $?) "submit --json with --submission-id and --priority"
ctl submit "$tmp/short.json" --submission-id s-1
ok $([ $RC = 0 ] && grep -q 'already submitted' "$tmp/out"; echo $?) "resubmission with the same id: already submitted"
ctl list
ok $([ $RC = 0 ] && head -1 "$tmp/out" | grep -q 'ID *STATE *PROGRESS *METHOD *N *AGE' && grep -q "^$id .*succeeded *100.0%" "$tmp/out"; echo $?) "list: table"
ctl list --all --limit 1 --json
ok $([ $RC = 0 ] && jsonok 'len(d["jobs"]) == 3 and d["next_cursor"] is None'; echo $?) "list --all --limit 1 follows the cursor to all 3 jobs"
ctl list --state succeeded --limit 1
ok $([ $RC = 0 ] && [ "$(grep -c succeeded "$tmp/out")" = 1 ] && grep -q 'more' "$tmp/out"; echo $?) "list --state --limit: one row and a 'more' hint"
ctl submit --preset cooling-2d --set run.until.time=-1
ok $([ $RC = 2 ] && one_line && grep -q 'run.until.time' "$tmp/err"; echo $?) "scene rejected by the daemon (400): exit 2, $(cat "$tmp/err")"
ctl submit --preset no-such-preset
ok $([ $RC = 4 ] && grep -q "no-such-preset" "$tmp/err"; echo $?) "unknown preset: exit 4"

# 5b. The submission's Slurm options: the flags become its "slurm" object (kept, and shown, whatever the
# launcher); a bad value is refused by the client before any request, or by the daemon (400) with the key named.
ctl submit "$tmp/short.json" --nodes 1 --time-limit 60 --partition debug --account proj_1 --json
sid=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["id"])' "$tmp/out" 2>/dev/null)
ok $([ $RC = 0 ] && jsonok 'd["slurm"] == {"nodes": 1, "time_limit": 60, "partition": "debug", "account": "proj_1"}'; echo $?) "submit --nodes --time-limit --partition --account: the job's slurm options $(tr -d '\n ' <"$tmp/out" | grep -o '"slurm":{[^}]*}')"
ctl show "$sid"
ok $([ $RC = 0 ] && grep -q '^  slurm  *nodes 1 time limit 60 s partition debug account proj_1$' "$tmp/out"; echo $?) "show prints them: $(grep '^  slurm' "$tmp/out")"
echo '{"scene":'"$SHORT"',"slurm":{"partition":"long","nodes":1}}' >"$tmp/sub.json"
ctl submit "$tmp/sub.json" --partition short --json
ok $([ $RC = 0 ] && jsonok 'd["slurm"] == {"nodes": 1, "partition": "short"}'; echo $?) "a flag goes over the same key of a whole submission, the others stay"
ctl submit "$tmp/short.json" --nodes 2
ok $([ $RC = 2 ] && one_line && grep -q 'slurm.nodes' "$tmp/err"; echo $?) "--nodes above the ranks, refused by the daemon (400): exit 2, $(head -1 "$tmp/err")"
echo '{"scene":'"$SHORT"',"slurm":{"account":"a b"}}' >"$tmp/sub.json"
ctl submit "$tmp/sub.json"
ok $([ $RC = 2 ] && one_line && grep -q 'slurm.account' "$tmp/err"; echo $?) "an account that is not a name, refused by the daemon (400): exit 2, $(head -1 "$tmp/err")"
n0=$("$GRANULARCTL" list --json | "$PY" -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')
bad=
for a in "--nodes 0" "--nodes 4097" "--nodes two" "--time-limit 0" "--time-limit 1e3" "--time-limit 100000001" "--partition a/b" "--partition=" "--account a/b" "--account="; do
	# shellcheck disable=SC2086 # the flag and its value are two words
	ctl submit "$tmp/short.json" $a
	[ $RC = 2 ] && one_line && grep -q -- "granularctl: ${a%%[ =]*} " "$tmp/err" || bad="$bad [$a]"
done
ok $([ -z "$bad" ] && [ "$("$GRANULARCTL" list --json | "$PY" -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')" = "$n0" ]; echo $?) \
	"bad --nodes, --time-limit, --partition, --account: exit 2, one line naming the flag, no job${bad:+ (not:$bad)}"
ctl list --partition x; ok $([ $RC = 2 ] && grep -q -- "--partition: not an option of 'list'" "$tmp/err"; echo $?) "--partition is submit's only"

# 4b. Fields the server sends as null (an observable not asked for) print as "-", never "nan".
echo "$SHORT" | sed 's/"observables":\[[^]]*\]/"observables":["kinetic_energy"]/' >"$tmp/noobs.json"
ctl submit "$tmp/noobs.json" --wait
nid=$(sed -n 's/^job \([0-9]*\) submitted.*/\1/p' "$tmp/out")
: >"$tmp/tables"
for c in show progress clusters; do ctl "$c" "$nid"; cat "$tmp/out" >>"$tmp/tables"; done
ctl cluster; cat "$tmp/out" >>"$tmp/tables"
ctl list; cat "$tmp/out" >>"$tmp/tables"
ok $([ -n "$nid" ] && ! grep -qiw 'nan' "$tmp/tables"; echo $?) "no 'nan' in show, progress, clusters, cluster, list for a job without collision_rate$(grep -iw -m1 nan "$tmp/tables" | sed 's/^/: /')"
ctl progress "$nid"
ok $(awk 'NR > 1 && $2 == "progress" && $8 != "-" { bad = 1 } END { exit bad }' "$tmp/out" && grep -q ' progress ' "$tmp/out"; echo $?) "progress: COLL_RATE reads '-' where the record has none"

# 6. cancel: watch ends with exit 1; errors are the server's message; wrong token: exit 4.
ctl submit "$tmp/long.json"
lid=$(sed -n 's/^job \([0-9]*\) submitted.*/\1/p' "$tmp/out")
wait_state "$lid" running 20
ctl --token wrong cancel "$lid"
ok $([ $RC = 4 ] && one_line && grep -q 'wrong token (token from --token)' "$tmp/err"; echo $?) "wrong token: exit 4, $(cat "$tmp/err")"
GRANULAR_TOKEN=wrong "$GRANULARCTL" delete "$lid" >/dev/null 2>"$tmp/err"
ok $([ $? = 4 ] && grep -q 'GRANULAR_TOKEN' "$tmp/err"; echo $?) "wrong \$GRANULAR_TOKEN: exit 4, the source named"
echo wrong-token-in-a-file >"$tmp/tokfile"
ctl --token-file "$tmp/tokfile" cancel "$lid"
ok $([ $RC = 4 ] && one_line && grep -q "token from --token-file $tmp/tokfile" "$tmp/err"; echo $?) "--token-file with a wrong token: exit 4, the file named"
ctl --token-file "$tmp/no-such-token" cancel "$lid"
ok $([ $RC = 2 ] && one_line && grep -q "no-such-token" "$tmp/err"; echo $?) "--token-file that cannot be read: exit 2, $(cat "$tmp/err")"
ctl cancel "$lid"
ok $([ $RC = 0 ] && grep -q "job $lid" "$tmp/out"; echo $?) "cancel: $(out)"
ctl show "$lid"
ok $([ $RC = 0 ] && grep -q '^  cancel  *requested' "$tmp/out"; echo $?) "show of a job cancelled while running: $(grep '^  cancel' "$tmp/out")"
ctl watch "$lid"
ok $([ $RC = 1 ] && grep -q "job $lid cancelled" "$tmp/out"; echo $?) "watch of a cancelled job: exit 1"
ctl cancel "$id"
ok $([ $RC = 4 ] && one_line && grep -q 'already succeeded' "$tmp/err" && ! grep -q '{' "$tmp/err"; echo $?) "cancel of a finished job (409): exit 4, the message not JSON"
ctl show 999999
ok $([ $RC = 4 ] && one_line && grep -q 'job 999999 not found' "$tmp/err"; echo $?) "unknown id: exit 4, $(cat "$tmp/err")"
ctl watch 999999; ok $([ $RC = 4 ]; echo $?) "watch of an unknown id: exit 4"

# 7. watch --json streams events as JSON lines; delete.
ctl watch "$id" --json
ok $([ $RC = 0 ] && "$PY" -c 'import json,sys; [json.loads(l) for l in open(sys.argv[1])]' "$tmp/out" && grep -q '"event": "state"' "$tmp/out"; echo $?) "watch --json: JSON lines"
ctl files "$id"
ok $([ $RC = 0 ] && grep -q '^scene.json ' "$tmp/out" && grep -q '^progress.jsonl ' "$tmp/out"; echo $?) "files: table with scene.json and progress.jsonl"
ctl files "$id" --json; ok $([ $RC = 0 ] && jsonok 'all(len(f["sha256"]) == 64 for f in d["files"])'; echo $?) "files --json: SHA-256 of each"
ctl download "$id" scene.json -o "$tmp/dl.json"
ok $([ $RC = 0 ] && cmp -s "$tmp/dl.json" "var/jobs/$id/scene.json"; echo $?) "download -o FILE: the same bytes as the job's scene.json"
ctl download "$id" progress.jsonl -o -
ok $([ $RC = 0 ] && cmp -s "$tmp/out" "var/jobs/$id/progress.jsonl"; echo $?) "download -o -: to stdout"
ctl download "$id" nope.h5 -o "$tmp/nope"
ok $([ $RC = 4 ] && one_line && [ ! -e "$tmp/nope" ]; echo $?) "download of a missing file: exit 4, no file left: $(cat "$tmp/err")"
echo keep >"$tmp/existing"
ctl download "$id" nope.h5 -o "$tmp/existing" --force
ok $([ $RC = 4 ] && [ "$(cat "$tmp/existing")" = keep ] && [ ! -e "$tmp/existing.part" ]; echo $?) "a failed download leaves an existing file as it was (even with --force)"
ctl download "$id" scene.json -o "$tmp/existing"
ok $([ $RC = 2 ] && one_line && grep -q 'exists.*--force' "$tmp/err" && [ "$(cat "$tmp/existing")" = keep ]; echo $?) "download onto an existing file without --force: exit 2, the file untouched: $(cat "$tmp/err")"
rm -f scene.json
ctl download "$id" scene.json
ok $([ $RC = 0 ] && cmp -s scene.json "var/jobs/$id/scene.json"; echo $?) "download ID NAME: to NAME in the current directory"
echo keep >scene.json
ctl download "$id" scene.json
ok $([ $RC = 2 ] && [ "$(cat scene.json)" = keep ]; echo $?) "a second download to NAME does not overwrite it"
ctl download "$id" scene.json -f
ok $([ $RC = 0 ] && cmp -s scene.json "var/jobs/$id/scene.json"; echo $?) "download -f replaces it"
ctl download "$id" nope.h5 -o /dev/null
ok $([ $RC = 4 ] && [ -c /dev/null ]; echo $?) "a failed download to /dev/null leaves /dev/null a device"
ctl download "$id" ../token; ok $([ $RC = 2 ]; echo $?) "download ../token: exit 2 before any request"
ctl delete "$id"; ok $([ $RC = 0 ] && grep -q "job $id deleted" "$tmp/out"; echo $?) "delete"
ctl delete "$id" --json; ok $([ $RC = 4 ]; echo $?) "delete again: exit 4"

# 8. --url and $GRANULAR_URL win over the state directory.
GRANULAR_URL=http://127.0.0.1:1 "$GRANULARCTL" list >/dev/null 2>"$tmp/err"
ok $([ $? = 3 ] && grep -q '127.0.0.1:1' "$tmp/err"; echo $?) "\$GRANULAR_URL overrides the state directory"
ctl --url "$URL" --state-dir "$tmp/nowhere" presets; ok $([ $RC = 0 ]; echo $?) "--url needs no state directory"
ctl --url "$URL" --state-dir "$tmp/nowhere" --token-file var/token submit "$tmp/short.json"
ok $([ $RC = 0 ] && grep -q submitted "$tmp/out"; echo $?) "--token-file: the token from a file, not the command line"

# 8b. advise: the estimates as a table or JSON; bad scenes name the key; no job is made.
AUTO='{"method":"auto","accuracy":{"temperature":0.05},"dimensions":2,"particles":{"count":2000,"volume_fraction":0.1,"initial":{"positions":"random"}},"collisions":{"restitution":0.9},"run":{"until":{"time":5},"replicas":4}}'
echo "$AUTO" >"$tmp/auto.json"
njobs=$("$GRANULARCTL" list --json | "$PY" -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')
ctl advise "$tmp/auto.json" --ranks 2
ok $([ $RC = 0 ] && grep -q '^METHOD *SETTINGS *CPU *WALL *ERROR *MEETS *EXTRAPOLATED' "$tmp/out" &&
     grep -q '^ed *cell automatic' "$tmp/out" && grep -q '^dsmc *none, cell' "$tmp/out" && grep -q '^dsmc *enskog, cell' "$tmp/out" && grep -q '^hsmc *cba, cell' "$tmp/out" &&
     grep -q '^choice: ' "$tmp/out" && grep -q '4 replicas, 2 ranks' "$tmp/out"; echo $?) "advise: a table of ed, dsmc, hsmc with the choice ($(grep '^choice' "$tmp/out" | cut -c1-60)...)"
ctl advise "$tmp/auto.json" --json --set particles.count=4000
ok $([ $RC = 0 ] && jsonok 'd["scene"]["particles"] == 4000 and len(d["estimates"]) >= 4 and d["choice"] in ("ed","dsmc","hsmc")'; echo $?) \
	"advise --json --set: the server's JSON for the changed scene"
ctl advise --preset cooling-2d
ok $([ $RC = 0 ] && grep -q ' x 1 replica, 1 rank;' "$tmp/out"; echo $?) "advise reads right in the singular: $(head -n 1 "$tmp/out" | cut -c1-60)"
ctl advise --preset cooling-2d --json
ok $([ $RC = 0 ] && jsonok 'd["choice"] is None and d["target"] is None and all(e["meets_target"] is None for e in d["estimates"])'; echo $?) \
	"advise --preset on a concrete scene: estimates without a target"
# an md scene: md's own row last, with its step and CPU seconds (the model's cost.md)
echo '{"method":"md","dimensions":2,"particles":{"count":500,"volume_fraction":0.3},"collisions":{"restitution":0.9},"run":{"until":{"time":1}}}' >"$tmp/md.json"
ctl advise "$tmp/md.json"
ok $([ $RC = 0 ] && tail -n +3 "$tmp/out" | grep -v '^  ' | tail -n 1 | grep -q '^md *step [0-9.e-]* *[0-9.e+-]*s '; echo $?) \
	"advise on an md scene: md's row last with its step and cost ($(grep '^md ' "$tmp/out" | tr -s ' ' | cut -c1-60))"
# on a bed under gravity (the gravity-box preset, made auto): ed chosen, dsmc refused with the reason
"$PY" -c 'import json, sys
s = json.load(open(sys.argv[1])); s["method"] = "auto"; s.pop("hsmc"); s["accuracy"] = {"temperature": 0.05}
json.dump(s, open(sys.argv[2], "w"))' "$SRCDIR/presets/gravity-box-2d.json" "$tmp/gb.json"
ctl advise "$tmp/gb.json"
ok $([ $RC = 0 ] && grep -q '^dsmc *none, cell.* refused ' "$tmp/out" && grep -q '^  dsmc: refused: gravity pulls the particles onto a wall' "$tmp/out" &&
     grep -q '^choice: ed ' "$tmp/out"; echo $?) "advise on a bed under gravity: $(grep '^dsmc ' "$tmp/out" | head -n 1 | tr -s ' ' | cut -c1-80); $(grep '^choice' "$tmp/out" | cut -c1-40)"
ctl advise "$tmp/auto.json" --set accuracy.temperature=0
ok $([ $RC = 2 ] && one_line && grep -q 'accuracy.temperature: must be between 0 and 1' "$tmp/err"; echo $?) "advise with a bad target: exit 2, $(head -1 "$tmp/err")"
# 8c. validate: the submission's checks without a job; a scene the engine would refuse names the key.
ctl validate --preset cooling-2d
ok $([ $RC = 0 ] && grep -q '^valid: method ed; memory [0-9.]* MiB' "$tmp/out"; echo $?) "validate --preset: $(head -n 1 "$tmp/out" | cut -c1-100)"
ctl validate --preset cooling-2d --json
ok $([ $RC = 0 ] && jsonok 'd["valid"] is True and d["resources"]["memory_bytes"] > 0'; echo $?) "validate --json: the server's answer with resources"
echo '{"method":"dsmc","dimensions":2,"particles":{"count":2000,"volume_fraction":0.1},"dsmc":{"cell_size":1e-9},"run":{"until":{"time":1}}}' >"$tmp/tiny.json"
ctl validate "$tmp/tiny.json"
ok $([ $RC = 2 ] && one_line && grep -q 'dsmc.cell_size' "$tmp/err"; echo $?) "validate: a scene the engine would refuse, exit 2: $(head -1 "$tmp/err" | cut -c1-100)"
ok $([ "$("$GRANULARCTL" list --json | "$PY" -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')" = "$njobs" ]; echo $?) "advise and validate made no job"

# 9. The dashboard is served from the daemon, scripts from files only (CSP default-src 'self').
curl -s -D "$tmp/hdr" -o "$tmp/index" "$URL/"
ok $(grep -q 'src="/static/app.js"' "$tmp/index" && grep -qi "content-security-policy: default-src 'self'" "$tmp/hdr"; echo $?) "GET /: the dashboard, under CSP default-src 'self'"
for f in app.js app.css uPlot.iife.min.js uPlot.min.css; do
	c=$(curl -s -o "$tmp/f" -w '%{http_code} %{content_type}' "$URL/static/$f")
	# the embedding ends the last line with a newline when the file does not
	src=$(find "$SRCDIR/dashboard" -name "$f")
	{ cat "$src"; [ -z "$(tail -c 1 "$src")" ] || echo; } >"$tmp/want"
	cmp -s "$tmp/f" "$tmp/want" || c="$c, differs"
	ok $(case "$c" in "200 text/"*charset*) [ "${c%differs}" = "$c" ] ;; *) false ;; esac; echo $?) "GET /static/$f: $c"
done

# 10. The daemon stops under a watch: exit 3.
ctl submit "$tmp/long.json"
lid=$(sed -n 's/^job \([0-9]*\) submitted.*/\1/p' "$tmp/out")
wait_state "$lid" running 20
"$GRANULARCTL" watch "$lid" >"$tmp/out" 2>"$tmp/err" &
w=$!
sleep 0.5
kill -9 "$GD_PID"; wait "$GD_PID" 2>/dev/null; GD_PID=
wait $w; RC=$?
ok $([ $RC = 3 ] && one_line; echo $?) "daemon killed under watch: exit 3, $(cat "$tmp/err")"
finish
