#!/bin/sh
# Ensembles (run.replicas > 1) of bounded scenes through the real program (TAP): wall forces, centre-of-mass
# height, potential energy, flux, the rotational observables, the coarse-grained fields and the density
# spectrum as means over the replicas with standard errors; exact against the replicas' own frames, the force
# balance against the weight, isothermal fields, and the same numbers on any number of MPI ranks.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ensemble_bounded_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()

# An elastic gas of 200 disks under gravity g = 0.2 between a floor and a lid 40 diameters apart (periodic x),
# 4 replicas, progress and frames every 2 time units to t = 400. After the fall (potential energy into heat:
# T about 2.5, scale height about 12) the gas is stationary.
cat >"$tmp/g.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 200, "box": [40, 40]},
 "gravity": [0, -0.2],
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "run": {"until": {"time": 400}, "seed": 11, "replicas": 4},
 "output": {"every": {"time": 2},
            "observables": ["kinetic_energy", "wall_force", "center_of_mass_height", "potential_energy", "flux"],
            "snapshots": {"every": {"time": 2}}}}
EOF
if "$ENGINE" run "$tmp/g.json" --out "$tmp/G" >"$tmp/g.out" 2>"$tmp/g.err"; then
	# 1. The reduction, exactly: at each record the centre-of-mass height is the mean over the replicas of
	#    each replica's mean height (its frame at that time, /particles/replica_r), its _se the replicas'
	#    sample standard deviation / sqrt(4), and the potential energy N m |g| times the height (1e-9).
	# 2. Physics: in the stationary half (t > 200) the floor and the lid together carry the weight: the mean
	#    over the records of F_y(lower) + F_y(upper) = N m g_y = -40 within 4 standard errors over the
	#    records (each an interval mean over 2 time units, several collisions per particle: their measured
	#    lag-1 autocorrelation is printed and must be small, |rho| < 0.3, for the records to count as
	#    independent).
	"$PY" - "$tmp/G" >"$tmp/g.res" 2>&1 <<'PY'
import h5py, json, math, sys
out = sys.argv[1]
prog = [json.loads(l) for l in open(out + '/progress.jsonl')]
prog = [p for p in prog if p['type'] == 'progress']
f = h5py.File(out + '/trajectory.h5', 'r')
R, N = 4, 200
ys, times = [], None
for r in range(R):
    pos = f['/particles/replica_%d/position/value' % r][...]
    times = f['/particles/replica_%d/position/time' % r][...]
    ys.append(pos[:, :, 1].mean(axis=1))
worst, worst_se, worst_pot, matched = 0.0, 0.0, 0.0, 0
for p in prog:
    k = [i for i, t in enumerate(times) if abs(t - p['time']) < 1e-9]
    if not k:
        continue
    k = k[0]
    hs = [ys[r][k] for r in range(R)]
    m = sum(hs) / R
    se = math.sqrt(sum((h - m) ** 2 for h in hs) / (R - 1) / R)
    worst = max(worst, abs(p['center_of_mass_height'] - m) / m)
    worst_se = max(worst_se, abs(p['center_of_mass_height_se'] - se) / max(se, 1e-300))
    worst_pot = max(worst_pot, abs(p['potential_energy'] - N * 0.2 * p['center_of_mass_height']) / p['potential_energy'])
    matched += 1
print('%s - centre-of-mass height: the mean of the 4 replicas\' own heights at %d records (largest relative '
      'difference %.1e), its _se their spread (%.1e), potential energy N m g h (%.1e)' %
      ('ok' if matched >= 200 and worst < 1e-9 and worst_se < 1e-9 and worst_pot < 1e-9 else 'not ok', matched,
       worst, worst_se, worst_pot))
