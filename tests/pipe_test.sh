#!/bin/sh
# density_spectrum and flux of whole engine runs against theory (issue 13 experiment 2; TAP): the white spectrum of a
# dilute elastic gas at its equation-of-state level, zero flux of a gas at rest (ed, dsmc, hsmc), the flux equals
# sum v . g_hat / volume of the trajectory frame and trajectory.h5's observables/flux, exact resume of the spectrum.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pipe_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
run() { "$ENGINE" run "$1" --out "$2" >"$2.log" 2>&1; }

# 1. Ideal gas: 127 elastic disks at nu = 0.01 in a periodic 100 x 100 box (mean free path ~ 28, thermal speed ~ 1.3,
# D ~ 18): 10 slices along y sampled every 50 time units, three times the relaxation time of the slowest density
# mode L^2 / (4 pi^2 D) ~ 14, so the slice counts of successive samples are uncorrelated: P(f) is white at
# 2 var / m with var = (N/S)(1 - 1/S) S(0), S(0) = (1 - nu)^3 / (1 + nu) (hard disks, scaled-particle theory), and
# the fitted slope is 0 within its standard error. m = 256 samples, 127 frequencies.
cat >"$tmp/ideal.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":127,"box":[100,100],"initial":{"positions":"random"}},
 "run":{"seed":5,"until":{"time":12800}},
 "output":{"every":{"time":1280},"observables":["temperature","density_spectrum"],
   "density_spectrum":{"interval":50,"slices":10},"snapshots":{"every":{"time":12800}}}}
JSON
run "$tmp/ideal.json" "$tmp/ideal"
ok $? "ideal gas: the run completes"
"$PY" - "$tmp/ideal/observables.jsonl" <<'PY' >"$tmp/ideal.out" 2>&1
import json, math, sys
d = [json.loads(l) for l in open(sys.argv[1])][-1]
P = d['tables'][0]['columns']['P']
N, S, m, nu = 127, 10, 256, 127 * math.pi * 0.25 / 1e4
level = 2 * (N / S) * (1 - 1 / S) * (1 - nu) ** 3 / (1 + nu) / m
K = len(P); mean = sum(P) / K
sem = math.sqrt(sum((p - mean) ** 2 for p in P) / (K - 1) / K)
a, se = d['alpha'], d['alpha_se']
good = d['samples'] == m and K == m // 2 - 1 and abs(mean - level) < 5 * sem and abs(a) < 5 * se
print("%d mean P %.5g vs level %.5g (5 se %.3g), slope %.4f +- %.4f" % (good, mean, level, 5 * sem, a, se))
PY
read -r good rest <"$tmp/ideal.out"
[ "$good" = 1 ]
ok $? "ideal gas: white spectrum at the Poisson level times S(0) within 5 se, slope 0 within 5 se: $rest"

