#!/bin/sh
# One dsmc system split over MPI ranks (engine/mc/dsmcp.h, engine/par/dsmcrun.h) through the real program (TAP):
# the same records on 1 (--split), 2, 3 and 4 ranks, Haff's law over 2 ranks, the refusals naming the key, and
# the same frames (--out, gathered to rank 0) on 1, 2 and 3 ranks.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dsmc_split_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

if ! command -v mpirun >/dev/null 2>&1; then
	echo "1..0 # SKIP no mpirun"
	exit 0
fi

# 1. Bit-identity over rank counts: a cooling 3D gas of 20000 particles (19^3 cells, slabs of 19/P planes,
#    thousands of migrants per step), progress every 0.25 to t = 2. Time, events, collisions, kinetic energy
#    and temperature are exact sums (docs/parallel.md), so those columns are equal byte for byte; pressure,
#    compressibility and momentum are sums of doubles over ranks: equal to 1e-12 relative (1e-9 absolute for
#    the momentum, whose exact value is 0 and whose rounding is ~1e-12).
cat >"$tmp/p.json" <<'EOF'
{"method":"dsmc","dimensions":3,"particles":{"count":20000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":5,"until":{"time":2}},
 "output":{"every":{"time":0.25},"observables":["kinetic_energy","temperature","pressure","compressibility",
                                               "collision_rate","momentum"]}}
EOF
strip() { sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//;
               s/"memory_bytes":[^,}]*//; s/"pressure":[^,}]*//; s/"compressibility":[^,}]*//;
               s/"momentum":\[[^]]*\]//' "$1"; }
"$ENGINE" run "$tmp/p.json" --split >"$tmp/o1" 2>"$tmp/e1"
rc1=$?
ok $(( rc1 == 0 && $(grep -c '"type":"progress"' "$tmp/o1") == 9 ? 0 : 1 )) "--split on one rank: exit $rc1, 9 progress lines"
for np in 2 3 4; do
	mpirun --oversubscribe -np $np "$ENGINE" run "$tmp/p.json" >"$tmp/o$np" 2>"$tmp/e$np"
	rc=$?
	strip "$tmp/o1" >"$tmp/s1"
	strip "$tmp/o$np" >"$tmp/s$np"
	cmp -s "$tmp/s1" "$tmp/s$np"
	same=$?
	$PY - "$tmp/o1" "$tmp/o$np" <<'PY'
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert len(a) == len(b) and len(a) > 2
for x, y in zip(a, b):
    for k in ("pressure", "compressibility"):
        if x.get(k) is not None:
            assert abs(x[k] - y[k]) <= 1e-12 * abs(x[k]), (k, x[k], y[k])
    for u, v in zip(x.get("momentum", []), y.get("momentum", [])):
        assert abs(u - v) <= 1e-9, ("momentum", u, v)
PY
	ok $(( rc == 0 && same == 0 && $? == 0 ? 0 : 1 )) "mpirun -np $np: exit $rc, records equal to the 1-rank split run (exact columns byte for byte)"
done
grep -q '"collisions":[1-9]' "$tmp/o2"
ok $? "the split run collides: $(tail -n 1 "$tmp/o2" | head -c 160)"

# 1b. A schedule in collisions per particle (run.until and output.every): each record after the step that
#     reaches its count, as the serial run (the same number of records), identical on 1 (--split), 2 and 3
#     ranks; 2D, CBA offsets.
cat >"$tmp/c.json" <<'EOF'
{"method":"dsmc","dimensions":2,"particles":{"count":4000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.8},"dsmc":{"correction":"cba"},"run":{"seed":8,"until":{"collisions_per_particle":3}},
 "output":{"every":{"collisions_per_particle":0.5}}}
