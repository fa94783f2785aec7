#!/usr/bin/python3
"""Seed 000 section 3.6 (issue 13, item 5): where DSMC and HSMC leave the exact engine as velocity correlations grow.

usage: bench/correlations.py ENGINE [--quick]     (prints a markdown report; about 3 minutes, --quick 1)

2D, N = 50000 (--quick: 10000), volume fraction 0.05 and 0.245, restitution 0.98 and 0.85; each scene run by
ed (TC 1e-4 against inelastic collapse), dsmc (correction none) and hsmc (cba) from an elastic relaxation of 10
collisions per particle, to tau = 2C/N = 200 collisions per particle (the seed's collision units, which take
out the methods' different collision rates). Reported per method:
- K/K0 at tau = 140 (the seed's observation time) and the first tau where K_MC/K_ED leaves 1 by more than 5%
  (outputs every 5 collisions per particle);
- "corrected" (the seed's "HSMC corrected"): the same MC run with the impact parameter drawn from ED's own c(tau)
  (dsmc/hsmc impact_c, docs/scene.md: ed's fit over each snapshot interval, at the interval's middle);
- c of the impact-parameter fit P(b)/P_chaos = a/(1 - c b^2) (b in diameters; c = 0 is molecular chaos) over
  tau 100-120 and 180-200 (the collisions between snapshots 20 apart), and the first snapshot where |c|
  exceeds 0.05.
The seed: r = 0.98 matches ED; at r = 0.85 the MC energy falls below ED from tau ~80 (nu = 0.05) and ~30
(nu = 0.245), and c departs from 0 at tau ~80 / 40.
"""
import json, os, subprocess, sys, tempfile

args = [a for a in sys.argv[1:] if not a.startswith("--")]
ENGINE = args[0]
QUICK = "--quick" in sys.argv
N = 10000 if QUICK else 50000
TAU, EVERY, SNAP = 200, 5, 20


def run(method, nu, r, table=None):
    s = {"method": method, "dimensions": 2,
         "particles": {"count": N, "volume_fraction": nu, "initial": {"relax": {"collisions_per_particle": 10}}},
         "collisions": {"restitution": r},
         "run": {"seed": 1, "until": {"collisions_per_particle": TAU}},
         "output": {"every": {"collisions_per_particle": EVERY}, "observables": ["kinetic_energy", "impact_parameter"],
                    "snapshots": {"every": {"collisions_per_particle": SNAP}}}}
    if method == "ed":
        s["collisions"]["tc"] = 1e-4
    if table:   # "corrected": the impact parameter from ed's c(tau) (impact_c, docs/scene.md)
        s[method] = {"impact_c": table}
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "scene.json")
        json.dump(s, open(path, "w"))
        p = subprocess.run([ENGINE, "run", path, "--out", os.path.join(d, "out")], capture_output=True, text=True)
        if p.returncode != 0:
            raise SystemExit("%s nu=%g r=%g: exit %d: %s" % (method, nu, r, p.returncode, p.stderr.strip()[:300]))
        prog = [json.loads(l) for l in open(os.path.join(d, "out", "progress.jsonl")) if '"progress"' in l]
        curves = [json.loads(l) for l in open(os.path.join(d, "out", "observables.jsonl"))]
    k0 = prog[0]["kinetic_energy"]
    K = {round(q["collisions_per_particle"]): q["kinetic_energy"] / k0 for q in prog}
    C = {round(c["collisions_per_particle"]): c["fit_c"] for c in curves if c["name"] == "impact_parameter"}
    return K, C


def fmt(x, f="%.3f"):
    return "-" if x is None else f % x


print("## Velocity correlations: where MC leaves ED (seed 000 section 3.6, issue 13)\n")
print("Command: `bench/correlations.py engine/granular-engine` (N = %d). The method: the docstring of "
      "bench/correlations.py.\n" % N)
print("| volume fraction | restitution | method | K/K0 at tau 140 | K_MC/K_ED - 1 at 140 | leaves ED (5%) at tau | "
      "c at tau 120 | c at tau 200 | abs(c) > 0.05 from tau |")
print("|---|---|---|---|---|---|---|---|---|")
for nu in (0.05, 0.245):
    for r in (0.98, 0.85):
        res = {"ed": run("ed", nu, r)}
        # ed's fit c over each snapshot interval, placed at the interval's middle (the corrected runs' table)
        table = [[t - SNAP / 2, max(-100.0, min(0.99, c))] for t, c in sorted(res["ed"][1].items()) if t > 0 and c is not None]
        for m in ("dsmc", "hsmc"):
            res[m] = run(m, nu, r)
            if table:
                res[m + " corrected"] = run(m, nu, r, table)
        Ked = res["ed"][0]
        for m in [k for k in ("ed", "dsmc", "dsmc corrected", "hsmc", "hsmc corrected") if k in res]:
            K, C = res[m]
            common = sorted(t for t in K if t in Ked and t > 0)
            dev = None
            if m != "ed":
                dev = next((t for t in common if abs(K[t] / Ked[t] - 1) > 0.05), None)
            cfrom = next((t for t in sorted(C) if C[t] is not None and abs(C[t]) > 0.05), None)
            print("| %g | %g | %s | %s | %s | %s | %s | %s | %s |" % (
                nu, r, m, fmt(K.get(140), "%.4g"),
                "" if m == "ed" else fmt(K[140] / Ked[140] - 1, "%+.3f") if 140 in K and 140 in Ked else "-",
                "" if m == "ed" else (fmt(dev, "%d") if dev else "no (to 200)"),
                fmt(C.get(120)), fmt(C.get(200)), fmt(cfrom, "%d") if cfrom else "no"))
        sys.stdout.flush()
