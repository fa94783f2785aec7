#!/bin/sh
# Structure observables where particles come and go or obstacles take room (issue 17 with issue 12's open
# and reservoir walls and obstacles; TAP): the velocity distribution, g(r), clusters and S(k) over the
# particles present, and g(r) normalised by the region the centres can reach, against theory.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/obsopen_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
run() {
	if ! "$ENGINE" run "$tmp/$1.json" --out "$tmp/$1" >"$tmp/$1.out" 2>"$tmp/$1.err"; then
		echo "not ok - $1: the run failed: $(head -c 300 "$tmp/$1.err")" >"$tmp/$1.res"
		return 1
	fi
}

# g(r) = 1 over [2, 10) diameters for a dilute elastic gas: above 2 diameters hard disks at area fraction
# 0.01 have g = 1 up to O(nu^2) ~ 1e-4. Per bin the mean over the snapshots (each 2 mean free times apart:
# the pairs within 10 diameters are new ones, independent samples) and its standard error; chi^2 of the 16
# bins against 1 below the 99.9% quantile of chi^2 with 16 degrees of freedom (Wilson-Hilferty, 39.25).

# ---- 1. equilibrium with reservoirs at both ends: the particles present ----------------------------------
# 2D, x walled 100 diameters wide with the same reservoir (area fraction 0.01, T = 1, at rest) at both ends,
# periodic y of 300: the box holds the reservoir's equilibrium gas (grand canonical: an ideal-gas reservoir
# and a dilute hard-disk gas agree to O(nu)), about 382 disks that come and go (capacity slots, NaN rows for
# the empty ones, which the observables must skip). The mean free time is about 22 at T = 1; 41 snapshots
# every 90 (4 mean free times: a particle's velocity at one snapshot is nearly forgotten at the next). Checks: g(r) = 1 as above (x walled: the edge-corrected normalisation, with the count present at
# each snapshot); the curves' temperature and a2 (the particles present are Maxwellian at T = 1: a2 = 0),
# per snapshot, mean within 4 standard errors over the snapshots; the clusters family at every snapshot.
cat >"$tmp/res.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 382, "box": [100, 300]},
 "boundaries": {"x": {"type": "walls",
                      "lower": {"type": "reservoir", "volume_fraction": 0.01, "temperature": 1},
                      "upper": {"type": "reservoir", "volume_fraction": 0.01, "temperature": 1}}},
 "run": {"until": {"time": 3690}, "seed": 17},
 "output": {"observables": ["kinetic_energy", "velocity_distribution", "pair_correlation", "clusters",
                            "structure_factor", "flux"],
            "pair_correlation": {"range": 10, "bins": 20},
            "snapshots": {"every": {"time": 90}}}}
EOF
if run res; then
	"$PY" "$SRCDIR/tests/check_g1.py" "$tmp/res" "reservoirs at both ends" >"$tmp/res.res" 2>&1
	"$PY" - "$tmp/res" >>"$tmp/res.res" 2>&1 <<'PY'
import json, math, sys
out = sys.argv[1]
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
vd = [c for c in cur if c['name'] == 'velocity_distribution' and c['sample'] > 0]
def ms(v):
    m = sum(v) / len(v)
    return m, math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1) / len(v))
t, st = ms([c['temperature'] for c in vd])
a2, sa = ms([c['a2'] for c in vd])
print('%s - reservoirs: temperature of the particles present %.4f +- %.4f (T = 1, 4 se)' %
      ('ok' if abs(t - 1) < 4 * st else 'not ok', t, st))
print('%s - reservoirs: a2 of the particles present %.4f +- %.4f (Maxwellian: 0, 4 se)' %
      ('ok' if abs(a2) < 4 * sa else 'not ok', a2, sa))
cl = [c for c in cur if c['name'] == 'clusters']
sk = [c for c in cur if c['name'] == 'structure_factor']
fin = all(math.isfinite(x) for c in sk for x in c['tables'][0]['columns']['s'] if x is not None)
print('%s - reservoirs: clusters and S(k) at every snapshot (%d, %d), S(k) finite' %
      ('ok' if len(cl) == len(vd) + 1 and len(sk) == len(vd) + 1 and fin else 'not ok', len(cl), len(sk)))
