#!/bin/sh
# Mean-square displacement and pressure over a varying particle set (issue 17; TAP): open and reservoir walls,
# where the MSD is over the particles present at the origin and still present (docs/output.md), against free
# flight and against Enskog's self-diffusion, and the pressure (kinetic + collisional virial of the particles
# present) against Carnahan-Starling; resumed runs continue the MSD exactly.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/msdopen_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()

# ---- free flight between two open walls -----------------------------------------------------------------------
# 3D, N = 2000 in a box 100 x 1000 x 1000 (volume fraction 1e-5: 0.012 collisions per particle by t = 80, too
# few to show), open walls on x. Centres start uniform over the W = 99 between the contact planes with
# Maxwellian velocities at T = 1, and fly straight: a particle is still there at t when |v_x| t < the distance
# to the wall it flies to, so the fraction present is f(t) = E[(1 - |v_x| t / W)+] (v_x ~ N(0, T)), and the
# members' displacement is v t exactly: along x E[v_x^2 t^2 (1 - |v_x| t/W)+] / f (survival selects slow v_x),
# across (y, z: independent of v_x) 2 T t^2 unchanged by the selection. Checked at t = 10 ... 80: msd_count
# within 4 binomial se of N f; the transverse MSD (msd - msd_walled) within 4 se of 2 T t^2, se = 2 T t^2 /
# sqrt(count) (v_y^2 + v_z^2 is exponential: sd = mean); msd_walled within 4 se of its value, se from the
# members' fourth moment. ed follows the periodic images exactly; dsmc by the speed bound of the particles
# present (leaving removes energy: the bound holds).
cat >"$tmp/ff.py" <<'PY'
import json, math, sys
out, label = sys.argv[1], sys.argv[2]
p = [json.loads(l) for l in open(out) if '"progress"' in l]
N, W, T = 2000, 99.0, p[0]['temperature']
M = 20000
def E(fn, t):   # E[fn(v) (1 - |v| t / W)+] over v ~ N(0, T), midpoint rule over |v| < W / t
    a = W / t; h = a / M; s = 0.0
    for i in range(M):
        v = (i + 0.5) * h
        s += fn(v) * (1 - v / a) * math.exp(-v * v / (2 * T))
    return 2 * s * h / math.sqrt(2 * math.pi * T)
bad = []
for x in p[1:]:
    t = x['time']; c = x['msd_count']
    f = E(lambda v: 1.0, t)
    if abs(c - N * f) > 4 * math.sqrt(N * f * (1 - f)):
        bad.append('t=%g count %d vs %.1f' % (t, c, N * f))
    tr = x['msd'] - x['msd_walled']
    if abs(tr - 2 * T * t * t) > 4 * 2 * T * t * t / math.sqrt(c):
        bad.append('t=%g transverse %.2f vs %.2f' % (t, tr, 2 * T * t * t))
    m2 = E(lambda v: v * v, t) / f * t * t; m4 = E(lambda v: v ** 4, t) / f * t ** 4
    if abs(x['msd_walled'] - m2) > 4 * math.sqrt((m4 - m2 * m2) / c):
        bad.append('t=%g along x %.2f vs %.2f' % (t, x['msd_walled'], m2))
last = p[-1]
print('%s - %s: free flight between open walls, t = 10 ... %g: members %d (theory %.1f), transverse MSD %.1f '
      '(2 T t^2 = %.1f), along x %.1f (theory %.1f) within 4 se%s' % ('not ok' if bad else 'ok', label, last['time'],
      last['msd_count'], N * E(lambda v: 1.0, last['time']), last['msd'] - last['msd_walled'],
      2 * T * last['time'] ** 2, last['msd_walled'],
      E(lambda v: v * v, last['time']) / E(lambda v: 1.0, last['time']) * last['time'] ** 2,
      ('; ' + ', '.join(bad)) if bad else ''))
