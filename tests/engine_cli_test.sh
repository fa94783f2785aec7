#!/bin/sh
# Integration test of the granular-engine program: bad scenes, progress protocol, exit codes, MPI launch.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/engine_cli.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
PY=/usr/bin/python3

# 1. Every bad scene: exit 2, exactly one line on stderr, starting with the key path.
while IFS="$(printf '\t')" read -r file key _rest; do
	[ -n "$file" ] || continue
	"$ENGINE" run "$SRCDIR/tests/scenes/bad/$file" >"$tmp/out" 2>"$tmp/err"
	rc=$?
	lines=$(wc -l <"$tmp/err")
	case "$(head -n 1 "$tmp/err")" in
	"$key"*) prefix=0 ;;
	*) prefix=1 ;;
	esac
	[ $rc -eq 2 ] && [ "$lines" -eq 1 ] && [ $prefix -eq 0 ] && [ ! -s "$tmp/out" ]
	ok $? "bad scene $file: exit $rc, $lines line(s): $(head -n 1 "$tmp/err")"
done <"$SRCDIR/tests/scenes/bad/expected.tsv"

"$ENGINE" run "$tmp/missing.json" >/dev/null 2>"$tmp/err"
ok $(( $? == 2 ? 0 : 1 )) "missing scene file: exit 2 ($(cat "$tmp/err"))"
"$ENGINE" frobnicate >/dev/null 2>&1
ok $(( $? == 2 ? 0 : 1 )) "unknown command: exit 2"

