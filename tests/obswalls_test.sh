#!/bin/sh
# Structure observables in bounded scenes (issue 17 with issue 12's walls and gravity; TAP): g(r) with the
# edge-corrected ideal-gas normalisation, clusters, S(k), velocity correlations and the mean-square
# displacement with walls and gravity, for ed, dsmc and hsmc, against the values theory gives.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/obswalls_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
run() {   # run NAME: engine on $tmp/NAME.json into $tmp/NAME, stdout to $tmp/NAME.out; 0 or an error line
	if ! "$ENGINE" run "$tmp/$1.json" --out "$tmp/$1" >"$tmp/$1.out" 2>"$tmp/$1.err"; then
		echo "not ok - $1: the run failed: $(head -c 300 "$tmp/$1.err")" >"$tmp/$1.res"
		return 1
	fi
}

# ---- a dilute elastic gas between walls: g(r) = 1, S(k), velocity correlations ---------------------------
# 2D, walls along y 20 diameters apart (centres fill 19), periodic x of 3000, area fraction 0.01 (N = 764),
# range 10 diameters: the shell's part inside the walls is down to 1 - 2r/(pi 19) = 0.67 at r = 10, so an
# uncorrected g would fall to 0.67 there. Above 2 diameters hard disks at this density have g = 1 up to
# O(nu^2) ~ 1e-4 (the first density correction vanishes beyond 2 sigma); dsmc/hsmc points have g = 1
# everywhere. 40 snapshots 2 collisions per particle apart: the mean free path is ~28 diameters, so each
# snapshot's pairs within 10 diameters are new ones (independent samples). Per bin the mean over snapshots
# and its standard error; chi^2 of the 16 bins over [2, 10) against 1 must stay below 39.25, the 99.9%
# quantile of chi^2 with 16 degrees of freedom. The same in 3D (hsmc, walls along z 12 diameters apart,
# range 6: 8 bins over [2, 6)).
# S(k) (wave vectors along the periodic axes, fgrid.h): per snapshot the mean over all shells, then its mean
# and standard error over the 40 snapshots, within 4 se of theory: 1 for the points of dsmc/hsmc, and for
# hard disks the first order in density, S(k) = 1 + n h(k) with h = -1 inside sigma:
# 1 - 8 nu J1(k sigma)/(k sigma) (2D), about 0.962 here, 5 se below 1 (the excluded volume is seen). The
# velocity correlations of an elastic gas in equilibrium vanish: S_par = S_perp = 1 and G_par = G_perp = 0
# (pair-weighted over r in [1, 10)), each within 4 se over the snapshots.
cat >"$tmp/check_cl.py" <<'PY'
import json, sys
out, what = sys.argv[1], sys.argv[2]
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
S = len([c for c in cur if c['name'] == 'pair_correlation' and c['sample'] > 0])
# the clusters family ran with walls too
cl = [c for c in cur if c['name'] == 'clusters']
print('%s - %s: clusters with walls at every snapshot (%d)' % ('ok' if len(cl) == S + 1 else 'not ok', what,
      len(cl)))
PY
cat >"$tmp/check_sk.py" <<'PY'
import json, math, sys
out, what, nu = sys.argv[1], sys.argv[2], float(sys.argv[3])
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
def tab(name, sub):
    return [t for c in cur if c['name'] == name and c['sample'] > 0 for t in c['tables'] if t['table'] == sub]
def J1(x, M=200):   # Bessel J1 = (1/pi) int_0^pi cos(t - x sin t) dt, midpoint rule
    return sum(math.cos((i + 0.5) * math.pi / M - x * math.sin((i + 0.5) * math.pi / M)) for i in range(M)) / M
def stats(v):
    S = len(v); m = sum(v) / S
    return m, math.sqrt(sum((x - m) ** 2 for x in v) / (S - 1) / S)
sk = tab('structure_factor', '')
k = sk[0]['centres']
th = sum(1 - 8 * nu * J1(x) / x if nu > 0 else 1.0 for x in k) / len(k)
m, se = stats([sum(t['columns']['s']) / len(k) for t in sk])
print('%s - %s: S(k) between walls averaged over %d shells (k sigma up to %.2f): %.4f +- %.4f vs %.4f (%s) '
      'within 4 se' % ('ok' if abs(m - th) < 4 * se else 'not ok', what, len(k), k[-1], m, se, th,
      '1 - 8 nu J1(k sigma)/(k sigma)' if nu > 0 else 'ideal gas'))