PY
for m in ed dsmc; do
	cat >"$tmp/ff$m.json" <<JSON
{"method":"$m","dimensions":3,"particles":{"count":2000,"box":[100,1000,1000],
   "initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"open"},"upper":{"type":"open"}}},
 $([ $m = dsmc ] && echo '"dsmc":{"time_step":0.25},')
 "run":{"seed":7,"until":{"time":80}},
 "output":{"every":{"time":10},"observables":["temperature","mean_square_displacement","outflow"]}}
JSON
	if "$ENGINE" run "$tmp/ff$m.json" >"$tmp/ff$m.out" 2>"$tmp/ff$m.err"; then
		"$PY" "$tmp/ff.py" "$tmp/ff$m.out" "$m" >"$tmp/ff.res" 2>&1 || echo "not ok - $m free-flight check: $(tail -1 "$tmp/ff.res")" >>"$tmp/ff.res"
		report "$tmp/ff.res"
	else
		ok 1 "$m free-flight run: $(head -c 300 "$tmp/ff$m.err")"
	fi
done

# ---- self-diffusion in a slab between two reservoirs ------------------------------------------------------------
# 3D elastic hard spheres, N = 2000 in 400 x 16 x 16 (volume fraction 0.0102) between reservoir walls on x
# holding the gas at volume fraction 0.01 and T = 1 (an equilibrium slab: particles come and go, ~33% of the
# first ones leave by t = 400). D over each output interval of 20 (~3 collision times) from the members' growth
# along y and z (the key diffusion), t >= 40; the run's D / D_E is sum D / sum D_E(n, T) over those intervals,
# D_E = 3 / (8 n sigma^2 chi) sqrt(T / (pi m)) (Enskog, chi Carnahan-Starling) with n and T of the particles
# present (the mean of the interval's ends: the reservoirs hold them within a few per cent of the targets).
# 6 seeds: mean and standard error; the band of tests/transport_test.sh, 0.98 D_E to 1.02 D_Speedy, with 4 se
# (Student t, 5 dof: p ~ 0.01). (Measured 1.027 +- 0.012; the survivors are no biased sample along y, z.)
for s in 1 2 3 4 5 6; do
	cat >"$tmp/rs$s.json" <<JSON
{"method":"ed","dimensions":3,"particles":{"count":2000,"box":[400,16,16],"capacity":4000,
   "initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.01,"temperature":1},
                                   "upper":{"type":"reservoir","volume_fraction":0.01,"temperature":1}}},
 "run":{"seed":$((40 + s)),"until":{"time":400}},
 "output":{"every":{"time":20},"observables":["temperature","mean_square_displacement","outflow"]}}
JSON
	"$ENGINE" run "$tmp/rs$s.json" >"$tmp/rs$s.out" 2>"$tmp/rs$s.err" || echo "run $s failed: $(head -c 200 "$tmp/rs$s.err")" >>"$tmp/rs.err"
done
"$PY" - "$tmp" <<'PY' >"$tmp/rs.res" 2>&1 || echo "not ok - reservoir diffusion check: $(tail -1 "$tmp/rs.res")" >>"$tmp/rs.res"
import json, math, sys
V = 400 * 16 * 16
def DE(n, T):
    nu = n * math.pi / 6; chi = (1 - nu / 2) / (1 - nu) ** 3
    return 3 / (8 * n * chi) * math.sqrt(T / math.pi)
R = []
for s in range(1, 7):
    p = [json.loads(l) for l in open('%s/rs%d.out' % (sys.argv[1], s)) if '"progress"' in l]
    d = e = 0.0
    for a, b in zip(p, p[1:]):
        if b['time'] < 40 - 1e-9:
            continue
        d += b['diffusion']
        e += DE((a['particles_present'] + b['particles_present']) / 2 / V, (a['temperature'] + b['temperature']) / 2)
    R.append(d / e)
m = sum(R) / len(R); se = math.sqrt(sum((r - m) ** 2 for r in R) / (len(R) - 1) / len(R))
ns = 6 * 0.01 / math.pi; chi = (1 - 0.005) / 0.99 ** 3
sp = (1 - ns / 1.09) * (1 + ns * ns * (0.40 - 0.83 * ns * ns)) * chi   # D_Speedy / D_E
print('%s - 3D slab between reservoirs (volume fraction 0.01): D/D_Enskog over the members = %.3f +- %.3f over 6 '
      'runs (band %.3f ... %.3f, members left at t = 400: %d of 2000)' % ('ok' if 0.98 - 4 * se < m < 1.02 * sp + 4 * se
      else 'not ok', m, se, 0.98, 1.02 * sp, p[-1]['msd_count']))
