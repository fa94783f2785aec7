#!/bin/sh
# Ensembles of mixtures (particles.species with run.replicas > 1) through the real program: each replica on its own stream, per-species means; resume of ensembles and of a rough mixture (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/mixture_ensemble_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
PY=/usr/bin/python3

# A dense 2D mixture, one species polydisperse (its radii drawn from each replica's stream).
cat >"$tmp/ens.json" <<'EOF'
{"method":"ed","dimensions":2,
 "particles":{"species":[{"name":"big","count":100,"radius":0.8,"mass":3},{"name":"poly","count":300,"radius_range":[0.3,0.5],"mass":1}],
  "volume_fraction":0.45,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":7,"until":{"time":2},"replicas":2},
 "output":{"every":{"time":0.25},"observables":["temperature","pressure"],"snapshots":{"every":{"time":0.5}}}}
EOF
sed 's/"replicas":2/"replicas":1/' "$tmp/ens.json" >"$tmp/one.json"
"$ENGINE" run "$tmp/ens.json" --out "$tmp/E" >/dev/null 2>"$tmp/err" &&
	"$ENGINE" run "$tmp/one.json" --out "$tmp/O" >/dev/null 2>>"$tmp/err"
ok $? "a mixture ensemble of 2 replicas and its single run complete ($(head -n 1 "$tmp/err"))"

# 1. Replica 0 runs on random stream 0, as the single run does: its frames, diameters and masses are the single run's, bit for bit.
h5diff -q "$tmp/E/trajectory.h5" "$tmp/O/trajectory.h5" /particles/replica_0 /particles/all
ok $? "replica_0's particles group (positions, velocities, species, diameters, masses) equals the single run's bit for bit"

# 2. Replica 1 has its own stream: its own polydisperse radii (the monodisperse species' the same), and the
# diameters written for it are the ones its engine uses: no two of its particles closer than the sum of their
# radii in any frame, while with replica 0's diameters the same frames overlap (the check has power).
for r in 0 1; do
	h5dump -d "/particles/replica_$r/diameter" -b LE -o "$tmp/d$r" "$tmp/E/trajectory.h5" >/dev/null 2>&1
	h5dump -d "/particles/replica_$r/position/value" -b LE -o "$tmp/p$r" "$tmp/E/trajectory.h5" >/dev/null 2>&1
done
box=$(h5dump -d /particles/replica_1/box/edges/value -s 0,0,0 -c 1,1,1 "$tmp/E/trajectory.h5" 2>/dev/null |
	sed -n 's/^ *(0,0,0): *\([0-9.e+-]*\).*/\1/p')
"$PY" - "$tmp" 400 "$box" <<'EOF'
import struct, sys
t, n, L = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rd = lambda f: struct.unpack("<%dd" % (len(open(f, "rb").read()) // 8), open(f, "rb").read())
d0, d1, p1 = rd(t + "/d0"), rd(t + "/d1"), rd(t + "/p1")
assert len(d0) == len(d1) == n and len(p1) % (2 * n) == 0, "sizes"
assert d0[:100] == d1[:100] == (1.6,) * 100, "the monodisperse species: diameter 1.6 in both replicas"
assert all(a != b for a, b in zip(d0[100:], d1[100:])), "replica 1 draws its own polydisperse radii"
assert all(0.6 <= x <= 1.0 for x in d1[100:]), "in radius_range"
def overlaps(p, d, f):
    c = 0
    for i in range(n):
        for j in range(i):
            dx = p[f + 2 * i] - p[f + 2 * j]; dy = p[f + 2 * i + 1] - p[f + 2 * j + 1]
            dx -= L * round(dx / L); dy -= L * round(dy / L)
            if dx * dx + dy * dy < (0.5 * (d[i] + d[j]) * (1 - 1e-9)) ** 2:
                c += 1
    return c
frames = len(p1) // (2 * n)
own = sum(overlaps(p1, d1, 2 * n * k) for k in range(frames))
other = sum(overlaps(p1, d0, 2 * n * k) for k in range(frames))
print("# replica 1, %d frames: %d overlaps with its own diameters, %d with replica 0's" % (frames, own, other))
sys.exit(0 if own == 0 and other > 0 else 1)
EOF
ok $? "replica 1: its own radii (stream 1), no overlaps with them in any frame, overlaps with replica 0's"

# 3. Per-species temperatures: the record's mean over the 2 replicas and its standard error; with 2 replicas
# the sample standard error of the mean is |x0 - x1| / 2 = |mean - x0|, x0 the single run (stream 0).
"$PY" - "$tmp/E/progress.jsonl" "$tmp/O/progress.jsonl" <<'EOF'
import json, sys
e = [json.loads(l) for l in open(sys.argv[1]) if '"progress"' in l]
o = [json.loads(l) for l in open(sys.argv[2]) if '"progress"' in l]
assert len(e) == len(o) >= 8, "rows"
for a, b in zip(e, o):
    assert a["replicas"] == 2 and a["time"] == b["time"]
    m, se, x0 = a["temperature_species"], a["temperature_species_se"], b["temperature_species"]
    assert len(m) == len(se) == len(x0) == 2
    for k in range(2):
        x1 = 2 * m[k] - x0[k]   # replica 1, from the mean
        assert abs(se[k] - abs(m[k] - x0[k])) <= 1e-12 * m[k], (a["time"], k, se[k], m[k], x0[k])
        assert x1 > 0 and x1 != x0[k], "replica 1 another run"
    # the mixture's temperature is the particle-number weighted mean of the species' (100 and 300 particles)
    assert abs(a["temperature"] - (100 * m[0] + 300 * m[1]) / 400) <= 1e-12 * a["temperature"]
print("# %d rows: temperature_species = mean over replicas, _se = |mean - replica 0|" % len(e))
EOF
ok $? "temperature_species: means over the replicas with their standard errors (replica 0 = the single run)"

# 4. The ensemble under mpirun -np 2 (replica 1 on rank 1) gives the serial output.
if command -v mpirun >/dev/null 2>&1; then
	mpirun -np 2 "$ENGINE" run "$tmp/ens.json" --out "$tmp/M" >/dev/null 2>"$tmp/mpi.err"
	rc=$?
	strip() { sed 's/,"wall_seconds":[^,}]*//; s/,"events_per_second":[^,}]*//; s/,"collisions_per_second":[^,}]*//' "$1"; }
	strip "$tmp/E/progress.jsonl" >"$tmp/e.txt"; strip "$tmp/M/progress.jsonl" >"$tmp/m.txt"
	[ $rc -eq 0 ] && cmp -s "$tmp/e.txt" "$tmp/m.txt" && h5diff -q "$tmp/E/trajectory.h5" "$tmp/M/trajectory.h5" /particles /particles
	ok $? "mpirun -np 2: the same records and frames as the serial ensemble (exit $rc; $(head -c 150 "$tmp/mpi.err"))"
fi

# 5. Checkpoint and resume: the ensemble resumed from its checkpoint ends as the uninterrupted run, bit for bit.
sed 's/"snapshots":{"every":{"time":0.5}}/"snapshots":{"every":{"time":0.5}},"checkpoint":{"every":{"time":0.6}}/' \
	"$tmp/ens.json" >"$tmp/ck.json"
"$ENGINE" run "$tmp/ck.json" --out "$tmp/C" >/dev/null 2>"$tmp/ck.err"
rc=$?
cp -r "$tmp/C" "$tmp/R"
"$ENGINE" run "$tmp/ck.json" --resume "$tmp/R/checkpoint.prev.h5" --out "$tmp/R" >/dev/null 2>>"$tmp/ck.err"
rc2=$?
strip() { sed 's/,"wall_seconds":[^,}]*//; s/,"events_per_second":[^,}]*//; s/,"collisions_per_second":[^,}]*//' "$1"; }
strip "$tmp/C/progress.jsonl" >"$tmp/c.txt"; strip "$tmp/R/progress.jsonl" >"$tmp/r.txt"
[ $rc -eq 0 ] && [ $rc2 -eq 0 ] && [ -f "$tmp/C/checkpoint.prev.h5" ] && cmp -s "$tmp/c.txt" "$tmp/r.txt" &&
	h5diff -q "$tmp/C/trajectory.h5" "$tmp/R/trajectory.h5" /particles /particles &&
	h5diff -q "$tmp/C/trajectory.h5" "$tmp/R/trajectory.h5" /observables /observables
ok $? "resume from checkpoint.prev.h5: progress, frames and observables identical (exit $rc, $rc2; $(head -n 1 "$tmp/ck.err"))"

# 6. A single rough mixture between a specular floor and a thermal ceiling under gravity, Walton's rule, TC:
# resumed from its earlier checkpoint it ends as the uninterrupted run, bit for bit (spins, species, walls).
cat >"$tmp/rk.json" <<'EOF'
{"method":"ed","dimensions":3,
 "particles":{"species":[{"name":"a","count":300,"radius":0.6,"mass":2},{"name":"b","count":500,"radius_range":[0.3,0.5],"mass":1}],
  "box":[14,14,20],"initial":{"positions":"random","rotational_temperature":0.5}},
 "collisions":{"restitution":0.9,"tc":1e-4,"rough":{"tangential_restitution":0.4,"friction":0.3}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"thermal","temperature":1}}},"gravity":[0,0,-0.5],
 "run":{"seed":6,"until":{"time":6}},"output":{"every":{"time":0.5},"observables":["temperature","rotational_temperature","center_of_mass_height"],"snapshots":{"every":{"time":1}},"checkpoint":{"every":{"time":2.2}}}}
EOF
"$ENGINE" run "$tmp/rk.json" --out "$tmp/RC" >/dev/null 2>"$tmp/rk.err"
rc=$?
cp -r "$tmp/RC" "$tmp/RR"
"$ENGINE" run "$tmp/rk.json" --resume "$tmp/RR/checkpoint.prev.h5" --out "$tmp/RR" >/dev/null 2>>"$tmp/rk.err"
rc2=$?
strip "$tmp/RC/progress.jsonl" >"$tmp/rc.txt"; strip "$tmp/RR/progress.jsonl" >"$tmp/rr.txt"
[ $rc -eq 0 ] && [ $rc2 -eq 0 ] && cmp -s "$tmp/rc.txt" "$tmp/rr.txt" &&
	h5diff -q "$tmp/RC/trajectory.h5" "$tmp/RR/trajectory.h5" /particles /particles &&
	h5diff -q "$tmp/RC/trajectory.h5" "$tmp/RR/trajectory.h5" /observables /observables
ok $? "rough mixture with walls and gravity: resume from checkpoint.prev.h5 identical (exit $rc, $rc2; $(head -n 1 "$tmp/rk.err"))"

echo "1..$n"
[ $failed -eq 0 ]