vm = tab('velocity_correlations', 'modes')
for col in ('s_par', 's_perp'):
    m, se = stats([sum(t['columns'][col]) / len(k) for t in vm])
    print('%s - %s: %s between walls averaged over the shells %.4f +- %.4f: 1 within 4 se' %
          ('ok' if abs(m - 1) < 4 * se else 'not ok', what, col, m, se))
vp = tab('velocity_correlations', 'pairs')
for col in ('g_par', 'g_perp'):
    vals = []
    for t in vp:   # weighted by the pairs of each bin (g times the shell, up to a constant)
        num = den = 0.0
        for j, r in enumerate(t['centres']):
            x, g = t['columns'][col][j], t['columns']['g_nn'][j] + 1
            if t['edges'][j] >= 1.0 and x is not None:
                num += g * r * x; den += g * r
        vals.append(num / den)
    m, se = stats(vals)
    print('%s - %s: %s between walls over r in [1, %g) %.4f +- %.4f: 0 within 4 se' %
          ('ok' if abs(m) < 4 * se else 'not ok', what, col, vp[0]['edges'][-1], m, se))
PY
for m in ed dsmc hsmc; do
	cat >"$tmp/g1$m.json" <<JSON
{"method":"$m","dimensions":2,"particles":{"count":764,"box":[3000,20],"initial":{"positions":"random"}},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":5,"until":{"collisions_per_particle":80}},
 "output":{"every":{"collisions_per_particle":2},
   "observables":["collision_rate","pair_correlation","clusters","structure_factor","velocity_correlations"],
   "pair_correlation":{"bins":20,"range":10},"structure_factor":{"grid":1024},
   "snapshots":{"every":{"collisions_per_particle":2}}}}
JSON
	nu=0; [ $m = ed ] && nu=0.0100007
	run "g1$m" && { "$PY" "$SRCDIR/tests/check_g1.py" "$tmp/g1$m" "$m between walls" && "$PY" "$tmp/check_cl.py" "$tmp/g1$m" "$m" && "$PY" "$tmp/check_sk.py" "$tmp/g1$m" "$m" $nu; } \
		>"$tmp/g1$m.res" 2>&1
	report "$tmp/g1$m.res"
