#!/bin/sh
# Observables of mixtures (particles.species, issue 12) through the real program (TAP): the velocity
# distribution with each species scaled by its own temperature, the coarse-grained fields mass-weighted,
# clusters with each particle's own radius, the mean-square displacement; against theory and brute force.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/mixture_obs_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()

# An elastic binary mixture in equilibrium: 300 disks of radius 0.5 and mass 1, 100 of radii uniform in
# [0.8, 1.2] and mass 4, periodic 80 x 80 (area fraction 0.08), T = 1; records and snapshots every 15 time
# units (about 3 collisions per particle: nearly independent samples) to t = 600, the first 150 left out.
cat >"$tmp/m.json" <<'EOF'
{"method": "ed", "dimensions": 2,
 "particles": {"species": [{"name": "light", "count": 300, "radius": 0.5, "mass": 1},
                           {"name": "heavy", "count": 100, "radius_range": [0.8, 1.2], "mass": 4}],
               "box": [80, 80]},
 "run": {"until": {"time": 600}, "seed": 9},
 "output": {"every": {"time": 15}, "observables": ["kinetic_energy", "velocity_distribution", "clusters",
            "mean_square_displacement"],
            "clusters": {"delta": 0.5},
            "snapshots": {"every": {"time": 15}}}}
EOF
if "$ENGINE" run "$tmp/m.json" --out "$tmp/M" >"$tmp/m.out" 2>"$tmp/m.err"; then
	# 1. In equilibrium every species is Maxwellian at the common T (equipartition), so the pooled velocities,
	#    each scaled by its own species' thermal speed, have a2 = 0: the mean over the snapshots within 4 se.
	#    (Scaled by one mass for all, the pooled distribution would mix two Gaussians whose widths differ by a
	#    factor 2 here: a2 = 0.16 in 2D, 17 of these standard errors.)
	# 2. Clusters with each particle's radius: at every snapshot the progress record's count and largest
	#    cluster equal a brute-force union-find over all pairs of the frame (minimum image, cutoff
	#    r_i + r_j + delta, delta = 0.5 of the largest diameter, 2.4).
	# 3. The mean-square displacement grows (finite in every record).
	"$PY" - "$tmp/M" >"$tmp/m.res" 2>&1 <<'PY'
import h5py, json, math, sys
out = sys.argv[1]
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
prog = [p for p in map(json.loads, open(out + '/progress.jsonl')) if p['type'] == 'progress']
byt = {p['time']: p for p in prog}
def ms(v):
    m = sum(v) / len(v)
    return m, math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1) / len(v))
vd = [c for c in cur if c['name'] == 'velocity_distribution' and c['time'] >= 150]
a2, se = ms([c['a2'] for c in vd])
print('%s - mixture: pooled a2 of the velocities scaled per species %.4f +- %.4f over %d snapshots (0, 4 se)' %
      ('ok' if len(vd) >= 25 and abs(a2) < 4 * se else 'not ok', a2, se, len(vd)))
f = h5py.File(out + '/trajectory.h5', 'r')
pos = f['/particles/all/position/value'][...]
times = f['/particles/all/position/time'][...]
diam = f['/particles/all/diameter'][...]
L, delta = 80.0, 0.5 * 2 * 1.2
N = len(diam)
bad, checked = 0, 0
for k, t in enumerate(times):
    if t not in byt or 'clusters' not in byt[t]:
        continue
    par = list(range(N))
    def find(x):
        while par[x] != x:
            par[x] = par[par[x]]
            x = par[x]
        return x
    p = pos[k]
    for i in range(N):
        for j in range(i + 1, N):
            dx = p[i][0] - p[j][0]; dy = p[i][1] - p[j][1]
            dx -= L * round(dx / L); dy -= L * round(dy / L)
            cut = 0.5 * (diam[i] + diam[j]) + delta
            if dx * dx + dy * dy < cut * cut:
                a, b = find(i), find(j)
                if a != b:
                    par[a] = b
    sizes = {}
    for i in range(N):
        r = find(i)
        sizes[r] = sizes.get(r, 0) + 1
    c = byt[t]['clusters']
    checked += 1
    if c['count'] != len(sizes) or c['largest'] != max(sizes.values()):
        bad += 1
