#!/bin/sh
# Pipe flow (seed 000 A8, A9): the density_spectrum slope alpha against the restitution r at nu = 0.38, p = 0.1, and the fundamental diagram Phi(nu) at r = 0, from presets/pipe-flow-2d.json (hsmc).
# usage: bench/pipe.sh [ENGINE]   (default engine/granular-engine; prints a markdown report)
# Settings (environment): RS="0 0.5 0.9 0.99" (restitutions for alpha), NUS="0.2 0.38 0.6 0.7 0.75 0.8" (area fractions for
# Phi; empty: skip), T_SKIP (default 204.8: the transient from rest left out), T_END (default 409.6), SEED (1).
# alpha: the mean of the fitted slopes of the spectra of the snapshot windows after T_SKIP (non-overlapping windows
# of 20.48 time units, 2048 samples each), its standard error the scatter of those slopes / sqrt(windows); twice:
# the engine's own fit over the preset's fixed range output.density_spectrum.fit, and a refit of the same spectra
# over the range the seed names (between the two cut-offs of fig. 3.19) scaled with the measured mean velocity <v>:
# f from 2 <v> / L (L the pipe length: slower fluctuations are cut by the periodic system) to <v> / (2 h)
# (h the slice height: faster ones are single particles entering and leaving the slice).
# Phi: flux = sum v . g_hat / area (particles per unit length per unit time along gravity) averaged over the
# progress records after T_SKIP; its standard error from the means of the same windows; Phi_nu = nu <v> = flux x
# particle area (the seed's flow rate as area fraction times mean velocity).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
engine=${1:-$here/engine/granular-engine}
exec /usr/bin/python3 - "$engine" "$here/presets/pipe-flow-2d.json" <<'PY'
import json, math, os, subprocess, sys, tempfile, time

engine, preset = sys.argv[1], sys.argv[2]
env = os.environ.get
RS = [float(v) for v in env("RS", "0 0.5 0.9 0.99").split()]
NUS = [float(v) for v in env("NUS", "0.2 0.38 0.6 0.7 0.75 0.8").split()]
T_SKIP, T_END, SEED = float(env("T_SKIP", "204.8")), float(env("T_END", "409.6")), int(env("SEED", "1"))
base = json.load(open(preset))
W = base["output"]["snapshots"]["every"]["time"]
a_p = math.pi * base["particles"]["radius"] ** 2
box = base["particles"]["box"]

def mean_se(x):
    m = sum(x) / len(x)
    return m, (math.sqrt(sum((v - m) ** 2 for v in x) / (len(x) - 1) / len(x)) if len(x) > 1 else float("nan"))

def fit(f, P, lo, hi):
    pts = [(math.log(x), math.log(y)) for x, y in zip(f, P) if lo <= x <= hi and y is not None and y > 0]
    n = len(pts)
    if n < 3:
        return None
    sx = sum(x for x, _ in pts); sy = sum(y for _, y in pts)
    sxx = sum(x * x for x, _ in pts); sxy = sum(x * y for x, y in pts)
    return (n * sxy - sx * sy) / (n * sxx - sx * sx)

def run(r, nu):
    s = json.loads(json.dumps(base))
    s["collisions"]["restitution"] = r
    s["particles"]["count"] = int(round(nu * box[0] * box[1] / a_p))
    s["run"] = {"seed": SEED, "until": {"time": T_END}}
    d = tempfile.mkdtemp()
    with open(d + "/scene.json", "w") as fh:
        json.dump(s, fh)
    t0 = time.time()
    subprocess.run([engine, "run", d + "/scene.json", "--out", d + "/out"], check=True, stdout=subprocess.DEVNULL)
    wall = time.time() - t0
    spec = [json.loads(l) for l in open(d + "/out/observables.jsonl")]
    spec = [c for c in spec if c["time"] > T_SKIP + 1e-9 and c["alpha"] is not None]
    alphas = [c["alpha"] for c in spec]
    prog = [json.loads(l) for l in open(d + "/out/progress.jsonl")]
    prog = [p for p in prog if p["type"] == "progress" and p["time"] > T_SKIP + 1e-9]
    win = {}
    for p in prog:
        win.setdefault(math.ceil((p["time"] - T_SKIP) / W - 1e-9), []).append(p["flux"])
    fl = [sum(v) / len(v) for v in win.values()]
    v = mean_se(fl)[0] * box[0] * box[1] / s["particles"]["count"]
    L, h = box[1], box[1] / s["output"]["density_spectrum"]["slices"]
    lo, hi = 2 * v / L, v / (2 * h)
    sc = [fit(c["tables"][0]["centres"], c["tables"][0]["columns"]["P"], lo, hi) for c in spec]
    sc = [a for a in sc if a is not None]
    return s["particles"]["count"], mean_se(alphas), len(alphas), mean_se(fl), len(fl), wall, mean_se(sc), (lo, hi)

print("Preset %s, hsmc, p = 0.1, box %g x %g diameters, %s; windows after t = %g up to %g, seed %d.\n" %
      (os.path.basename(preset), box[0], box[1], "slices %d, interval %g, fit f in %s" % (
       base["output"]["density_spectrum"]["slices"], base["output"]["density_spectrum"]["interval"],
       base["output"]["density_spectrum"]["fit"]), T_SKIP, T_END, SEED))
print("| r | nu | N | alpha (fixed fit) | se | <v> | scaled fit range | alpha (scaled) | se | windows | flux | se | wall s |")
print("|---|----|---|-------------------|----|-----|------------------|----------------|----|---------|------|----|--------|")
for r in RS:
    n, (a, ase), na, (f, fse), nf, wall, (b, bse), (lo, hi) = run(r, 0.38)
    print("| %g | 0.38 | %d | %.3f | %.3f | %.2f | [%.3g, %.3g] | %.3f | %.3f | %d | %.3f | %.3f | %.0f |" % (
          r, n, a, ase, f * box[0] * box[1] / n, lo, hi, b, bse, na, f, fse, wall), flush=True)
if NUS:
    print("\nFundamental diagram at r = 0:\n")
    print("| nu | N | flux | se | Phi_nu = nu <v> | se | <v> | alpha (scaled fit) | se | wall s |")
    print("|----|---|------|----|-----------------|----|-----|--------------------|----|--------|")
    for nu in NUS:
        n, (a, ase), na, (f, fse), nf, wall, (b, bse), _ = run(0.0, nu)
        print("| %g | %d | %.3f | %.3f | %.3f | %.3f | %.2f | %.3f | %.3f | %.0f |" % (
              nu, n, f, fse, f * a_p, fse * a_p, f * box[0] * box[1] / n, b, bse, wall), flush=True)
PY