done
cat >"$tmp/g13.json" <<'JSON'
{"method":"hsmc","dimensions":3,"particles":{"count":825,"box":[60,60,12],"initial":{"positions":"random"}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":5,"until":{"collisions_per_particle":80}},
 "output":{"every":{"collisions_per_particle":2},
   "observables":["collision_rate","pair_correlation","clusters","structure_factor","velocity_correlations"],
   "pair_correlation":{"bins":12,"range":6},"structure_factor":{"grid":32},
   "snapshots":{"every":{"collisions_per_particle":2}}}}
JSON
run g13 && { "$PY" "$SRCDIR/tests/check_g1.py" "$tmp/g13" "hsmc 3D between walls" && "$PY" "$tmp/check_cl.py" "$tmp/g13" "hsmc 3D" && "$PY" "$tmp/check_sk.py" "$tmp/g13" "hsmc 3D" 0; } \
	>"$tmp/g13.res" 2>&1
report "$tmp/g13.res"

# ---- g(sigma) of a dense elastic gas between walls ----------------------------------------------------
# ed, 2D area fraction 0.3 with walls along y (box 80 x 100), 3D volume fraction 0.2 with walls along z
# (box 20 x 20 x 30); 50 samples 2 collisions per particle apart, errors from blocks of 5 (as in
# observe_test.sh). Two checks:
# - the exact equilibrium relation between the contact pairs and the collision rate: both count the pairs
#   at contact (the collision rate weights them by the Maxwellian approach speed, the same for every pair
#   at one temperature), also where walls make the density uneven. g_contact_rate is normalised by the
#   whole box (volume V, the scene's volume fraction), the pair histogram by the region the centres fill
#   (V_in, one radius in from each wall) and the part f(sigma) of the contact shell inside it, so
#   g_pairs = g_rate V_in / (V f(sigma)): within 3 se + 1% (the periodic check's allowance for the contact
#   fit, observe_test.sh);
# - g_pairs against Henderson (2D) / Carnahan-Starling (3D) at the mean density within 3 se + 1% of the
#   theory, as the periodic check: the wall layers (a few diameters of 100 and 30, where density and g
#   differ from the bulk) are within that (measured with 4 seeds in 2D: 1.799 between walls, 1.789 periodic).
cat >"$tmp/check_gs.py" <<'PY'
import json, math, sys
out, dim, phi, L = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
prog = [json.loads(l) for l in open(out + '.out') if '"progress"' in l]
prog = [p for p in prog if p.get('g_contact_rate') is not None]
def block(x, b=5):
    m = [sum(x[i:i + b]) / b for i in range(0, len(x) - b + 1, b)]
    k = len(m); mu = sum(m) / k
    return mu, math.sqrt(sum((v - mu) ** 2 for v in m) / (k - 1) / k)
if dim == 2:
    gth, name = (1 - 7 * phi / 16) / (1 - phi) ** 2, 'Henderson'
    f = 1 - 2 / (math.pi * (L - 1))       # 1 - 2 r / (pi L_in) at r = sigma = 1
else:
    gth, name = (1 - phi / 2) / (1 - phi) ** 3, 'Carnahan-Starling'
    f = 1 - 1 / (2 * (L - 1))             # 1 - r / (2 L_in)
vin = (L - 1) / L
gp = block([p['g_contact_pairs'] for p in prog])
gr = block([p['g_contact_rate'] * vin / f for p in prog])
d, se = gp[0] - gr[0], math.hypot(gp[1], gr[1])
print('%s - %dD walls: g(sigma) from pairs %.4f +- %.4f and from the collision rate %.4f +- %.4f (x V_in/(V f) = '
      '%.5f) agree within 3 se + 1%%' % ('ok' if abs(d) < 3 * se + 0.01 * gr[0] else 'not ok', dim, gp[0], gp[1],
      gr[0], gr[1], vin / f))
print('%s - %dD walls: g(sigma) from pairs %.4f +- %.4f vs %s %.4f within 3 se + 1%%' %
      ('ok' if abs(gp[0] - gth) < 3 * gp[1] + 0.01 * gth else 'not ok', dim, gp[0], gp[1], name, gth))
PY
cat >"$tmp/gs2.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":3056,"box":[80,100],
   "initial":{"positions":"random","relax":{"collisions_per_particle":20}}},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":5,"until":{"collisions_per_particle":100}},
 "output":{"every":{"collisions_per_particle":2},"observables":["temperature","collision_rate","pair_correlation"]}}
JSON
cat >"$tmp/gs3.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":4584,"box":[20,20,30],
   "initial":{"positions":"random","relax":{"collisions_per_particle":20}}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":5,"until":{"collisions_per_particle":100}},
 "output":{"every":{"collisions_per_particle":2},"observables":["temperature","collision_rate","pair_correlation"]}}
JSON
run gs2 && "$PY" "$tmp/check_gs.py" "$tmp/gs2" 2 0.3000221 100 >"$tmp/gs2.res" 2>&1
report "$tmp/gs2.res"
run gs3 && "$PY" "$tmp/check_gs.py" "$tmp/gs3" 3 0.2000147 30 >"$tmp/gs3.res" 2>&1
report "$tmp/gs3.res"

