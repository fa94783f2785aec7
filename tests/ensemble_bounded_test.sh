#!/bin/sh
# Ensembles (run.replicas > 1) of bounded scenes through the real program (TAP): wall forces, centre-of-mass
# height, potential energy, flux and the rotational observables as means over the replicas with standard
# errors; exact against the replicas' own frames, the force balance against the weight, and the same numbers
# on any number of MPI ranks.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ensemble_bounded_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
report() {
	while IFS= read -r line; do
		case "$line" in
		"ok - "*) ok 0 "${line#ok - }" ;;
		"not ok - "*) ok 1 "${line#not ok - }" ;;
		*) echo "# $line" ;;
		esac
	done <"$1"
}

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

echo "1..$n"
[ "$failed" = 0 ]