print('%s - mixture clusters with each particle\'s radius: count and largest equal brute force at %d of %d snapshots' %
      ('ok' if checked >= 30 and bad == 0 else 'not ok', checked - bad, checked))
m = [p['msd'] for p in prog[1:]]
print('%s - mixture msd finite and growing (%.1f .. %.1f)' %
      ('ok' if all(x is not None and math.isfinite(x) for x in m) and m[-1] > m[0] > 0 else 'not ok', m[0], m[-1]))
PY
	report "$tmp/m.res"
else
	ok 1 "the mixture ran ($(head -c 300 "$tmp/m.err"))"
fi
# 4. Fields of the mixture, mass-weighted: 16 replicas of the same mixture, 2 x 2 cells (about 100 particles
#    each), exposure 15 with 5 instants before t = 200, 400, 600. An elastic gas in equilibrium is isothermal,
#    so each cell's temperature, the replicas' occupation-weighted mean with its ratio-estimator standard error,
#    equals T = 1 (elastic: exact at all times). Replicas are independent (the cells of one run are not: heat
#    fluctuations over a cell 40 wide relax in about 50 time units), and the snapshots 200 apart too. z-scores
#    follow Student's t with 15 degrees of freedom (variance 15/13): chi^2 of the 12 values below 15/13 times
#    the 99.9% quantile of chi^2 with 12 degrees of freedom (32.91). The estimator about the cell's own
#    barycentric velocity is low by T/n for n particles per instant (1%, 0.4 se here). With one mass for all
#    particles the cells would read (300 + 100/4)/400 = 0.81.
cat >"$tmp/e.json" <<'EOF'
{"method": "ed", "dimensions": 2,
 "particles": {"species": [{"name": "light", "count": 300, "radius": 0.5, "mass": 1},
                           {"name": "heavy", "count": 100, "radius_range": [0.8, 1.2], "mass": 4}],
               "box": [80, 80]},
 "run": {"until": {"time": 600}, "seed": 9, "replicas": 16},
 "output": {"every": {"time": 20}, "observables": ["kinetic_energy", "fields"],
            "fields": {"cells": [2, 2], "exposure": 15, "samples": 5},
            "snapshots": {"every": {"time": 200}}}}
EOF
if "$ENGINE" run "$tmp/e.json" --out "$tmp/E" >"$tmp/e.out" 2>"$tmp/e.err"; then
	"$PY" - "$tmp/E" >"$tmp/e.res" 2>&1 <<'PY'
import json, sys
cur = [json.loads(l) for l in open(sys.argv[1] + '/observables.jsonl')]
chi, k, sums = 0.0, 0, []
for c in cur:
    if c['name'] != 'fields' or c['time'] < 200:
        continue
    t = {x['table']: x for x in c['tables']}
    sums.append(sum(t['density']['columns']['count']))
    for T, se in zip(t['temperature']['columns']['T'], t['temperature']['se']['T']):
        chi += ((T - 1) / se) ** 2
        k += 1
q = 15.0 / 13.0 * 32.91
print('%s - mixture fields (mass-weighted, 16 replicas): isothermal cells, chi^2 = %.1f for %d values against T = 1 '
      '(< %.1f); occupations add up to 400' %
      ('ok' if k == 12 and chi < q and all(abs(x - 400) < 1e-9 for x in sums) else 'not ok', chi, k, q))
PY
	report "$tmp/e.res"
else
	ok 1 "the mixture ensemble ran ($(head -c 300 "$tmp/e.err"))"
fi

echo "1..$n"
[ "$failed" = 0 ]