# ---- mean-square displacement with walls and gravity -------------------------------------------------------
# (a) Self-diffusion along the periodic axes between specular walls: 3D hard spheres at volume fraction 0.1
# between walls along z 21 diameters apart (centres fill 20; x, y periodic 16), 6 seeds. Specular walls keep
# v_x, v_y, and 20 diameters are ~20 mean free paths: D along x, y is the bulk value. D of each run from
# the slope of msd - msd_walled (the periodic part) between t = 10 and t = 400 over 2 D_p = 4 axes; the test
# and its band are transport_test.sh's periodic check (Enskog with Speedy's dense-gas correction: D between
# 0.98 D_Enskog and 1.02 D_Speedy within 4 se over the seeds, Student t with 5 dof, p ~ 0.01).
# (b) Saturation along the walled axis: at times long after the slowest diffusive mode across the slab,
# z(t) and z(0) are independent draws of the stationary profile, so msd_walled -> 2 Var(z). Dilute gas
# (volume fraction 0.01, walls 11 apart: centres uniform on [0.5, 10.5] up to O(nu) wall layering):
# 2 Var = L_in^2 / 6 = 16.667; each run averaged over t in [20, 200] (the slowest mode decays in
# L_in^2 / (pi^2 D) ~ 1), 6 seeds per method, within 4 se over the seeds.
# (c) Gravity along the walled axis (g = -0.2, elastic, relaxed to equilibrium before the origin): the
# profile is barometric, exp(-lambda z) on [0, L_in] with lambda = m g / kT (T the measured temperature),
# so msd_walled -> 2 Var(z) = 2 (1/lambda^2 - L_in^2 e^(-lambda L_in) / (1 - e^(-lambda L_in))^2), t in
# [50, 400], 6 seeds per method within 4 se (hard spheres: the O(nu) excluded volume at the floor,
# where the density doubles to nu = 0.02, is well inside that). The speed bound then counts the
# potential energy above the floor (engine/observe/msd.h).
cat >"$tmp/check_dw.py" <<'PY'
import json, math, sys
d, what = sys.argv[1], sys.argv[2]
Ds = []
for s in range(1, 7):
    p = [json.loads(l) for l in open('%s/dw%d.out' % (d, s)) if '"progress"' in l]
    a = [x for x in p if x['time'] >= 10 - 1e-9]
    per = lambda x: x['msd'] - x['msd_walled']
    Ds.append((per(a[-1]) - per(a[0])) / (4 * (a[-1]['time'] - a[0]['time'])))
m = sum(Ds) / 6; se = math.sqrt(sum((x - m) ** 2 for x in Ds) / 5 / 6)
nu = 1027 * math.pi / 6 / (16 * 16 * 21); ns = 6 * nu / math.pi; chi = (1 - nu / 2) / (1 - nu) ** 3
DE = 3 / (8 * ns * chi) * math.sqrt(1 / math.pi)
D0 = 3 / 8 * math.sqrt(1 / math.pi); DS = D0 / ns * (1 - ns / 1.09) * (1 + ns * ns * (0.40 - 0.83 * ns * ns))
good = 0.98 * DE - 4 * se < m < 1.02 * DS + 4 * se
print('%s - %s: D along the periodic axes between walls %.4f +- %.4f over 6 runs, D/D_Enskog = %.3f (Enskog %.4f, '
      'Speedy %.4f)' % ('ok' if good else 'not ok', what, m, se, m / DE, DE, DS))
PY
cat >"$tmp/check_sat.py" <<'PY'
import json, math, sys
d, name, what, g, t0 = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
W, th = [], []
for s in range(1, 7):
    p = [json.loads(l) for l in open('%s/%s%d.out' % (d, name, s)) if '"progress"' in l]
    late = [x for x in p if x['time'] >= t0]
    W.append(sum(x['msd_walled'] for x in late) / len(late))
    T = sum(x['temperature'] for x in late) / len(late)
    Le = 10.0
    if g:
        lam = g / T
        th.append(2 * (1 / lam ** 2 - Le ** 2 * math.exp(-lam * Le) / (1 - math.exp(-lam * Le)) ** 2))
    else:
        th.append(Le ** 2 / 6)
m = sum(W) / 6; se = math.sqrt(sum((x - m) ** 2 for x in W) / 5 / 6); t = sum(th) / 6
print('%s - %s: msd_walled saturates at %.3f +- %.3f over 6 runs vs %s %.3f within 4 se' %
      ('ok' if abs(m - t) < 4 * se else 'not ok', what, m, se,
       '2 Var(z) of the barometric profile' if g else 'L_in^2/6 (uniform centres)', t))