EOF
"$ENGINE" run "$tmp/c.json" >"$tmp/c0" 2>/dev/null
"$ENGINE" run "$tmp/c.json" --split >"$tmp/c1" 2>/dev/null
rc1=$?
strip "$tmp/c1" >"$tmp/cs1"
for np in 2 3; do
	mpirun --oversubscribe -np $np "$ENGINE" run "$tmp/c.json" >"$tmp/c$np" 2>/dev/null
	rc=$?
	strip "$tmp/c$np" >"$tmp/cs$np"
	cmp -s "$tmp/cs1" "$tmp/cs$np"
	same=$?
	"$PY" - "$tmp/c0" "$tmp/c$np" <<'PY'
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert len(a) == len(b) == 8, (len(a), len(b))
for k, r in enumerate(b[1:-1]):   # the record of output k+1 comes after the step reaching 0.5 (k+1) per particle
    assert r["collisions_per_particle"] >= 0.5 * (k + 1) - 1e-12, (k, r["collisions_per_particle"])
assert b[-2]["collisions_per_particle"] >= 3 and b[-1]["status"] == "completed"
PY
	ok $(( rc1 == 0 && rc == 0 && same == 0 && $? == 0 ? 0 : 1 )) "collisions-per-particle schedule, mpirun -np $np: the serial run's 8 records, equal to the 1-rank split run (exit $rc)"
done

