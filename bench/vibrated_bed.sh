#!/bin/sh
# Vibrated bed (seed 000 A11): H(V) - H(0) against V = 2 pi f A for ed, dsmc and hsmc from presets/vibrated-bed-2d.json, and the log-log fit of the exponent alpha.
# usage: bench/vibrated_bed.sh [ENGINE]   (default engine/granular-engine; prints a markdown report)
# Settings (environment): VS="0.2 0.4 ..." (m/s; V = 0 is always run for H(0)), T_END (s, default 4),
# T_SKIP (s, default 1: the transient left out), SEEDS (default 2), METHODS (default "ed dsmc hsmc"; "md" too,
# with RW = r and ALL_WALLS=1 only: its walls have the particles' force law; MD='{...}' its md settings,
# default frictionless), ALL_WALLS=1 (side walls and lid with r_w too; default: elastic, as the preset),
# RW (floor restitution r_w, default 1; the preset's particles have r = 0.9), VMIN (fit over V >= VMIN,
# default 0.6 m/s). H is the time mean of center_of_mass_height over [T_SKIP, T_END] (outputs every 0.01 s);
# its standard error comes from 10 block means per run, pooled over the seeds; alpha is the weighted
# least-squares slope of log(H - H0) on log V with its standard error (scaled up by sqrt(chi2/dof) when
# that exceeds 1). H(0): the bed at rest, from a run with amplitude 0 (ed: its last output before the run
# stops; a bed at rest under gravity ends in inelastic collapse even with tc, docs/engine.md).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
engine=${1:-$here/engine/granular-engine}
exec /usr/bin/python3 - "$engine" "$here/presets/vibrated-bed-2d.json" <<'PY'
import json, math, os, subprocess, sys, tempfile

engine, preset = sys.argv[1], sys.argv[2]
env = os.environ.get
VS = [float(v) for v in env("VS", "0.2 0.4 0.6 0.8 1.2 1.6 2.0").split()]
T_END, T_SKIP = float(env("T_END", "4")), float(env("T_SKIP", "1"))
SEEDS, METHODS = int(env("SEEDS", "2")), env("METHODS", "ed dsmc hsmc").split()
RW, VMIN = float(env("RW", "1")), float(env("VMIN", "0.6"))
ALLW = env("ALL_WALLS", "0") == "1"
base = json.load(open(preset))
f = base["boundaries"]["y"]["lower"]["frequency"]
mc = base.get("hsmc", {})