prog = [json.loads(l) for l in open(out + '/progress.jsonl')]
prog = [p for p in prog if p.get('type') == 'progress']
fl = [p['flux'] for p in prog]
print('%s - reservoirs: flux finite in every progress record (%d)' %
      ('ok' if fl and all(x is not None and math.isfinite(x) for x in fl) else 'not ok', len(fl)))
PY
fi
report "$tmp/res.res"

# ---- 2. an obstacle: g(r) in the region the centres reach ---------------------------------------------------
# 2D periodic 200 x 200 diameters, a slip disk of radius 40 (its contact circle, radius 40.5, takes 13% of
# the box), 509 elastic disks: the gas around it is uniform (equilibrium), so g(r) = 1 when the ideal pairs
# count only the reachable region; the box's plain normalisation would put g near 1.15. 40 snapshots two
# mean free times apart as above. Also the clusters and mean_square_displacement families run with it.
cat >"$tmp/obst.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 509, "box": [200, 200]},
 "obstacles": [{"type": "slip", "center": [120, 80], "radius": 40}],
 "run": {"until": {"time": 1845}, "seed": 23},
 "output": {"observables": ["kinetic_energy", "pair_correlation", "clusters", "mean_square_displacement"],
            "pair_correlation": {"range": 10, "bins": 20},
            "snapshots": {"every": {"time": 45}}}}
EOF
if run obst; then
	"$PY" "$SRCDIR/tests/check_g1.py" "$tmp/obst" "slip obstacle" >"$tmp/obst.res" 2>&1
	"$PY" - "$tmp/obst" >>"$tmp/obst.res" 2>&1 <<'PY'
import json, math, sys
prog = [json.loads(l) for l in open(sys.argv[1] + '/progress.jsonl')]
prog = [p for p in prog if p.get('type') == 'progress']
m = [p['msd'] for p in prog[1:]]
print('%s - slip obstacle: msd finite and growing (%.1f .. %.1f over %d records)' %
      ('ok' if m and all(x is not None and math.isfinite(x) for x in m) and m[-1] > m[0] else 'not ok',
       m[0] if m else 0, m[-1] if m else 0, len(m)))
PY
fi
report "$tmp/obst.res"

# ---- 3. rough particles through reservoirs -------------------------------------------------------------
# The equilibrium box of 1. with perfectly rough elastic disks (tangential_restitution 1: translation and
# rotation exchange energy, their sum conserved): particles enter with Maxwellian spins at the reservoir's
# temperature, so the particles present have T_rot = T = 1 (equipartition), the mean over the 41 records
# 90 apart within 4 standard errors. (Entering without spin they would gain rotation only in their few
# collisions before leaving: T_rot far below 1.)
cat >"$tmp/rough.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 382, "box": [100, 300]},
 "collisions": {"rough": {"tangential_restitution": 1}},
 "boundaries": {"x": {"type": "walls",
                      "lower": {"type": "reservoir", "volume_fraction": 0.01, "temperature": 1},
                      "upper": {"type": "reservoir", "volume_fraction": 0.01, "temperature": 1}}},
 "run": {"until": {"time": 3690}, "seed": 17},
 "output": {"every": {"time": 90}, "observables": ["kinetic_energy", "temperature", "rotational_energy",
                                                   "rotational_temperature", "outflow"]}}
EOF
if run rough; then
	"$PY" - "$tmp/rough.out" >"$tmp/rough.res" 2>&1 <<'PY'
import json, math, sys
P = [json.loads(l) for l in open(sys.argv[1])]
P = [p for p in P if p['type'] == 'progress' and p['time'] >= 90]
def ms(v):
    m = sum(v) / len(v)
    return m, math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1) / len(v))
t, st = ms([p['temperature'] for p in P])
r, sr = ms([p['rotational_temperature'] for p in P])
print('%s - rough disks through reservoirs: T = %.4f +- %.4f, T_rot = %.4f +- %.4f over %d records (both 1, 4 se)' %
      ('ok' if len(P) >= 40 and abs(t - 1) < 4 * st and abs(r - 1) < 4 * sr else 'not ok', t, st, r, sr, len(P)))
PY
fi
report "$tmp/rough.res"

echo "1..$n"
[ "$failed" = 0 ]
