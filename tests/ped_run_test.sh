#!/bin/sh
# One ed system split over MPI ranks through the real program (engine/par/edrun.h; TAP): the records and the final
# state of the split run (--split on one rank, mpirun -np 2 and 4, oversubscribed) against the serial engine's run of
# the same scene, bit-identical reruns at one rank count, trajectory.h5 laid out as the serial one's, the refusals
# naming the key, the plain-mpirun fallback for a scene the split run cannot do, and SIGTERM.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ped_run_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

if ! command -v mpirun >/dev/null 2>&1; then
	echo "1..0 # SKIP no mpirun"
	exit 0
fi
have_h5=0
command -v h5diff >/dev/null 2>&1 && command -v h5dump >/dev/null 2>&1 && have_h5=1

# runs NAME ARGS...: the engine on the scene $tmp/NAME.json, output dir $tmp/NAME.<tag> (tag: s serial, 1 --split,
# 2 and 4 mpirun -np), records in $tmp/NAME.<tag>.out
run_tag() {
	name=$1 tag=$2
	case $tag in
	s) "$ENGINE" run "$tmp/$name.json" --out "$tmp/$name.$tag" >"$tmp/$name.$tag.out" 2>"$tmp/$name.$tag.err" ;;
	1) "$ENGINE" run "$tmp/$name.json" --split --out "$tmp/$name.$tag" >"$tmp/$name.$tag.out" 2>"$tmp/$name.$tag.err" ;;
	*) mpirun --oversubscribe -np "$tag" "$ENGINE" run "$tmp/$name.json" --out "$tmp/$name.$tag" \
		>"$tmp/$name.$tag.out" 2>"$tmp/$name.$tag.err" ;;
	esac
}

# Records of a split run against the serial run's. The parallel core commits the serial engine's collisions
# (ped.h: the same pairs in the same order, times equal to rounding, tests/ped_test), so at every output time
# the collision count, the TC-elastic count and the time are equal exactly. Kinetic energy, temperature, pressure
# and compressibility come from the same collisions, summed in another order (rank order) from velocities that
# differ by rounding grown through the chaos of the dynamics (ped_test: collision times within 3e-10 after 8
# collisions per particle): equal to 1e-9 relative, where one different collision would change the energy by
# ~1/N = 3e-4 relative. The collision rate is two counts over the same interval: 1e-12. Momentum (exactly 0,
# rounding ~1e-13): 1e-9 absolute. The events column is the core's (crossings of its own cell grid): not compared.
cmp_records() {   # cmp_records SERIAL SPLIT
	"$PY" - "$1" "$2" <<'PY'
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert len(a) == len(b) > 3, (len(a), len(b))
worst = 0.0
for x, y in zip(a, b):
    assert x["type"] == y["type"], (x["type"], y["type"])
    for k in ("time", "collisions", "collisions_per_particle", "status"):
        assert x.get(k) == y.get(k), (k, x.get(k), y.get(k))
    assert x.get("elastic_by_tc", 0) == y.get("elastic_by_tc", 0), ("elastic_by_tc", x, y)
    for k, tol in (("kinetic_energy", 1e-9), ("temperature", 1e-9), ("pressure", 1e-9), ("compressibility", 1e-9),
                   ("collision_rate", 1e-12)):
        if x.get(k) is None:
            assert y.get(k) is None, k
            continue
        d = abs(x[k] - y[k]) / abs(x[k])
        worst = max(worst, d)
        assert d <= tol, (k, x[k], y[k])
    for u, v in zip(x.get("momentum", []), y.get("momentum", [])):
        assert abs(u - v) <= 1e-9, ("momentum", u, v)
    # the split run's load keys (ranks > 1: rank_events, rank_particles, rollbacks, syncs, sync_interval,
    # rebalances) are its own
    own = ("events_per_second", "memory_bytes", "cells", "ranks", "rank_events", "rank_particles", "rollbacks", "syncs",
           "sync_interval", "rebalances")
    assert sorted(k for k in x if k not in own) == sorted(k for k in y if k not in own), (sorted(x), sorted(y))
print("%d records, %d collisions (%.1f per particle), largest relative difference %.2g" %
      (len(b), b[-1]["collisions"], b[-1]["collisions_per_particle"], worst))
PY
}