def run(method, V, seed):
    s = json.loads(json.dumps(base))
    s["method"] = method
    s.pop("hsmc", None)
    if method != "ed":
        s[method] = dict(mc)
    lw = s["boundaries"]["y"]["lower"]
    lw["amplitude"] = V / (2 * math.pi * f)
    lw["restitution"] = RW
    if ALLW:
        # side walls and lid with r_w too (the preset's are elastic)
        for ax, side in (("x", "lower"), ("x", "upper"), ("y", "upper")):
            s["boundaries"][ax][side]["restitution"] = RW
    if method == "md":
        # soft disks (issue 18): no TC, and every wall is a contact partner with the particles' law and
        # restitution, so md runs with RW = r and ALL_WALLS=1 only; frictionless, as the hard disks
        s["collisions"].pop("tc", None)
        if RW != s["collisions"]["restitution"] or not ALLW:
            return [], "md needs RW = r and ALL_WALLS=1"
        for ax, side in (("x", "lower"), ("x", "upper"), ("y", "lower"), ("y", "upper")):
            s["boundaries"][ax][side].pop("restitution", None)
        s["md"] = json.loads(env("MD", '{"friction": 0}'))
    s["run"] = {"seed": seed, "until": {"time": T_END}}
    s["output"] = {"every": {"time": 0.01}, "observables": ["center_of_mass_height"]}
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        json.dump(s, fh)
        path = fh.name
    p = subprocess.run([engine, "run", path], capture_output=True, text=True)
    os.unlink(path)
    rows = [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{")]
    hs = [(r["time"], r["center_of_mass_height"]) for r in rows if "center_of_mass_height" in r and r.get("type") != "summary"]
    status = rows[-1].get("status", "?") if rows else "no output"
    return hs, status

def stats(method, V):
    blocks, statuses, last = [], set(), None
    for seed in range(1, SEEDS + 1):
        hs, st = run(method, V, seed)
        statuses.add(st)
        if V == 0:
            # the bed at rest: its last height (ed may stop in a collapse)
            if hs:
                blocks.append(hs[-1][1])
            continue
        xs = [h for t, h in hs if t >= T_SKIP - 1e-9]
        if st != "completed" or len(xs) < 20:
            return None, None, ",".join(sorted(statuses))
        k = len(xs) // 10
        blocks += [sum(xs[i * k:(i + 1) * k]) / k for i in range(10)]
    if not blocks:
        return None, None, ",".join(sorted(statuses))
    m = sum(blocks) / len(blocks)
    se = math.sqrt(sum((b - m) ** 2 for b in blocks) / (len(blocks) - 1) / len(blocks)) if len(blocks) > 1 else 0.0
    return m, se, ",".join(sorted(statuses))

def fit(pts):
    # weighted least squares y = a + alpha x, weights 1/sy^2
    if len(pts) < 2:
        return None
    W = sum(1 / sy ** 2 for x, y, sy in pts)
    Sx = sum(x / sy ** 2 for x, y, sy in pts); Sy = sum(y / sy ** 2 for x, y, sy in pts)
    Sxx = sum(x * x / sy ** 2 for x, y, sy in pts); Sxy = sum(x * y / sy ** 2 for x, y, sy in pts)
    D = W * Sxx - Sx * Sx
    al = (W * Sxy - Sx * Sy) / D
    a = (Sy - al * Sx) / W
    se = math.sqrt(W / D)
    chi2 = sum(((y - a - al * x) / sy) ** 2 for x, y, sy in pts)
    dof = len(pts) - 2
    if dof > 0 and chi2 / dof > 1:
        se *= math.sqrt(chi2 / dof)
    return al, se, chi2, dof

print("Vibrated bed, %s: f = %g Hz, r_w = %g (%s), r = %g, N = %d, T_END = %g s, T_SKIP = %g s, %d seed(s)" %
      (os.path.basename(preset), f, RW, "every wall" if ALLW else "floor; side walls and lid elastic",
       base["collisions"]["restitution"], base["particles"]["count"], T_END, T_SKIP, SEEDS))
print()
res = {}
for m in METHODS:
    res[m] = {V: stats(m, V) for V in [0.0] + VS}
print("| V (m/s) | " + " | ".join("%s H (mm)" % m for m in METHODS) + " |")
print("|---|" + "---|" * len(METHODS))
for V in [0.0] + VS:
    cells = []
    for m in METHODS:
        h, se, st = res[m][V]
        cells.append("%.3f +- %.3f%s" % (1e3 * h, 1e3 * se, "" if st == "completed" else " (%s)" % st) if h is not None else st)
    print("| %g | %s |" % (V, " | ".join(cells)))
print()
for m in METHODS:
    h0, s0, _ = res[m][0.0]
    pts = []
    for V in VS:
        h, se, _ = res[m][V]
        if h is None or h0 is None or V < VMIN - 1e-12 or not h > h0:
            continue
        pts.append((math.log(V), math.log(h - h0), math.sqrt(se ** 2 + s0 ** 2) / (h - h0)))
    r = fit(pts)
    if r:
        print("- %s: alpha = %.2f +- %.2f over V >= %g m/s (%d points, chi2 %.1f for %d dof), H(0) = %.3f mm" %
              (m, r[0], r[1], VMIN, len(pts), r[2], r[3], 1e3 * h0))
    else:
        print("- %s: too few points above V = %g for a fit" % (m, VMIN))
if "ed" in METHODS:
    print()
    for m in METHODS:
        if m == "ed":
            continue
        dev = []
        for V in VS:
            a, b = res["ed"][V], res[m][V]
            if a[0] is None or b[0] is None:
                continue
            z = (b[0] - a[0]) / math.sqrt(a[1] ** 2 + b[1] ** 2)
            dev.append("V=%g: %+.0f%% (%+.1f SE)" % (V, 100 * (b[0] / a[0] - 1), z))
        print("- %s against ed: %s" % (m, "; ".join(dev)))
PY
