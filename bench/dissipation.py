#!/usr/bin/python3
"""Energy lost per collision (kappa, units of (1 - e^2) T) of ed, dsmc and hsmc over replicas: mean and standard error per window.

usage: dissipation.py BENCH_BINARY [--dim 2] [--n 4000] [--reps 64] [--jobs 2] [--phi 0.1,0.2,0.3,0.4]
                      [--e 0.9,0.7] [--variants ed,dsmc/enskog,hsmc/cba] [--cell 0] [--cps 0] [--raw FILE]
Prints one table row per (phi, e, variant, window): means and standard errors over the replicas of the
bench program's columns (bench/dissipation.c); then per (phi, e, variant) kappa over c = 0-15 (collision-weighted)
and its ratio to ed's. Build the program with `make bench/dissipation`; run under `nice` on a shared machine.
The tables in docs/engine.md ("Dissipation per collision") come from
`python3 bench/dissipation.py bench/dissipation --dim 2 --reps 96` and `--dim 3`.
"""
import argparse
import json
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def run(binary, variant, dim, n, phi, e, seed, cell, cps):
    method, _, corr = variant.partition("/")
    cmd = [binary, method, corr or "-", str(dim), str(n), str(phi), str(e), str(seed), str(cell), str(cps)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def mean_se(xs):
    m = sum(xs) / len(xs)
    if len(xs) < 2:
        return m, float("nan")
    var = sum((x - m) ** 2 for x in xs) / (len(xs) - 1)
    return m, math.sqrt(var / len(xs))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--reps", type=int, default=64)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--phi", default="0.1,0.2,0.3,0.4")
    ap.add_argument("--e", default="0.9,0.7")
    ap.add_argument("--variants", default="ed,dsmc/enskog,hsmc/cba")
    ap.add_argument("--cell", type=float, default=0)
    ap.add_argument("--cps", type=float, default=0)
    ap.add_argument("--raw")
    a = ap.parse_args()
    phis = [float(x) for x in a.phi.split(",")]
    es = [float(x) for x in a.e.split(",")]
    variants = a.variants.split(",")
    jobs = [(v, p, e, s) for p in phis for e in es for v in variants for s in range(1, a.reps + 1)]
    with ThreadPoolExecutor(a.jobs) as pool:
        res = list(pool.map(lambda j: run(a.binary, j[0], a.dim, a.n, j[1], j[2], j[3], a.cell, a.cps), jobs))
    if a.raw:
        with open(a.raw, "w") as f:
            for j, r in zip(jobs, res):
                for w in r:
                    f.write(json.dumps(dict(w, variant=j[0])) + "\n")
    by = {}
    for j, r in zip(jobs, res):
        by.setdefault((j[1], j[2], j[0]), []).append(r)
    print(f"# dim {a.dim} N {a.n} replicas {a.reps} cell {a.cell} cps {a.cps}")
    print("phi e variant window kappa se pairs_glob se pairs_cell se contact se cos2 se rate se")
    whole = {}
    for (p, e, v), runs in by.items():
        for w in range(len(runs[0])):
            k, se = mean_se([r[w]["kappa"] for r in runs])
            keys = ("pairs_glob", "pairs_cell", "contact", "cos2", "rate")
            extra = [mean_se([r[w][key] for r in runs]) for key in keys]
            win = f"{runs[0][w]['c0']:.0f}-{runs[0][w]['c1']:.0f}"
            print(f"{p} {e} {v} {win} {k:.4f} {se:.4f} " + " ".join(f"{x:.4f} {s:.4f}" for x, s in extra))
        # whole run: loss per collision over all windows of each replica (collision-weighted)
        ks = []
        for r in runs:
            dc = [w["c1"] - w["c0"] for w in r]
            ks.append(sum(w["kappa"] * d for w, d in zip(r, dc)) / sum(dc))
        whole[(p, e, v)] = mean_se(ks)
    print("\nphi e variant kappa_0_15 se ratio_to_ed se_ratio")
    for (p, e, v), (k, se) in whole.items():
        ref = whole.get((p, e, "ed"))
        if ref:
            r = k / ref[0]
            sr = r * math.sqrt((se / k) ** 2 + (ref[1] / ref[0]) ** 2)
            print(f"{p} {e} {v} {k:.4f} {se:.4f} {r:.4f} {sr:.4f}")
        else:
            print(f"{p} {e} {v} {k:.4f} {se:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