PY
for s in 1 2 3 4 5 6; do
	cat >"$tmp/dw$s.json" <<JSON
{"method":"ed","dimensions":3,"particles":{"count":1027,"box":[16,16,21],
   "initial":{"positions":"random","relax":{"collisions_per_particle":10}}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":$((30 + s)),"until":{"time":400}},
 "output":{"every":{"time":2},"observables":["temperature","mean_square_displacement"]}}
JSON
	"$ENGINE" run "$tmp/dw$s.json" >"$tmp/dw$s.out" 2>"$tmp/dw$s.err" || echo "run $s failed: $(head -c 200 "$tmp/dw$s.err")" >&2
done
"$PY" "$tmp/check_dw.py" "$tmp" ed >"$tmp/dw.res" 2>&1 || echo "not ok - diffusion with walls: $(tail -1 "$tmp/dw.res")" >>"$tmp/dw.res"
report "$tmp/dw.res"
for m in ed dsmc hsmc; do
	for s in 1 2 3 4 5 6; do
		cat >"$tmp/sat$s.json" <<JSON
{"method":"$m","dimensions":3,"particles":{"count":336,"box":[40,40,11],"initial":{"positions":"random"}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":$((40 + s)),"until":{"time":200}},
 "output":{"every":{"time":1},"observables":["temperature","mean_square_displacement"]}}
JSON
		sed -e 's/"positions":"random"}/"positions":"random","relax":{"collisions_per_particle":20}}/' \
			-e 's/"run":{/"gravity":[0,0,-0.2],"run":{/' -e 's/"time":200/"time":400/' "$tmp/sat$s.json" >"$tmp/grav$s.json"
		"$ENGINE" run "$tmp/sat$s.json" >"$tmp/sat$s.out" 2>"$tmp/sat$s.err" || echo "$m run $s failed" >&2
		"$ENGINE" run "$tmp/grav$s.json" >"$tmp/grav$s.out" 2>"$tmp/grav$s.err" || echo "$m gravity run $s failed" >&2
	done
	{ "$PY" "$tmp/check_sat.py" "$tmp" sat "$m, walls" 0 20 && "$PY" "$tmp/check_sat.py" "$tmp" grav "$m, walls and gravity" 0.2 50; } \
		>"$tmp/sat$m.res" 2>&1 || echo "not ok - $m saturation: $(tail -1 "$tmp/sat$m.res")" >>"$tmp/sat$m.res"
	report "$tmp/sat$m.res"
done

# ---- resume ----------------------------------------------------------------------------------------------
# A bed under gravity between walls (inelastic, TC for ed) with every structure observable: resumed from its
# checkpoint (time 2 of 4), the progress records (MSD, msd_walled, D, g(sigma)) and observables.jsonl equal
# the uninterrupted run's.
for m in ed dsmc hsmc; do
	cat >"$tmp/ck$m.json" <<JSON
{"method":"$m","dimensions":2,"particles":{"count":400,"box":[40,40],"initial":{"positions":"random"}},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular","restitution":0.9},"upper":{"type":"rough","probability":0.5}}},
 "gravity":[0,-0.5],"collisions":{"restitution":0.9,"tc":1e-4},"run":{"seed":8,"until":{"time":4}},
 "output":{"every":{"time":0.5},"observables":["temperature","pair_correlation","clusters","structure_factor",
   "velocity_correlations","mean_square_displacement"],
   "snapshots":{"every":{"time":1.5}},"checkpoint":{"every":{"time":2}}}}
JSON
	[ $m = ed ] || sed -i 's/,"tc":1e-4//' "$tmp/ck$m.json"
	"$ENGINE" run "$tmp/ck$m.json" --out "$tmp/full$m" >/dev/null 2>"$tmp/ckf.err"
	mkdir -p "$tmp/part$m"
	cp -r "$tmp/full$m/." "$tmp/part$m/"
	"$ENGINE" run "$tmp/ck$m.json" --out "$tmp/part$m" --resume "$tmp/part$m/checkpoint.h5" >/dev/null 2>"$tmp/ck.err"
	rc=$?
	"$PY" - "$tmp/full$m" "$tmp/part$m" <<'PY' >"$tmp/ck.res" 2>&1
import json, sys
def rows(o):
    return [(p['time'], p['msd'], p['msd_walled'], p.get('diffusion'), p.get('g_contact_pairs'))
            for p in map(json.loads, open(o + '/progress.jsonl')) if p.get('type') == 'progress']
a, b = rows(sys.argv[1]), rows(sys.argv[2])
assert a == b and len(a) == 9, (len(a), len(b))
assert open(sys.argv[1] + '/observables.jsonl').read() == open(sys.argv[2] + '/observables.jsonl').read()
print(len(a))
PY
	ok $(( rc != 0 || $? != 0 )) "$m, walls and gravity: the resumed run's MSD, msd_walled, D, g(sigma) and curves equal the uninterrupted run's (rc $rc; $(tail -1 "$tmp/ck.res") $(head -c 200 "$tmp/ckf.err"))"
done

echo "1..$n"
[ "$failed" = 0 ]