# 1c. hsmc: a dense 2D gas (nu = 0.75, cells of 2 diameters) with cell-cell collisions and rejected moves
#     across the slab borders: the records of 2, 3 and 4 ranks equal the 1-rank split run's.
cat >"$tmp/h.json" <<'EOF'
{"method":"hsmc","dimensions":2,"particles":{"count":6000,"volume_fraction":0.75,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"hsmc":{"cell_size":2},"run":{"seed":4,"until":{"time":0.5}},
 "output":{"every":{"time":0.1}}}
EOF
"$ENGINE" run "$tmp/h.json" --split >"$tmp/h1" 2>/dev/null
rc1=$?
strip "$tmp/h1" >"$tmp/hs1"
for np in 2 3 4; do
	mpirun --oversubscribe -np $np "$ENGINE" run "$tmp/h.json" >"$tmp/h$np" 2>/dev/null
	rc=$?
	strip "$tmp/h$np" >"$tmp/hs$np"
	cmp -s "$tmp/hs1" "$tmp/hs$np"
	same=$?
	cc=$(tail -n 1 "$tmp/h$np" | sed -n 's/.*"cell_collisions":\([0-9]*\).*/\1/p')
	ok $(( rc1 == 0 && rc == 0 && same == 0 && ${cc:-0} > 0 ? 0 : 1 )) "hsmc, mpirun -np $np: records equal to the 1-rank split run ($cc cell collisions, exit $rc)"
done

# 2. Haff's law through the program on 2 ranks: 6 seeds of a 3D gas (N = 2000, nu = 0.1, e = 0.9, chi = 1),
#    8 outputs to tau = 2; the mean T/T0 over the seeds within 4 standard errors plus 1.5% of theory (the
#    Sonine and time-splitting allowance of tests/dsmc_test.c), at every output.
for r in 0 1 2 3 4 5; do
	$PY - "$r" >"$tmp/h$r.json" <<'PY'
import json, math, sys
nu, e, D = 0.1, 0.9, 3
f = D * 2 ** (D - 1) / (math.sqrt(math.pi) * 0.5) * nu
t_end = 2 * 2 * D / ((1 - e * e) * f)
print(json.dumps({"method": "dsmc", "dimensions": 3,
                  "particles": {"count": 2000, "volume_fraction": nu, "initial": {"positions": "random"}},
                  "collisions": {"restitution": e}, "run": {"seed": 300 + int(sys.argv[1]), "until": {"time": t_end}},
                  "output": {"every": {"time": t_end / 8}, "observables": ["temperature"]}}))
PY
	mpirun -np 2 "$ENGINE" run "$tmp/h$r.json" >"$tmp/h$r.out" 2>>"$tmp/h.err" || echo "seed $r failed" >>"$tmp/h.err"
done
$PY - "$tmp" <<'PY' >"$tmp/haff"
import json, math, sys
nu, e, D, R = 0.1, 0.9, 3, 6
f = D * 2 ** (D - 1) / (math.sqrt(math.pi) * 0.5) * nu
rate = (1 - e * e) * f / (2 * D)
runs = []
for r in range(R):
    rec = [json.loads(l) for l in open("%s/h%d.out" % (sys.argv[1], r)) if '"progress"' in l]
    assert len(rec) == 9, len(rec)
    runs.append(rec)
worst = 0
for k in range(1, 9):
    x = [run[k]["temperature"] / run[0]["temperature"] for run in runs]
    m = sum(x) / R
    se = math.sqrt(sum((v - m) ** 2 for v in x) / (R - 1) / R)
    tau = rate * runs[0][k]["time"]
    th = 1 / (1 + tau) ** 2
    worst = max(worst, abs(m - th) / (4 * se + 0.015 * th))
print("%.2f" % worst)
assert worst < 1
PY
ok $? "Haff's law on 2 ranks, 6 seeds: worst deviation $(cat "$tmp/haff") of tolerance $(head -c 200 "$tmp/h.err")"

# 3. What the split run cannot do yet is refused: exit 2, one line naming the key (--split shows the line
#    alone; under mpirun, mpirun adds its own notice after it): walls, gravity, curve observables, and the
#    checkpoint of a run on one rank (not split) with --split. (Split checkpoints: tests/dsmc_split_resume_test.sh.)
refuse() {   # refuse KEY DESCRIPTION JSON [ARGS...]
	key=$1; what=$2; json=$3; shift 3
	printf '%s\n' "$json" >"$tmp/r.json"
	"$ENGINE" run "$tmp/r.json" --split "$@" >/dev/null 2>"$tmp/r.err"
	rc=$?
	lines=$(wc -l <"$tmp/r.err")
	grep -q "^$key" "$tmp/r.err"
	ok $(( rc == 2 && lines == 1 && $? == 0 ? 0 : 1 )) "$what: exit $rc, $lines line: $(head -c 160 "$tmp/r.err")"
}
base='"dimensions":3,"particles":{"count":500,"volume_fraction":0.05},"run":{"until":{"time":1}}'
refuse boundaries "walls" "{\"method\":\"dsmc\",$base,\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}}"
refuse gravity "gravity" "{\"method\":\"dsmc\",$base,\"gravity\":[0,0,-1]}"
refuse output.observables "clusters" "{\"method\":\"dsmc\",$base,\"output\":{\"observables\":[\"clusters\"]}}"
# a checkpoint of a run on one rank (plain, not split): with --split refused; under mpirun alone the run goes on
# as before the split path existed (rank 0 alone, one notice line), so jobs that worked keep working
printf '%s\n' "{\"method\":\"dsmc\",$base,\"output\":{\"checkpoint\":{\"every\":{\"time\":0.5}}}}" >"$tmp/c.json"
"$ENGINE" run "$tmp/c.json" --out "$tmp/out2" >/dev/null 2>&1
refuse "granular-engine: --resume: the checkpoint is of a run on one rank" "--split with a plain run's checkpoint" \
	"{\"method\":\"dsmc\",$base,\"output\":{\"checkpoint\":{\"every\":{\"time\":0.5}}}}" --out "$tmp/out2" --resume "$tmp/out2/checkpoint.h5"
mpirun -np 2 "$ENGINE" run "$tmp/c.json" --out "$tmp/out2" --resume "$tmp/out2/checkpoint.h5" >/dev/null 2>"$tmp/m.err"
rc=$?
head -n 1 "$tmp/m.err" | grep -q '^granular-engine: running on rank 0 alone, not split over 2 ranks: --resume: the checkpoint is of a run on one rank'
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "mpirun -np 2 --resume of a plain run's checkpoint: rank 0 alone, exit $rc, first line $(head -n 1 "$tmp/m.err" | head -c 120)"

# 4. Frames (--out): gathered to rank 0 in the scene's particle order; trajectory.h5 of 2 and 3 ranks equal to
#    the 1-rank split run's dataset by dataset, byte for byte (positions, velocities, times, observables; pressure,
#    compressibility and momentum to the bounds of section 1), and
#    a frame at the first state, after the step reaching each snapshot instant, and at the last state.
if "$PY" -c 'import h5py, numpy' 2>/dev/null; then
	cat >"$tmp/f.json" <<'EOF'
{"method":"dsmc","dimensions":3,"particles":{"count":3000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":5,"until":{"time":2}},
 "output":{"every":{"time":0.25},"snapshots":{"every":{"time":0.7}},
           "observables":["kinetic_energy","temperature","pressure","collision_rate","momentum"]}}
EOF
	"$ENGINE" run "$tmp/f.json" --split --out "$tmp/f1" >/dev/null 2>"$tmp/f.err"
	rc=$?
	for np in 2 3; do
		mpirun --oversubscribe -np $np "$ENGINE" run "$tmp/f.json" --out "$tmp/f$np" >/dev/null 2>>"$tmp/f.err"
		rc2=$?
		"$PY" - "$tmp/f1/trajectory.h5" "$tmp/f$np/trajectory.h5" <<'PY' >"$tmp/f.res"
import sys, h5py, numpy as np
def walk(g, out, p=""):
    for k in g:
        o = g[k]
        if isinstance(o, h5py.Dataset):
            out[p + "/" + k] = o[()]
        else:
            walk(o, out, p + "/" + k)
a, b = {}, {}
walk(h5py.File(sys.argv[1], "r"), a)
walk(h5py.File(sys.argv[2], "r"), b)
assert sorted(a) == sorted(b), (sorted(a), sorted(b))
for k in a:
    if "pressure" in k or "compressibility" in k:
        assert np.allclose(a[k], b[k], rtol=1e-12, atol=0, equal_nan=True), k
    elif "momentum/value" in k:   # exactly 0, rounding ~1e-12 (section 1)
        assert np.allclose(a[k], b[k], rtol=0, atol=1e-9), k
    else:
        assert np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes(), k
t = a["/particles/all/position/time"]
assert list(t[:1]) == [0.0] and t[-1] == 2.0 and len(t) == 4, t
assert 0.7 <= t[1] < 0.9 and 1.4 <= t[2] < 1.6, t
x = a["/particles/all/position/value"]
assert x.shape == (4, 3000, 3) and np.isfinite(x).all()
print("frames at %s" % np.round(t, 4).tolist())
PY
		ok $(( rc == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "--out under mpirun -np $np: trajectory.h5 equal to the 1-rank split run's ($(cat "$tmp/f.res") $(head -c 200 "$tmp/f.err"))"
	done
else
	for np in 2 3; do n=$((n + 1)); echo "ok $n # SKIP python3-h5py not installed"; done
fi

# 4b. SIGTERM stops a split run without --out after the next step (rank 0's flag, reduced with the step): a last
#     progress record and a summary with status "interrupted", exit 3 (no checkpoint to write; with --out:
#     tests/dsmc_split_resume_test.sh).
cat >"$tmp/long.json" <<'EOF'
{"method":"dsmc","dimensions":3,"particles":{"count":20000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":1},"run":{"seed":2,"until":{"time":1e9}},"output":{"every":{"time":1}}}
EOF
"$ENGINE" run "$tmp/long.json" --split >"$tmp/long.out" 2>/dev/null &
pid=$!
i=0; until [ -s "$tmp/long.out" ] || [ $i -ge 300 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
kill -TERM $pid
wait $pid
rc=$?
tail -n 1 "$tmp/long.out" | grep -q '"type":"summary","status":"interrupted"'
ok $(( rc == 3 && $? == 0 ? 0 : 1 )) "SIGTERM: summary with status interrupted, exit $rc"

# 5. Ensembles keep their meaning: run.replicas 2 under mpirun -np 2 is two replicas, not a split system.
sed 's/"seed":5,/"seed":5,"replicas":2,/; s/"count":20000/"count":1000/' "$tmp/p.json" >"$tmp/ens.json"
"$ENGINE" run "$tmp/ens.json" >"$tmp/ens1" 2>/dev/null
mpirun -np 2 "$ENGINE" run "$tmp/ens.json" >"$tmp/ens2" 2>/dev/null
rc=$?
estrip() { sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//' "$1"; }
estrip "$tmp/ens1" >"$tmp/es1"; estrip "$tmp/ens2" >"$tmp/es2"
cmp -s "$tmp/es1" "$tmp/es2" && grep -q '"replicas":2' "$tmp/ens2"
ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "run.replicas 2 under mpirun -np 2: the serial ensemble's records (exit $rc)"

echo "1..$n"
[ "$failed" = 0 ]
