#!/bin/sh
# Heap (seed 000 A10): presets/heap-2d.json and variants of it through the engine (hsmc), the surface profile h(x)
# at the last snapshot fitted per side as tests/heap_test.sh fits it (bins between 25% and 75% of the apex height).
# usage: bench/heap.sh [ENGINE]   (default engine/granular-engine; prints a markdown table)
# VARIANTS (environment): semicolon-separated JSON objects of "dotted.key": value changes to the preset; default:
# the preset, then with entry "step", rejected_moves "keep" and both (the seed's rules).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
engine=${1:-$here/engine/granular-engine}
exec /usr/bin/python3 - "$engine" "$here/presets/heap-2d.json" <<'PY'
import json, math, os, subprocess, sys, tempfile, time

engine, preset = sys.argv[1], sys.argv[2]
variants = os.environ.get("VARIANTS", '{}; {"hsmc.entry": "step"}; {"hsmc.rejected_moves": "keep"}; '
                          '{"hsmc.entry": "step", "hsmc.rejected_moves": "keep"}')
variants = [json.loads(v) for v in variants.split(";") if v.strip()]

def fit(sel):
    n = len(sel)
    if n < 3:
        return None
    mx = sum(x for x, _ in sel) / n; my = sum(y for _, y in sel) / n
    sxx = sum((x - mx) ** 2 for x, _ in sel)
    b = sum((x - mx) * (y - my) for x, y in sel) / sxx
    rms = math.sqrt(sum((y - my - b * (x - mx)) ** 2 for x, y in sel) / (n - 2))
    return n, abs(b), rms / math.sqrt(sxx), rms

print("| variant | wall s | CPU s | inserted | apex h_m | left side | right side |")
print("|---|---|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as tmp:
    for i, ch in enumerate(variants):
        s = json.load(open(preset))
        for k, v in ch.items():
            d = s
            for q in k.split(".")[:-1]:
                d = d.setdefault(q, {})
            d[k.split(".")[-1]] = v
        path, out = os.path.join(tmp, "s%d.json" % i), os.path.join(tmp, "o%d" % i)
        json.dump(s, open(path, "w"))
        t0, c0 = time.time(), os.times()
        subprocess.run([engine, "run", path, "--out", out], stdout=subprocess.DEVNULL, check=True)
        c1 = os.times()
        prog = [json.loads(l) for l in open(out + "/progress.jsonl") if '"progress"' in l]
        S = [json.loads(l) for l in open(out + "/observables.jsonl")][-1]
        t = S["tables"][0]
        pts = [(x, y) for x, y in zip(t["centres"], t["columns"]["h"]) if y is not None]
        hm = max(y for _, y in pts)
        xa = sum(x for x, y in pts if y == hm) / sum(1 for _, y in pts if y == hm)
        lo, hi = 0.5 + 0.25 * (hm - 0.5), 0.5 + 0.75 * (hm - 0.5)
        sides = [fit([(x, y) for x, y in pts if (x - xa) * sg > 0 and lo <= y <= hi]) for sg in (-1, 1)]
        txt = ["%d bins" % (0 if f is None else f[0]) if f is None or f[0] < 4 else
               "slope %.3f ± %.3f, rms %.2f, %d bins" % (f[1], f[2], f[3], f[0]) for f in sides]
        print("| %s | %.1f | %.1f | %d | %.1f | %s | %s |" % (json.dumps(ch) if ch else "preset", time.time() - t0,
              c1.children_user - c0.children_user + c1.children_system - c0.children_system, prog[-1]["inserted"],
              hm, txt[0], txt[1]))
        sys.stdout.flush()
PY