late = [p for p in prog if p['time'] > 200]
F = [p['wall_force'][0]['force'][1] + p['wall_force'][1]['force'][1] for p in late]
m = sum(F) / len(F)
var = sum((x - m) ** 2 for x in F) / (len(F) - 1)
se = math.sqrt(var / len(F))
rho = sum((F[i] - m) * (F[i + 1] - m) for i in range(len(F) - 1)) / ((len(F) - 1) * var)
print('%s - the walls carry the weight: F_y(lower) + F_y(upper) = %.3f +- %.3f over %d records, N m g_y = -40 '
      '(4 se; lag-1 autocorrelation %.2f)' % ('ok' if abs(m + 40) < 4 * se and abs(rho) < 0.3 else 'not ok', m, se,
                                               len(F), rho))
keys = all('pressure_se' in w and 'force_se' in w for p in prog for w in p['wall_force'])
print('%s - every record has wall pressure_se and force_se, potential_energy_se and flux_se' %
      ('ok' if keys and all('potential_energy_se' in p and 'flux_se' in p for p in prog) else 'not ok'))
obs = f['/observables']
need = ['center_of_mass_height_se', 'potential_energy_se', 'wall_pressure_se']
print('%s - H5MD has %s' % ('ok' if all(k in obs for k in need) else 'not ok', ', '.join(need)))
PY
	report "$tmp/g.res"
else
	ok 1 "the gravity ensemble ran ($(head -c 300 "$tmp/g.err"))"
fi

# 3. The same numbers on 2 and 3 ranks (each replica on its own stream wherever it runs; the reduction visits
#    replicas in order): the progress lines equal the serial run's but for wall_seconds.
strip() { sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//' "$1"; }
sed 's/"until": {"time": 400}/"until": {"time": 40}/' "$tmp/g.json" >"$tmp/s.json"
if command -v mpirun >/dev/null 2>&1; then
	"$ENGINE" run "$tmp/s.json" >"$tmp/e1" 2>/dev/null
	rc1=$?
	strip "$tmp/e1" >"$tmp/e1s"
	for np in 2 3; do
		mpirun -np $np "$ENGINE" run "$tmp/s.json" >"$tmp/e$np" 2>"$tmp/merr"
		rc=$?
		strip "$tmp/e$np" >"$tmp/e${np}s"
		cmp -s "$tmp/e1s" "$tmp/e${np}s"
		ok $(( rc1 == 0 && rc == 0 && $? == 0 ? 0 : 1 )) "gravity ensemble: mpirun -np $np gives the serial output (exit $rc)"
	done
fi

# 4. Rough particles: the rotational energy and temperature of an ensemble with their standard errors, and
#    E_rot = T_rot D_r N / 2 (D_r = 1 in 2D) in every record.
cat >"$tmp/r.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 100, "volume_fraction": 0.1},
 "collisions": {"restitution": 0.9, "rough": {"tangential_restitution": 0.5}},
 "run": {"until": {"time": 4}, "seed": 3, "replicas": 3},
 "output": {"every": {"time": 0.5}, "observables": ["kinetic_energy", "rotational_energy", "rotational_temperature"]}}
EOF
if "$ENGINE" run "$tmp/r.json" >"$tmp/r.out" 2>"$tmp/r.err"; then
	"$PY" - "$tmp/r.out" >"$tmp/r.res" 2>&1 <<'PY'
import json, sys
prog = [json.loads(l) for l in open(sys.argv[1])]
prog = [p for p in prog if p['type'] == 'progress']
good = all('rotational_energy_se' in p and 'rotational_temperature_se' in p and
           abs(p['rotational_energy'] - 0.5 * 100 * p['rotational_temperature']) <= 1e-9 * abs(p['rotational_energy'])
           for p in prog)
grow = prog[-1]['rotational_temperature'] > 0 and prog[-1]['rotational_temperature_se'] > 0
print('%s - rough ensemble: rotational energy and temperature with _se in %d records, E_rot = N T_rot / 2' %
      ('ok' if good and grow and len(prog) >= 8 else 'not ok', len(prog)))
PY
	report "$tmp/r.res"
else
	ok 1 "the rough ensemble ran ($(head -c 300 "$tmp/r.err"))"
fi