PY
[ -f "$tmp/rs.err" ] && cat "$tmp/rs.err" >>"$tmp/rs.res"
report "$tmp/rs.res"

# ---- dsmc with an energy feed: image counts --------------------------------------------------------------------
# Moving walls make the speed bound unavailable (they can feed energy), so dsmc counts the periodic images each
# particle crosses (dsmc_unwrapped(); exact against hand-unwrapped positions in tests/mc_walls_test.c). Here the
# two walls on x move along y and z at 0.5 with tangential_restitution -1 (v_t' - u = v_t - u: the tangential
# velocity is kept, the normal one reversed), so the gas stays in equilibrium at T = 1 and Enskog applies:
# 3D, N = 2000 in 100 x 32 x 32 (volume fraction 0.0102), D along y and z from the MSD's growth over
# t = 40 ... 300 of each of 6 seeds, against D_E(n, T) with the same band and 4 se as above. (Thermal walls
# would lower it: a thermal wall forgets the tangential velocity, and the Knudsen layers within a mean free path,
# ~12 diameters, of each wall diffuse less: measured 0.977 +- 0.012 of D_E in the same box.)
for s in 1 2 3 4 5 6; do
	cat >"$tmp/mv$s.json" <<JSON
{"method":"dsmc","dimensions":3,"particles":{"count":2000,"box":[100,32,32],
   "initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"moving","velocity":[0,0.5,0],"tangential_restitution":-1},
                                   "upper":{"type":"moving","velocity":[0,0,-0.5],"tangential_restitution":-1}}},
 "run":{"seed":$((60 + s)),"until":{"time":300}},
 "output":{"every":{"time":20},"observables":["temperature","mean_square_displacement"]}}
JSON
	"$ENGINE" run "$tmp/mv$s.json" >"$tmp/mv$s.out" 2>"$tmp/mv$s.err" || echo "run $s failed: $(head -c 200 "$tmp/mv$s.err")" >>"$tmp/mv.err"
done
"$PY" - "$tmp" <<'PY' >"$tmp/mv.res" 2>&1 || echo "not ok - moving-wall diffusion check: $(tail -1 "$tmp/mv.res")" >>"$tmp/mv.res"
import json, math, sys
V = 100 * 32 * 32
def DE(n, T):
    nu = n * math.pi / 6; chi = (1 - nu / 2) / (1 - nu) ** 3
    return 3 / (8 * n * chi) * math.sqrt(T / math.pi)
R = []
for s in range(1, 7):
    p = [json.loads(l) for l in open('%s/mv%d.out' % (sys.argv[1], s)) if '"progress"' in l]
    a = [x for x in p if x['time'] >= 40 - 1e-9]
    D = ((a[-1]['msd'] - a[-1]['msd_walled']) - (a[0]['msd'] - a[0]['msd_walled'])) / (4 * (a[-1]['time'] - a[0]['time']))
    R.append(D / DE(2000 / V, sum(x['temperature'] for x in a) / len(a)))
m = sum(R) / len(R); se = math.sqrt(sum((r - m) ** 2 for r in R) / (len(R) - 1) / len(R))
nu = 2000 / V * math.pi / 6; ns = 6 * nu / math.pi; chi = (1 - nu / 2) / (1 - nu) ** 3
sp = (1 - ns / 1.09) * (1 + ns * ns * (0.40 - 0.83 * ns * ns)) * chi
print('%s - dsmc 3D between moving walls (image counts): D/D_Enskog along y, z = %.3f +- %.3f over 6 runs '
      '(band %.3f ... %.3f)' % ('ok' if 0.98 - 4 * se < m < 1.02 * sp + 4 * se else 'not ok', m, se, 0.98, 1.02 * sp))
