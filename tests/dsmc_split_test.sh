#!/bin/sh
# One dsmc system split over MPI ranks (engine/mc/dsmcp.h, engine/par/dsmcrun.h) through the real program (TAP):
# the same records on 1 (--split), 2, 3 and 4 ranks, Haff's law over 2 ranks, and the refusals naming the key.
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
#    alone; under mpirun, mpirun adds its own notice after it).
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
refuse method "hsmc" "{\"method\":\"hsmc\",$base}"
refuse boundaries "walls" "{\"method\":\"dsmc\",$base,\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}}"
refuse gravity "gravity" "{\"method\":\"dsmc\",$base,\"gravity\":[0,0,-1]}"
refuse output.observables "clusters" "{\"method\":\"dsmc\",$base,\"output\":{\"observables\":[\"clusters\"]}}"
refuse granular-engine "--out" "{\"method\":\"dsmc\",$base}" --out "$tmp/out"
mpirun -np 2 "$ENGINE" run "$tmp/r.json" --out "$tmp/out2" >/dev/null 2>"$tmp/m.err"
rc=$?
head -n 1 "$tmp/m.err" | grep -q '^granular-engine: --out: frames and checkpoints'
ok $(( rc == 2 && $? == 0 ? 0 : 1 )) "mpirun -np 2 --out: exit $rc, first line $(head -n 1 "$tmp/m.err" | head -c 120)"

# 4. Ensembles keep their meaning: run.replicas 2 under mpirun -np 2 is two replicas, not a split system.
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