# 5. fields and density_spectrum over an ensemble: 16 replicas of 200 elastic disks under gravity g = 0.1 in
#    80 x 40 (walls along y), fields on 1 x 10 cells, exposure 100 with 50 instants before each snapshot
#    (t = 200, 300, 400: the gas has settled, T about 1.6). An elastic gas in equilibrium under gravity is
#    isothermal (exactly, at any density), so every cell's temperature equals the progress temperature at
#    that time. The cell's value is the replicas' occupation-weighted mean with the ratio estimator's standard
#    error over 16 replicas (observe.c wstat()), whose z-scores follow Student's t with 15 degrees of freedom
#    (variance 15/13): chi^2 of the 30 cells against the progress temperature must stay below 15/13 times the
#    99.9% quantile of chi^2 with 30 degrees of freedom (59.70). (The cell temperature about the cell's own
#    mean velocity is low by a factor 1 - 1/V for V visits, V ~ 300 here: 0.3%, below a tenth of the se.)
#    The mean occupations add up to N = 200 (each replica's do, exactly); the spectrum's slope comes with
#    its standard error over the replicas.
cat >"$tmp/f.json" <<'EOF'
{"method": "ed", "dimensions": 2, "particles": {"count": 200, "box": [80, 40]},
 "gravity": [0, -0.1],
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "run": {"until": {"time": 400}, "seed": 5, "replicas": 16},
 "output": {"every": {"time": 10}, "observables": ["kinetic_energy", "fields", "density_spectrum"],
            "fields": {"cells": [1, 10], "exposure": 100, "samples": 50},
            "density_spectrum": {"interval": 1, "slices": 10},
            "snapshots": {"every": {"time": 100}}}}
EOF
if "$ENGINE" run "$tmp/f.json" --out "$tmp/F" >"$tmp/f.out" 2>"$tmp/f.err"; then
	"$PY" - "$tmp/F" >"$tmp/f.res" 2>&1 <<'PY'
import h5py, json, math, sys
out = sys.argv[1]
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
prog = {p['time']: p for p in map(json.loads, open(out + '/progress.jsonl')) if p['type'] == 'progress'}
chi, k, sums, worst = 0.0, 0, [], (0, 0, 0, 0)
for c in cur:
    if c['name'] != 'fields' or c['time'] < 200:
        continue
    t = {x['table']: x for x in c['tables']}
    T0 = prog[c['time']]['temperature']
    sums.append(sum(t['density']['columns']['count']))
    for j, (T, se) in enumerate(zip(t['temperature']['columns']['T'], t['temperature']['se']['T'])):
        z = (T - T0) / se
        chi += z * z
        k += 1
        if abs(z) > abs(worst[3]):
            worst = (c['time'], j, T, z)
q = 15.0 / 13.0 * 59.70
print('%s - ensemble fields: the cells\' temperatures equal the progress temperature (isothermal): chi^2 = %.1f '
      'for %d cells (< %.1f), largest |z| %.2f (t = %g, cell %d, T = %.4f)' %
      ('ok' if k == 30 and chi < q else 'not ok', chi, k, q, abs(worst[3]), worst[0], worst[1], worst[2]))
print('%s - ensemble fields: mean occupations add up to N = 200 (%s)' %
      ('ok' if sums and all(abs(s - 200) < 1e-9 for s in sums) else 'not ok', ', '.join('%.12g' % s for s in sums)))
ds = [c for c in cur if c['name'] == 'density_spectrum' and c['sample'] > 0]
good = ds and all(c.get('replicas') == 16 and c['alpha'] is not None and c['alpha_se'] is not None and
                  c['alpha_se'] > 0 for c in ds)
f = h5py.File(out + '/trajectory.h5', 'r')
have = 'fields_temperature' in f['observables'] and 'density_spectrum_alpha' in f['observables']
print('%s - ensemble density_spectrum: slope and its standard error over the replicas at %d snapshots; H5MD has '
      'the fields and the spectrum' % ('ok' if good and have else 'not ok', len(ds)))
PY
	report "$tmp/f.res"
else
	ok 1 "the fields ensemble ran ($(head -c 300 "$tmp/f.err"))"
fi

echo "1..$n"
[ "$failed" = 0 ]