PY
[ -f "$tmp/mv.err" ] && cat "$tmp/mv.err" >>"$tmp/mv.res"
report "$tmp/mv.res"

# ---- pressure between reservoirs --------------------------------------------------------------------------------
# With particles coming and going the pressure is P = (2 int E_kin dt + sum_coll r_ij . J_ij) / (D V tau) over the
# particles present (kinetic + collisional virial, no fixed N) and Z = 1 + virial / (2 int E_kin dt). 3D elastic
# spheres, 2000 in 80 x 16 x 16 between reservoirs at volume fraction 0.05 and T = 1 (the box settles near 0.04),
# 6 seeds, intervals of 10 for t >= 50: per run the mean over intervals of (Z - 1) / (Z_CS - 1) and of
# P / (n T Z_CS), Z_CS = 1 + 4 nu (1 - nu/2) / (1 - nu)^3 (Carnahan-Starling) at the interval's mean density
# n = N_present / V and temperature; their means over the seeds within 4 se of 1 (Student t, 5 dof).
# (Measured 1.003 +- 0.002 and 1.000 +- 0.001.)
for s in 1 2 3 4 5 6; do
	cat >"$tmp/pr$s.json" <<JSON
{"method":"ed","dimensions":3,"particles":{"count":2000,"box":[80,16,16],"capacity":4000,
   "initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.05,"temperature":1},
                                   "upper":{"type":"reservoir","volume_fraction":0.05,"temperature":1}}},
 "run":{"seed":$((70 + s)),"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["temperature","pressure","outflow"]}}
JSON
	"$ENGINE" run "$tmp/pr$s.json" >"$tmp/pr$s.out" 2>"$tmp/pr$s.err" || echo "run $s failed: $(head -c 200 "$tmp/pr$s.err")" >>"$tmp/pr.err"
done
"$PY" - "$tmp" <<'PY' >"$tmp/pr.res" 2>&1 || echo "not ok - pressure check: $(tail -1 "$tmp/pr.res")" >>"$tmp/pr.res"
import json, math, sys
V = 80 * 16 * 16
R, Q = [], []
for s in range(1, 7):
    p = [json.loads(l) for l in open('%s/pr%d.out' % (sys.argv[1], s)) if '"progress"' in l]
    zr, pr = [], []
    for a, b in zip(p, p[1:]):
        if b['time'] < 50 - 1e-9:
            continue
        n = (a['particles_present'] + b['particles_present']) / 2 / V; nu = n * math.pi / 6
        T = (a['temperature'] + b['temperature']) / 2
        Z = 1 + 4 * nu * (1 - nu / 2) / (1 - nu) ** 3
        zr.append((b['compressibility'] - 1) / (Z - 1)); pr.append(b['pressure'] / (n * T * Z))
    R.append(sum(zr) / len(zr)); Q.append(sum(pr) / len(pr))
def ms(X):
    m = sum(X) / len(X); return m, math.sqrt(sum((x - m) ** 2 for x in X) / (len(X) - 1) / len(X))
(mz, sz), (mp, sp) = ms(R), ms(Q)
print('%s - pressure between reservoirs (3D, volume fraction ~0.04): (Z - 1)/(Z_CS - 1) = %.4f +- %.4f over 6 runs, '
      'within 4 se of 1' % ('ok' if abs(mz - 1) < 4 * sz else 'not ok', mz, sz))
print('%s - pressure between reservoirs: P / (n T Z_CS) = %.4f +- %.4f over 6 runs, within 4 se of 1'
      % ('ok' if abs(mp - 1) < 4 * sp else 'not ok', mp, sp))
PY
[ -f "$tmp/pr.err" ] && cat "$tmp/pr.err" >>"$tmp/pr.res"
report "$tmp/pr.res"

# ---- resume ---------------------------------------------------------------------------------------------------------
# The members, their origins, labels and last squared displacements are checkpointed: a run resumed from its
# checkpoint (time 40 of 80) writes the same msd, msd_count and diffusion as the uninterrupted run. ed with
# reservoir walls (slots refilled: labels), dsmc with open walls (speed bound), hsmc with a source, periodic in z
# (image counts; inserted particles are no members: the count stays 300 while 200 enter).
for m in ed dsmc hsmc; do
	case $m in
	ed) cat >"$tmp/ck$m.json" <<JSON
{"method":"ed","dimensions":2,"particles":{"count":400,"box":[60,40],"capacity":800,
   "initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.05,"temperature":1},"upper":{"type":"open"}}},
JSON
	;;
	dsmc) cat >"$tmp/ck$m.json" <<JSON
{"method":"dsmc","dimensions":2,"particles":{"count":400,"box":[60,40],"initial":{"positions":"random","temperature":1}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"open"},"upper":{"type":"open"}}},
JSON
	;;
	hsmc) cat >"$tmp/ck$m.json" <<JSON
{"method":"hsmc","dimensions":3,"particles":{"count":300,"box":[30,20,10],"initial":{"positions":"random","temperature":1},
   "source":{"count":200,"rate":4,"position":[15,5],"spread":3,"height":2,"velocity":[0,-1,0],"temperature":0.5}},
 "gravity":[0,-1,0],"collisions":{"restitution":0.9},
 "boundaries":{"x":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}},
               "y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