# The trajectory of a split run against the serial one's: the same groups, datasets, shapes, types and attributes
# (h5dump -H, the file name line aside), the same frame times and collision counts exactly, positions and velocities
# of every frame within 1e-8 absolute (measured ~2e-12 at 6 collisions per particle: rounding, as above; a different
# collision moves a particle's velocity by O(1), the thermal speed, and its position by O(0.01) at least), the
# observables as the records. The H5MD "step" columns count the core's events: not compared.
cmp_traj() {   # cmp_traj SERIALDIR SPLITDIR -> prints why on failure
	h5dump -H "$1/trajectory.h5" | tail -n +2 >"$tmp/h.a"
	h5dump -H "$2/trajectory.h5" | tail -n +2 >"$tmp/h.b"
	cmp -s "$tmp/h.a" "$tmp/h.b" || { echo "h5dump -H differs: $(diff "$tmp/h.a" "$tmp/h.b" | head -n 4 | tr '\n' ' ')"; return 1; }
	for d in /particles/all/position/time /particles/all/velocity/time /observables/collision_count/value \
	         /observables/collision_count/time; do
		h5diff "$1/trajectory.h5" "$2/trajectory.h5" $d >/dev/null || { echo "$d differs"; return 1; }
	done
	for d in /particles/all/position/value /particles/all/velocity/value; do
		h5diff -d 1e-8 "$1/trajectory.h5" "$2/trajectory.h5" $d >/dev/null || { echo "$d differs by more than 1e-8"; return 1; }
	done
	for d in kinetic_energy temperature pressure compressibility; do
		h5diff -p 1e-9 "$1/trajectory.h5" "$2/trajectory.h5" /observables/$d/value >/dev/null ||
			{ echo "/observables/$d differs by more than 1e-9 relative"; return 1; }
	done
	return 0
}
strip() { sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//' "$1"; }

# 1. A cooling 3D gas with the TC model (N = 3000, phi 0.25, e 0.9, tc 0.01: ~15% of the collisions made elastic by
#    TC), progress every 0.1 to t = 1 (6.4 collisions per particle), frames every 0.3; --split on one rank, mpirun -np
#    2 and 4 against the serial run.
cat >"$tmp/a.json" <<'EOF'
{"method":"ed","dimensions":3,"particles":{"count":3000,"volume_fraction":0.25,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.01},"run":{"seed":3,"until":{"time":1}},
 "output":{"every":{"time":0.1},"snapshots":{"every":{"time":0.3}},
           "observables":["kinetic_energy","temperature","pressure","compressibility","collision_rate","momentum"]}}
EOF
run_tag a s
rcs=$?
for tag in 1 2 4; do
	run_tag a $tag
	rc=$?
	what=$([ $tag = 1 ] && echo "--split on one rank" || echo "mpirun -np $tag")
	cmp_records "$tmp/a.s.out" "$tmp/a.$tag.out" >"$tmp/r" 2>&1
	ok $(( rcs == 0 && rc == 0 && $? == 0 ? 0 : 1 )) "3D e 0.9 tc: $what (exit $rc): the serial run's records: $(tail -n 1 "$tmp/r" | head -c 300) $(head -c 200 "$tmp/a.$tag.err")"
	if [ $have_h5 = 1 ]; then
		why=$(cmp_traj "$tmp/a.s" "$tmp/a.$tag")
		ok $? "3D e 0.9 tc: $what: trajectory.h5 laid out as the serial one's, the same frames (5 at 0, 0.3, 0.6, 0.9, 1), states within 1e-8 $why"
	else
		n=$((n + 1)); echo "ok $n # SKIP h5dump/h5diff not installed"
	fi
done

# 2. Bit-identical reruns at one rank count: mpirun -np 2 and 4 again give the same records byte for byte (wall
#    clock columns aside) and the same trajectory.h5 content (h5diff without tolerance).
for tag in 2 4; do
	mv "$tmp/a.$tag" "$tmp/a.$tag.first"; mv "$tmp/a.$tag.out" "$tmp/a.$tag.first.out"
	run_tag a $tag
	rc=$?
	strip "$tmp/a.$tag.first.out" >"$tmp/x1"; strip "$tmp/a.$tag.out" >"$tmp/x2"
	cmp -s "$tmp/x1" "$tmp/x2"
	same=$?
	if [ $have_h5 = 1 ]; then h5diff "$tmp/a.$tag.first/trajectory.h5" "$tmp/a.$tag/trajectory.h5" >/dev/null; hs=$?; else hs=0; fi
	ok $(( rc == 0 && same == 0 && hs == 0 ? 0 : 1 )) "mpirun -np $tag twice: records byte for byte and trajectory.h5 identical (exit $rc)"
done

# 3. An elastic 2D gas (N = 2000, phi 0.3) to ~7.7 collisions per particle on 2 and 4 ranks: the serial run's records
#    (as in 1), and the kinetic energy conserved to 1e-12 relative over the run.
cat >"$tmp/b.json" <<'EOF'
{"method":"ed","dimensions":2,"particles":{"count":2000,"volume_fraction":0.3,"initial":{"positions":"random"}},
 "run":{"seed":7,"until":{"time":3.25}},"output":{"every":{"time":0.5}}}
EOF
"$ENGINE" run "$tmp/b.json" >"$tmp/b.s.out" 2>/dev/null
rcs=$?
for np in 2 4; do
	mpirun --oversubscribe -np $np "$ENGINE" run "$tmp/b.json" >"$tmp/b.$np.out" 2>"$tmp/b.$np.err"
	rc=$?
	cmp_records "$tmp/b.s.out" "$tmp/b.$np.out" >"$tmp/r" 2>&1 &&
		"$PY" - "$tmp/b.$np.out" <<'PY' >>"$tmp/r" 2>&1
import json, sys
r = [json.loads(l) for l in open(sys.argv[1])]
e0 = r[0]["kinetic_energy"]
worst = max(abs(x["kinetic_energy"] - e0) / e0 for x in r)
assert worst <= 1e-12, worst
assert r[-1]["collisions_per_particle"] > 6, r[-1]
PY
	ok $(( rcs == 0 && rc == 0 && $? == 0 ? 0 : 1 )) "2D elastic, mpirun -np $np (exit $rc): the serial run's records, energy conserved: $(head -n 1 "$tmp/r" | head -c 200) $(head -c 200 "$tmp/b.$np.err")"
done

# 4. What the split run cannot do yet is refused with --split: exit 2, one line starting with the key.
refuse() {   # refuse KEY DESCRIPTION JSON [ARGS...]
	key=$1; what=$2; json=$3; shift 3
	printf '%s\n' "$json" >"$tmp/r.json"
	"$ENGINE" run "$tmp/r.json" --split "$@" >/dev/null 2>"$tmp/r.err"
	rc=$?
	lines=$(wc -l <"$tmp/r.err")
	grep -q "^$key" "$tmp/r.err"
	ok $(( rc == 2 && lines == 1 && $? == 0 ? 0 : 1 )) "$what: exit $rc, $lines line: $(head -c 160 "$tmp/r.err")"
}
base='"dimensions":3,"particles":{"count":500,"volume_fraction":0.1}'
until='"run":{"until":{"time":1}}'
refuse boundaries "walls" "{\"method\":\"ed\",$base,$until,\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}}"
refuse gravity "gravity" "{\"method\":\"ed\",$base,$until,\"gravity\":[0,0,-1],\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}}"
refuse collisions.rough "rough particles" "{\"method\":\"ed\",$base,$until,\"collisions\":{\"rough\":{\"tangential_restitution\":0.5}}}"
refuse collisions.tc "inelastic without the TC model" "{\"method\":\"ed\",$base,$until,\"collisions\":{\"restitution\":0.9}}"
refuse run.until "a collision-count stop" "{\"method\":\"ed\",$base,\"run\":{\"until\":{\"collisions_per_particle\":2}}}"
refuse output.observables "clusters" "{\"method\":\"ed\",$base,$until,\"output\":{\"observables\":[\"clusters\"]}}"
refuse output.snapshots "frames in collisions per particle" "{\"method\":\"ed\",$base,$until,\"output\":{\"snapshots\":{\"every\":{\"collisions_per_particle\":1}}}}" --out "$tmp/out"
refuse particles.count "a box of fewer than 3 cells along an axis" "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[2.5,2.5]},$until}"

# 5. Under mpirun without --split, a scene the split run cannot do runs as before (rank 0 alone, one notice line):
#    the serial run's records exactly.
printf '%s\n' "{\"method\":\"ed\",$base,$until,\"collisions\":{\"restitution\":0.9}}" >"$tmp/f.json"
"$ENGINE" run "$tmp/f.json" >"$tmp/f.s" 2>/dev/null
mpirun -np 2 "$ENGINE" run "$tmp/f.json" >"$tmp/f.2" 2>"$tmp/f.err"
rc=$?
strip "$tmp/f.s" >"$tmp/x1"; strip "$tmp/f.2" >"$tmp/x2"
cmp -s "$tmp/x1" "$tmp/x2" && head -n 1 "$tmp/f.err" | grep -q '^granular-engine: running on rank 0 alone, not split over 2 ranks: collisions.tc'
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "mpirun -np 2, e 0.9 without tc: rank 0 alone, the serial records, exit $rc: $(head -n 1 "$tmp/f.err" | head -c 120)"

# 6. Checkpoints in the serial layout, written by rank 0 (output.checkpoint every 0.45 in time: at 0.45 and 0.9):
#    the checkpoint files of mpirun -np 2 have the serial run's layout (h5dump -H); the run resumed from the first one
#    (t = 0.45) serially and under mpirun -np 4, and the serial run's first checkpoint resumed under mpirun -np 2, give
#    the serial run's records and trajectory (as in 1).
sed 's/"snapshots":{"every":{"time":0.3}}/"snapshots":{"every":{"time":0.3}},"checkpoint":{"every":{"time":0.45}}/' \
	"$tmp/a.json" >"$tmp/c.json"
run_tag c s
rcs=$?
run_tag c 2
rc=$?
# The split run's files add one group, /ped (the core's own state, for a resume at the same rank count): the layout
# without it is the serial one's; the serial run's files have no /ped.
noped() { awk '/^   GROUP "ped" \{/ { skip = 1 } !skip { print } skip && /^   \}/ { skip = 0 }'; }
lay=0
if [ $have_h5 = 1 ]; then
	for f in checkpoint.h5 checkpoint.prev.h5; do
		h5dump -H "$tmp/c.s/$f" | tail -n +2 >"$tmp/h.a"; h5dump -H "$tmp/c.2/$f" | tail -n +2 >"$tmp/h.b"
		grep -q 'GROUP "ped"' "$tmp/h.a" && lay=1
		grep -q 'DATASET "image"' "$tmp/h.b" || lay=1
		noped <"$tmp/h.b" >"$tmp/h.c"
		cmp -s "$tmp/h.a" "$tmp/h.c" || lay=1
	done
fi
[ -f "$tmp/c.2/checkpoint.h5" ] && [ -f "$tmp/c.2/checkpoint.prev.h5" ]
ok $(( rcs == 0 && rc == 0 && lay == 0 && $? == 0 ? 0 : 1 )) "mpirun -np 2 with output.checkpoint: checkpoint.h5 and checkpoint.prev.h5 in the serial layout plus /ped (exit $rc)"
resume_check() {   # resume_check FROM WHAT LAUNCHER...
	from=$1 what=$2; shift 2
	rm -rf "$tmp/cr"; cp -r "$tmp/$from" "$tmp/cr"
	"$@" run "$tmp/c.json" --out "$tmp/cr" --resume "$tmp/cr/checkpoint.prev.h5" >/dev/null 2>"$tmp/cr.err"
	rc=$?
	cmp_records "$tmp/c.s/progress.jsonl" "$tmp/cr/progress.jsonl" >"$tmp/r" 2>&1
	res=$?
	why=
	[ $have_h5 = 1 ] && why=$(cmp_traj "$tmp/c.s" "$tmp/cr") || res=1
	ok $(( rc == 0 && res == 0 ? 0 : 1 )) "$what (exit $rc): the serial run's records and trajectory: $(tail -n 1 "$tmp/r" | head -c 200) $why $(head -c 200 "$tmp/cr.err")"
}
resume_check c.2 "the split checkpoint at t = 0.45 resumed serially" "$ENGINE"
resume_check c.2 "the split checkpoint resumed under mpirun -np 4" mpirun --oversubscribe -np 4 "$ENGINE"
resume_check c.s "the serial checkpoint resumed under mpirun -np 2" mpirun --oversubscribe -np 2 "$ENGINE"
# The split checkpoint resumed at its own rank count (mpirun -np 2) loads the core's own state (/ped/image): the
# records of the uninterrupted 2-rank run byte for byte (the wall-clock, speed and memory columns aside: load
# fields, collision counts, energies, pressure to the last bit) and trajectory.h5 equal to it value for value
# (h5diff without tolerance). Resumed from checkpoint.prev.h5 (t = 0.45, between output times) and from
# checkpoint.h5 (t = 0.9).
stripm() { strip "$1" | sed 's/"memory_bytes":[^,}]*//'; }
for ck in checkpoint.prev.h5 checkpoint.h5; do
	rm -rf "$tmp/cr"; cp -r "$tmp/c.2" "$tmp/cr"
	mpirun --oversubscribe -np 2 "$ENGINE" run "$tmp/c.json" --out "$tmp/cr" --resume "$tmp/cr/$ck" >/dev/null 2>"$tmp/cr.err"
	rc=$?
	stripm "$tmp/c.2/progress.jsonl" >"$tmp/x1"; stripm "$tmp/cr/progress.jsonl" >"$tmp/x2"
	cmp -s "$tmp/x1" "$tmp/x2"; same=$?
	[ "$(wc -l <"$tmp/x1")" -gt 10 ] || same=1
	if [ $have_h5 = 1 ]; then h5diff -q "$tmp/c.2/trajectory.h5" "$tmp/cr/trajectory.h5" >/dev/null 2>&1 || same=1; fi
	ok $(( rc == 0 && same == 0 ? 0 : 1 )) "the split checkpoint ($ck) resumed under mpirun -np 2: the uninterrupted 2-rank run's records and trajectory bit for bit (exit $rc) $(diff "$tmp/x1" "$tmp/x2" | head -n 2 | cut -c 1-300) $(head -c 200 "$tmp/cr.err")"
done

# 7. SIGTERM stops a split run at the core's next sync (rank 0's flag, reduced with every round): a last progress
#    record and a summary with status "interrupted", exit 3 (--split); under mpirun -np 2 the same records.
cat >"$tmp/long.json" <<'EOF'
{"method":"ed","dimensions":3,"particles":{"count":3000,"volume_fraction":0.25,"initial":{"positions":"random"}},
 "run":{"seed":2,"until":{"time":1e9}},"output":{"every":{"time":1}}}
EOF
stop_run() {   # stop_run OUT COMMAND...: SIGTERM to COMMAND, or to mpirun's ranks (as granulard signals them:
               # Open MPI's mpirun may kill its ranks when it gets SIGTERM itself, docs/output.md)
	out=$1; shift
	"$@" >"$out" 2>/dev/null &
	pid=$!
	i=0; until [ -s "$out" ] || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
	sleep 0.5
	if [ "$1" = mpirun ]; then kill -TERM $(ps --ppid $pid -o pid=) 2>/dev/null; else kill -TERM $pid; fi
	i=0; while kill -0 $pid 2>/dev/null && [ $i -lt 600 ]; do sleep 0.1; i=$((i + 1)); done
	kill -KILL $pid 2>/dev/null   # still running after 60 s: the stop was not seen (fails below)
	wait $pid
}
stop_run "$tmp/long1.out" "$ENGINE" run "$tmp/long.json" --split
rc=$?
tail -n 1 "$tmp/long1.out" | grep -q '"type":"summary","status":"interrupted"' &&
	tail -n 2 "$tmp/long1.out" | head -n 1 | grep -q '"type":"progress"'
ok $(( rc == 3 && $? == 0 ? 0 : 1 )) "SIGTERM (--split): last record and summary with status interrupted, exit $rc"
stop_run "$tmp/long2.out" mpirun -np 2 "$ENGINE" run "$tmp/long.json"
rc=$?
tail -n 1 "$tmp/long2.out" | grep -q '"type":"summary","status":"interrupted"'
ok $(( rc == 3 && $? == 0 ? 0 : 1 )) "SIGTERM to the ranks of mpirun -np 2: summary with status interrupted, exit $rc: $(tail -n 1 "$tmp/long2.out" | head -c 120)"
# With --out, as the serial run: nothing sampled, a checkpoint, the summary (interrupted), exit 4; the checkpoint
# resumed serially runs to the end with the serial run's output times (the trajectories themselves part after
# tens of collisions per particle, by the chaos of the dynamics) and the energy of the elastic gas (1e-12 relative).
sed 's/"until":{"time":1e9}/"until":{"time":30}/' "$tmp/long.json" >"$tmp/t.json"
"$ENGINE" run "$tmp/t.json" >"$tmp/t.s" 2>/dev/null
stop_run "$tmp/t.1" "$ENGINE" run "$tmp/t.json" --split --out "$tmp/t"
rc=$?
tail -n 1 "$tmp/t.1" | grep -q '"type":"summary","status":"interrupted"' && [ -f "$tmp/t/checkpoint.h5" ]
st=$?
"$ENGINE" run "$tmp/t.json" --out "$tmp/t" --resume "$tmp/t/checkpoint.h5" >/dev/null 2>"$tmp/t.err"
rc2=$?
"$PY" - "$tmp/t.s" "$tmp/t/progress.jsonl" <<'PY' >"$tmp/r" 2>&1
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert [x["time"] for x in a] == [x["time"] for x in b], "output times"
e0 = b[0]["kinetic_energy"]
assert max(abs(x["kinetic_energy"] - e0) / e0 for x in b) <= 1e-12
assert b[-1]["status"] == "completed" and sum(1 for x in b if x["type"] == "summary") == 1
print("%d records" % len(b))
PY
ok $(( rc == 4 && st == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "SIGTERM with --out (--split): checkpoint, summary interrupted, exit $rc; resumed serially: exit $rc2, $(tail -n 1 "$tmp/r" | head -c 200) $(head -c 200 "$tmp/t.err")"
stop_run "$tmp/t.2" mpirun -np 2 "$ENGINE" run "$tmp/t.json" --out "$tmp/t2"
rc=$?
tail -n 1 "$tmp/t.2" | grep -q '"type":"summary","status":"interrupted"' && [ -f "$tmp/t2/checkpoint.h5" ]
st=$?
"$ENGINE" run "$tmp/t.json" --out "$tmp/t2" --resume "$tmp/t2/checkpoint.h5" >/dev/null 2>"$tmp/t.err"
rc2=$?
tail -n 1 "$tmp/t2/progress.jsonl" | grep -q '"type":"summary","status":"completed","time":30,'
ok $(( rc == 4 && st == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "SIGTERM to the ranks of mpirun -np 2 with --out: checkpoint, exit $rc; resumed serially to the end: exit $rc2 $(head -c 200 "$tmp/t.err")"

# 8. A wall-clock checkpoint (every 0.5 s) comes between output times (every 400 time units, ~4 10^6 collisions):
#    the run stops for rank 0's clock at chunks of about a second of wall time, not only at the schedule's stops.
if [ $have_h5 = 1 ]; then
	sed 's/"until":{"time":1e9}},"output":{"every":{"time":1}}/"until":{"time":1000}},"output":{"every":{"time":400},"checkpoint":{"every":{"wall_seconds":0.5}}}/' \
		"$tmp/long.json" >"$tmp/w.json"
	"$ENGINE" run "$tmp/w.json" --split --out "$tmp/w" >"$tmp/w.out" 2>/dev/null &
	pid=$!
	i=0; until [ -f "$tmp/w/checkpoint.h5" ] || [ $i -ge 600 ]; do sleep 0.1; i=$((i + 1)); done
	tck=$(h5dump -a time "$tmp/w/checkpoint.h5" 2>/dev/null | sed -n 's/^ *(0): //p')
	kill -TERM $pid
	wait $pid
	rc=$?
	"$PY" -c 'import sys; t = float(sys.argv[1]); assert 0 < t < 400, t' "${tck:-nan}" 2>/dev/null
	ok $(( rc == 4 && $? == 0 ? 0 : 1 )) "wall-clock checkpoint before the first output time (at t = $tck of 400), SIGTERM: exit $rc"
else
	n=$((n + 1)); echo "ok $n # SKIP h5dump not installed"
fi

echo "1..$n"
[ "$failed" = 0 ]
