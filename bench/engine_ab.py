#!/usr/bin/env python3
"""A/B of two granular-engine binaries on one scene: CPU seconds per run, interleaved, median of N ratios."""
# usage: bench/engine_ab.py BASELINE_ENGINE THIS_ENGINE SCENE.json [RUNS]  (default 7 runs)
# Prints one markdown row: speed ratio this / baseline (baseline CPU time / this CPU time), median and all
# runs. Exits 1 when the two builds' summaries differ in collisions or kinetic energy (bit-identical runs).
import json
import resource
import statistics
import subprocess
import sys


def run(engine, scene):
    t0 = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    out = subprocess.run([engine, "run", scene], capture_output=True, text=True, check=True).stdout
    t1 = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    s = json.loads(out.strip().splitlines()[-1])
    return t1 - t0, (s["collisions"], s["kinetic_energy"])


def main():
    base, new, scene = sys.argv[1:4]
    runs = int(sys.argv[4]) if len(sys.argv) > 4 else 7
    ratios = []
    for k in range(runs):
        # alternate which build goes first, so drifts of the machine cancel
        if k % 2 == 0:
            b = run(base, scene)
            n = run(new, scene)
        else:
            n = run(new, scene)
            b = run(base, scene)
        if b[1] != n[1]:
            print("runs differ: %s vs %s" % (b[1], n[1]), file=sys.stderr)
            return 1
        ratios.append(b[0] / n[0])
    r = sorted(ratios)
    print("| `%s` | %.3f | %s |" % (scene, statistics.median(r), ", ".join("%.3f" % x for x in r)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