# 2. A gas at rest in a box with specular walls on y (no gravity: the flux is along +y): sum v_y changes at every
# wall hit, so the flux fluctuates around 0 with the standard error over particles sqrt(N var v_y) / V of each
# record (Maxwellian, independent velocities): every one of the 20 records within 5 of its se (a false alarm
# has probability 20 x 6e-7).
for m in ed dsmc hsmc; do
	cat >"$tmp/rest-$m.json" <<JSON
{"method":"$m","dimensions":2,"particles":{"count":400,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":2,"until":{"time":20}},
 "output":{"every":{"time":1},"observables":["temperature","flux"],"snapshots":{"every":{"time":20}}}}
JSON
	run "$tmp/rest-$m.json" "$tmp/rest-$m"
	rc=$?
	"$PY" - "$tmp/rest-$m/progress.jsonl" <<'PY' >"$tmp/rest.out" 2>&1
import json, sys
recs = [json.loads(l) for l in open(sys.argv[1])]
prog = [r for r in recs if r['type'] == 'progress' and r['time'] > 0]
worst = max(abs(r['flux']) / r['flux_se'] for r in prog)
moved = sum(1 for r in prog if r['flux'] != 0)
print(int(len(prog) == 20 and worst < 5 and moved > 10), "worst |flux| / se = %.2f over %d records" % (worst, len(prog)))
PY
	read -r good rest <"$tmp/rest.out"
	[ $rc = 0 ] && [ "$good" = 1 ]
	ok $? "$m gas at rest: flux 0 within 5 se in every record: $rest"
done

# 3. The flux of the last record equals sum v . g_hat / volume of the last trajectory frame (same instant) and
# trajectory.h5's observables/flux: a pipe under gravity -y (g_hat = -y), hsmc, and the ed gas at rest above.
cat >"$tmp/pipe.json" <<'JSON'
{"method":"hsmc","dimensions":2,"particles":{"count":300,"radius":0.5,"box":[10,60],"initial":{"positions":"random","temperature":0.01}},
 "collisions":{"restitution":0.5,"tc":0.01},
 "boundaries":{"x":{"type":"walls","lower":{"type":"rough","probability":0.1},"upper":{"type":"rough","probability":0.1}}},
 "gravity":[0,-1],"run":{"seed":1,"until":{"time":8}},
 "output":{"every":{"time":0.5},"observables":["temperature","flux","density_spectrum"],
   "density_spectrum":{"interval":0.05,"slices":30},"snapshots":{"every":{"time":4}},
   "checkpoint":{"every":{"time":5.3}}},
 "hsmc":{"cell_size":2,"time_step":0.005}}
JSON
run "$tmp/pipe.json" "$tmp/pipe"
ok $? "pipe (hsmc, rough walls, gravity): the run completes"
for case in pipe:-1:300:600 rest-ed:1:400:6283.185307179586; do
	set -- $(echo "$case" | tr ':' ' ')
	d=$tmp/$1
	h5dump -m %.17g -y -w 0 -d /particles/all/velocity/value "$d/trajectory.h5" >"$tmp/vel.txt" 2>/dev/null &&
	h5dump -m %.17g -y -w 0 -d /observables/flux/value "$d/trajectory.h5" >"$tmp/fluxh5.txt" 2>/dev/null
	rc=$?
	"$PY" - "$d/progress.jsonl" "$tmp/vel.txt" "$tmp/fluxh5.txt" "$2" "$3" "$4" <<'PY' >"$tmp/cmp.out" 2>&1
import json, re, sys
prog = [json.loads(l) for l in open(sys.argv[1])]
prog = [r for r in prog if r['type'] == 'progress']
num = lambda f: [float(x) for x in re.findall(r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?', open(f).read().split('DATA {', 1)[1].split('}', 1)[0])]
sign, N, V = float(sys.argv[4]), int(sys.argv[5]), float(sys.argv[6])
v = num(sys.argv[2])[-2 * N:]
flux = sign * sum(v[2 * i + 1] for i in range(N)) / V
h5 = num(sys.argv[3])
last = prog[-1]['flux']
tol = 1e-9 * max(1.0, abs(flux))
good = abs(last - flux) <= tol and len(h5) == len(prog) and all(abs(a - r['flux']) <= 1e-12 * max(1, abs(a)) for a, r in zip(h5, prog))
print(int(good), "record %.12g, frame %.12g, %d H5MD rows" % (last, flux, len(h5)))
PY
	read -r good rest <"$tmp/cmp.out"
	[ $rc = 0 ] && [ "$good" = 1 ]
	ok $? "$1: flux of the last record = sum v . g_hat / volume of the last frame, = trajectory.h5 observables/flux: $rest"
done

# 4. Exact resume: a checkpoint at time 5.3, between snapshots (the ring of samples half full for the spectrum at
# 8): observables.jsonl of the resumed run equals the uninterrupted run's byte for byte.
cp -r "$tmp/pipe" "$tmp/part"
"$ENGINE" run "$tmp/pipe.json" --out "$tmp/part" --resume "$tmp/part/checkpoint.h5" >/dev/null 2>"$tmp/ck.err"
rc=$?
cmp -s "$tmp/pipe/observables.jsonl" "$tmp/part/observables.jsonl"
r1=$?
ok $(( rc != 0 || r1 != 0 )) "pipe: resumed from time 5.3, observables.jsonl equals the uninterrupted run's (rc $rc, alpha $(grep -o '"alpha":[^,]*' "$tmp/pipe/observables.jsonl" | tr '\n' ' ')) $(head -c 200 "$tmp/ck.err")"

# 5. trajectory.h5: one row of /observables/density_spectrum_* per spectrum, equal to observables.jsonl (17
# significant digits), and the resumed run's rows equal the uninterrupted run's.
same=0
for q in samples power alpha alpha_se; do
	h5dump -m %.17g -y -w 0 -d /observables/density_spectrum_$q/value "$tmp/pipe/trajectory.h5" >"$tmp/h5.$q" 2>&1 || same=1
	h5dump -m %.17g -y -w 0 -d /observables/density_spectrum_$q/value "$tmp/part/trajectory.h5" >"$tmp/h5p.$q" 2>&1 || same=1
	sed 1d "$tmp/h5.$q" >"$tmp/a"; sed 1d "$tmp/h5p.$q" >"$tmp/b"
	cmp -s "$tmp/a" "$tmp/b" || same=1
done
"$PY" - "$tmp/pipe/observables.jsonl" "$tmp/h5.power" "$tmp/h5.alpha" <<'PY' >"$tmp/h5cmp.out" 2>&1
import json, math, re, sys
num = lambda f: [float(x) for x in re.findall(r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|nan', open(f).read().split('DATA {', 1)[1].split('}', 1)[0])]
recs = [json.loads(l) for l in open(sys.argv[1])]
P = [x for r in recs for x in r['tables'][0]['columns']['P']]
A = [r['alpha'] for r in recs]
hp, ha = num(sys.argv[2]), num(sys.argv[3])
eq = lambda a, b: (a is None and math.isnan(b)) or (a is not None and abs(a - b) <= 1e-8 * abs(a))
print(int(len(hp) == len(P) and len(ha) == len(A) and all(map(eq, P, hp)) and all(map(eq, A, ha))), "%d rows" % len(A))
PY
read -r good rest <"$tmp/h5cmp.out"
[ "$good" = 1 ] && [ $same = 0 ]
ok $? "pipe: trajectory.h5 density_spectrum_* equal observables.jsonl ($rest), and the resumed run's rows equal the uninterrupted run's"

echo "1..$n"
[ $failed -eq 0 ]