JSON
	;;
	esac
	cat >>"$tmp/ck$m.json" <<JSON
 "run":{"seed":9,"until":{"time":80}},
 "output":{"every":{"time":5},"observables":["temperature","mean_square_displacement","outflow"],
   "checkpoint":{"every":{"time":40}}}}
JSON
	"$ENGINE" run "$tmp/ck$m.json" --out "$tmp/full$m" >/dev/null 2>"$tmp/ck.err"
	rc1=$?
	mkdir -p "$tmp/part$m"
	cp -r "$tmp/full$m/." "$tmp/part$m/"
	"$ENGINE" run "$tmp/ck$m.json" --out "$tmp/part$m" --resume "$tmp/part$m/checkpoint.h5" >/dev/null 2>>"$tmp/ck.err"
	rc=$?
	"$PY" - "$tmp/full$m" "$tmp/part$m" <<'PY' >"$tmp/ck.res" 2>&1
import json, sys
def rows(o):
    return [(p['time'], p['msd'], p['msd_count'], p.get('diffusion')) for p in map(json.loads, open(o + '/progress.jsonl'))
            if p.get('type') == 'progress']
a, b = rows(sys.argv[1]), rows(sys.argv[2])
assert a == b and len(a) == 17, (len(a), len(b))
assert a[-1][2] < a[0][2] or 'hsmc' in sys.argv[1], 'no member left'
# the H5MD series mean_square_displacement_count (and _walled with walls) hold the progress stream's values,
# row for row, in the uninterrupted and in the resumed file
import h5py
for d in sys.argv[1:]:
    pr = [p for p in map(json.loads, open(d + '/progress.jsonl')) if p.get('type') == 'progress']
    with h5py.File(d + '/trajectory.h5', 'r') as f:
        o = f['observables']
        for name, key in (('mean_square_displacement_count', 'msd_count'), ('mean_square_displacement_walled', 'msd_walled')):
            v = [float(x) for x in o[name + '/value'][:]]
            t = [float(x) for x in o[name + '/time'][:]] if 'time' in o[name] else [float(x) for x in o['collision_count/time'][:]]
            want = [(p['time'], float(p[key])) for p in pr]
            assert len(v) == len(want), (d, name, len(v), len(want))
            for (tt, w), x, ht in zip(want, v, t):
                assert x == w and abs(ht - tt) <= 1e-12 * max(1.0, tt), (d, name, tt, w, ht, x)
print('%d records, members %d -> %d' % (len(a), a[0][2], a[-1][2]))
PY
	ok $(( rc1 != 0 || rc != 0 || $? != 0 )) "$m resumed run with a varying particle set: msd, msd_count and diffusion equal the uninterrupted run's, and the H5MD series mean_square_displacement_count and _walled equal the stream's (rc $rc1 $rc; $(tail -1 "$tmp/ck.res") $(head -c 200 "$tmp/ck.err"))"
done

echo "1..$n"
[ "$failed" = 0 ]