# 2. Good scenes run to completion; every line is JSON with the documented keys.
for f in "$SRCDIR"/tests/scenes/good/*.json; do
	name=$(basename "$f")
	"$ENGINE" run "$f" >"$tmp/progress" 2>"$tmp/err"
	rc=$?
	"$PY" - "$tmp/progress" "$f" <<'PYEOF'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
scene = json.load(open(sys.argv[2]))
prog = [l for l in lines if l["type"] == "progress"]
summ = [l for l in lines if l["type"] == "summary"]
assert len(summ) == 1 and lines[-1]["type"] == "summary", "one summary, last"
assert summ[0]["status"] == "completed", summ[0]
base = {"time", "events", "collisions", "collisions_per_particle", "wall_seconds"}
obs = scene.get("output", {}).get("observables",
      ["kinetic_energy", "temperature", "pressure", "compressibility", "collision_rate"])
for p in prog:
    # structure observables: a2 and the contact values in progress records, curves only in observables.jsonl
    key = {"velocity_distribution": "a2", "pair_correlation": "g_contact_pairs", "mean_square_displacement": "msd"}
    missing = (base | {key.get(o, o) for o in obs
                       if o not in ("clusters", "structure_factor", "velocity_correlations", "fields", "density_spectrum",
                                     "surface_profile")}) - set(p)
    assert not missing, missing
    if "clusters" in obs and "replicas" not in p:   # ensembles: histogram totals over replicas
        c = p["clusters"]
        assert c["count"] >= 1 and 1 <= c["largest"] <= scene["particles"]["count"]
        assert sum(c["histogram"]) == c["count"]
times = [p["time"] for p in prog]
assert times == sorted(times) and len(prog) >= 2
n = scene["particles"].get("count") or sum(k["count"] for k in scene["particles"]["species"])   # mixtures: the total
for p in prog:
    if "replicas" in p:   # means over replicas; collisions are totals
        assert p["replicas"] == scene["run"]["replicas"] and "temperature_se" in p
        continue
    assert abs(p["collisions_per_particle"] - 2 * p["collisions"] / n) < 1e-12
    if "temperature" in p and "kinetic_energy" in p:   # open walls: over the particles still present
        np_ = p.get("particles_present", n)
        assert abs(p["temperature"] - 2 * p["kinetic_energy"] / (scene["dimensions"] * np_)) < 1e-12 * p["temperature"] + 1e-300
until = scene["run"]["until"]
if "time" in until:
    assert abs(prog[-1]["time"] - until["time"]) < 1e-9 * until["time"]
else:
    assert prog[-1]["collisions_per_particle"] >= until["collisions_per_particle"] - 1e-12
PYEOF
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "good scene $name: exit $rc, progress lines valid"
done

# 3. --progress-fd and --out.
scene="$SRCDIR/tests/scenes/good/$(ls "$SRCDIR/tests/scenes/good" | head -n 1)"
"$ENGINE" run "$scene" --progress-fd 3 --out "$tmp/out.d" 3>"$tmp/fd3" >"$tmp/stdout" 2>/dev/null
rc=$?
[ $rc -eq 0 ] && [ ! -s "$tmp/stdout" ] && [ -s "$tmp/fd3" ] && cmp -s "$tmp/fd3" "$tmp/out.d/progress.jsonl"
ok $? "--progress-fd 3 carries the progress, --out DIR keeps a copy (exit $rc)"

# 3b. Inelastic collapse (issue 19.10): strong dissipation without the TC
# model. e = 0.3 in 2D collapses within ~200 collisions per particle (the
# clock stalls: thousands of events in ~1e-5 time units); the run stops with
# exit 2 and one stderr line naming collisions.tc, the last progress record
# and the summary (status "collapsed") carry the message, and the H5MD file
# records it. The same scene with tc > 0 runs to its end.
cat >"$tmp/collapse.json" <<'EOF'
{ "method": "ed", "dimensions": 2,
  "particles": { "count": 500, "volume_fraction": 0.3, "initial": { "positions": "random", "temperature": 1 } },
  "collisions": { "restitution": 0.3, "tc": 0 },
  "run": { "seed": 1, "until": { "collisions_per_particle": 2000 } },
  "output": { "every": { "collisions_per_particle": 100 } } }
EOF
"$ENGINE" run "$tmp/collapse.json" --out "$tmp/collapse.d" >"$tmp/collapse.out" 2>"$tmp/collapse.err"
rc=$?
"$PY" - "$tmp/collapse.out" <<'PYEOF'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
summ, last = lines[-1], lines[-2]
assert summ["type"] == "summary" and summ["status"] == "collapsed", summ
assert last["type"] == "progress" and last["warning"].startswith("collisions.tc: inelastic collapse"), last
assert summ["warning"] == last["warning"] and summ["collisions_per_particle"] < 2000
PYEOF
py=$?
[ $rc -eq 2 ] && [ $py -eq 0 ] && [ "$(wc -l <"$tmp/collapse.err")" -eq 1 ] &&
	grep -q '^collisions\.tc: inelastic collapse at time .*set collisions\.tc > 0' "$tmp/collapse.err" &&
	h5dump -a /observables/inelastic_collapse "$tmp/collapse.d/trajectory.h5" 2>/dev/null | grep -q 'collisions.tc: inelastic collapse' &&
	h5dump -a /observables/inelastic_collapse_time "$tmp/collapse.d/trajectory.h5" >/dev/null 2>&1
ok $? "tc 0, e 0.3: inelastic collapse detected, exit $rc: $(cat "$tmp/collapse.err")"
sed 's/"tc": 0 }/"tc": 1e-4 }/' "$tmp/collapse.json" >"$tmp/collapse-tc.json"
"$ENGINE" run "$tmp/collapse-tc.json" >"$tmp/collapse-tc.out" 2>"$tmp/collapse-tc.err"
rc=$?
[ $rc -eq 0 ] && tail -n 1 "$tmp/collapse-tc.out" | grep -q '"status":"completed"' && ! grep -q collapse "$tmp/collapse-tc.out"
ok $? "the same scene with tc 1e-4 completes without a collapse warning (exit $rc)"

# 4. Same scene, same seed: identical physics (wall time aside).
strip() { "$PY" -c 'import json,sys
for l in open(sys.argv[1]):
    d=json.loads(l); [d.pop(k,None) for k in ("wall_seconds","events_per_second","collisions_per_second")]; print(json.dumps(d,sort_keys=True))' "$1"; }
"$ENGINE" run "$scene" >"$tmp/a" 2>/dev/null && "$ENGINE" run "$scene" >"$tmp/b" 2>/dev/null
strip "$tmp/a" >"$tmp/a2"; strip "$tmp/b" >"$tmp/b2"
cmp -s "$tmp/a2" "$tmp/b2"
ok $? "two runs of the same scene print identical physics"

# 5. SIGTERM: the engine stops cleanly with a summary of status interrupted, exit 3.
cat >"$tmp/long.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":4000,"volume_fraction":0.3},
 "run":{"until":{"collisions_per_particle":1e9}},"output":{"every":{"collisions_per_particle":10}}}
JSON
"$ENGINE" run "$tmp/long.json" >"$tmp/long.out" 2>/dev/null &
pid=$!
# The handlers are installed after MPI_Init, before the first record: wait
# for that record (MPI_Init alone can take seconds on a loaded machine).
i=0; until [ -s "$tmp/long.out" ] || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
kill -TERM $pid
wait $pid
rc=$?
tail -n 1 "$tmp/long.out" | grep -q '"status":"interrupted"'
ok $(( rc == 3 && $? == 0 ? 0 : 1 )) "SIGTERM: summary with status interrupted, exit $rc"

# 6. Under mpirun with 2 ranks: rank 0 runs, the other idles; same physics.
if command -v mpirun >/dev/null 2>&1; then
	mpirun -np 2 "$ENGINE" run "$scene" >"$tmp/m" 2>"$tmp/merr"
	rc=$?
	strip "$tmp/m" >"$tmp/m2"
	cmp -s "$tmp/a2" "$tmp/m2"
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "mpirun -np 2: exit $rc, same output as the serial run"
fi

# 7. Ensembles: the same numbers whatever the number of ranks (1, 2, 3).
if command -v mpirun >/dev/null 2>&1; then
	for f in 2d-ed-replicas.json 2d-dsmc-replicas.json; do
		"$ENGINE" run "$SRCDIR/tests/scenes/good/$f" >"$tmp/e1" 2>/dev/null
		rc1=$?
		strip "$tmp/e1" >"$tmp/e1s"
		for np in 2 3; do
			mpirun -np $np "$ENGINE" run "$SRCDIR/tests/scenes/good/$f" >"$tmp/e$np" 2>"$tmp/merr"
			rc=$?
			strip "$tmp/e$np" >"$tmp/e${np}s"
			cmp -s "$tmp/e1s" "$tmp/e${np}s"
			ok $(( rc1 == 0 && rc == 0 && $? == 0 ? 0 : 1 )) "ensemble $f: mpirun -np $np gives the serial output (exit $rc)"
		done
	done
fi

# 8. advise and "method": "auto": estimates as JSON; the choice runs as if the scene had named it.
auto="$SRCDIR/tests/scenes/good/2d-method-auto.json"
"$ENGINE" advise "$auto" >"$tmp/adv" 2>"$tmp/err"
rc=$?
choice=$("$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); v=[e["variant"] for e in d["estimates"]]; assert v[0] == "ed" and {"dsmc/none","dsmc/enskog","hsmc/cba"} <= set(v), v; assert all(e["cpu_seconds"] > 0 for e in d["estimates"]); assert d["resolved"]["method"] == d["choice"] and d["choice_variant"].split("/")[0] == d["choice"]; print(d["choice"])' "$tmp/adv" 2>/dev/null)
ok $(( rc == 0 && ${#choice} > 0 ? 0 : 1 )) "advise: exit $rc, estimates for ed and every measured dsmc/hsmc variant; choice $choice, resolved settings"
"$ENGINE" advise "$SRCDIR/tests/scenes/good/2d-minimal.json" --ranks 4 >"$tmp/adv2" 2>/dev/null
ok $("$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["choice"] is None and d["target"] is None and d["scene"]["ranks"] == 4' "$tmp/adv2" 2>/dev/null; echo $?) \
	"advise on a concrete scene: estimates, no target, no choice; --ranks 4 recorded"
"$ENGINE" advise "$SRCDIR/tests/scenes/bad/71-accuracy-zero.json" >"$tmp/out" 2>"$tmp/err"
ok $([ $? = 2 ] && [ "$(wc -l <"$tmp/err")" = 1 ] && grep -q '^accuracy.temperature: ' "$tmp/err" && [ ! -s "$tmp/out" ]; echo $?) \
	"advise on a bad target: exit 2, one line: $(cat "$tmp/err")"
echo '{"format": "granulard-advice-model", "version": 2, "particles_measured": 1000}' >"$tmp/model.json"
"$ENGINE" advise "$auto" --model "$tmp/model.json" >/dev/null 2>"$tmp/err"
ok $([ $? = 2 ] && grep -q 'cost: required key missing' "$tmp/err"; echo $?) "advise --model with a broken model: exit 2: $(cat "$tmp/err")"
"$ENGINE" advise "$auto" --ranks 0 >/dev/null 2>&1
ok $(( $? == 2 ? 0 : 1 )) "advise --ranks 0: exit 2"
"$ENGINE" run "$auto" >"$tmp/r1" 2>"$tmp/err"
rc=$?
"$PY" - "$tmp/r1" "$choice" <<'PYEOF'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
assert lines[0]["type"] == "advice" and lines[0]["choice"] == sys.argv[2] and lines[0]["reason"]
assert all(l["type"] == "progress" for l in lines[1:-1]) and lines[-1]["status"] == "completed"
assert all(l["type"] != "advice" for l in lines[1:])
PYEOF
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "run auto: the advice line first (choice $choice), then progress and the summary (exit $rc)"
# The concrete scene: the request with the advice line's "resolved" settings (method, MC correction), no accuracy.
variant=$("$PY" -c 'import json,sys; a=json.loads(open(sys.argv[1]).readline()); d=json.load(open(sys.argv[2])); del d["accuracy"]; d.update(a["resolved"]); json.dump(d,open(sys.argv[3],"w")); print(a["choice_variant"])' \
	"$tmp/r1" "$auto" "$tmp/concrete.json")
c=${variant#*/}
ok $([ "$variant" = ed ] || grep -q "\"$choice\": {\"correction\": \"$c\"}" "$tmp/concrete.json"; echo $?) "the resolved scene carries the chosen variant $variant"
"$ENGINE" run "$tmp/concrete.json" >"$tmp/r2" 2>/dev/null
tail -n +2 "$tmp/r1" >"$tmp/r1b"
strip "$tmp/r1b" >"$tmp/r1s"; strip "$tmp/r2" >"$tmp/r2s"
cmp -s "$tmp/r1s" "$tmp/r2s" && [ -s "$tmp/r1s" ]
ok $? "run auto gives the same records as the resolved concrete scene ($variant)"
if command -v mpirun >/dev/null 2>&1; then
	mpirun -np 2 "$ENGINE" run "$auto" >"$tmp/r3" 2>"$tmp/merr"
	rc=$?
	tail -n +2 "$tmp/r3" >"$tmp/r3b"; strip "$tmp/r3b" >"$tmp/r3s"
	cmp -s "$tmp/r1s" "$tmp/r3s" && head -n 1 "$tmp/r3" | grep -q "\"choice\":\"$choice\""
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "run auto (2 replicas) under mpirun -np 2: every rank resolves the same method, same records"
fi

echo "1..$n"
[ $failed -eq 0 ]
