#!/bin/sh
# The split ed run through the engine program (granular-engine run --split, one rank) against the serial run of
# the same scene: collisions per CPU second (user + system of the process, resource.getrusage of the child), ratio
# split / serial, interleaved runs (the order alternates), median of 5. One markdown table row per scene.
# usage: bench/ped_run.sh [ENGINE]   (default engine/granular-engine)
set -eu
ENGINE=${1:-engine/granular-engine}
/usr/bin/python3 - "$ENGINE" <<'PY'
import json, os, resource, subprocess, sys, tempfile
engine = sys.argv[1]
scenes = [
    ("3D elastic, N = 20000, phi 0.25, t = 3",
     {"method": "ed", "dimensions": 3, "particles": {"count": 20000, "volume_fraction": 0.25},
      "run": {"seed": 1, "until": {"time": 3}}, "output": {"every": {"time": 1}}}),
    ("2D e 0.9 tc 1e-3, N = 20000, phi 0.3, t = 2",
     {"method": "ed", "dimensions": 2, "particles": {"count": 20000, "volume_fraction": 0.3},
      "collisions": {"restitution": 0.9, "tc": 1e-3}, "run": {"seed": 1, "until": {"time": 2}},
      "output": {"every": {"time": 1}}}),
]
def run(path, split):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([engine, "run", path] + (["--split"] if split else []), check=True,
                         capture_output=True, text=True).stdout
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return json.loads(out.strip().splitlines()[-1])["collisions"] / cpu
print("| scene | split / serial, collisions per CPU second (median) | the 5 ratios |")
print("|---|---|---|")
for label, sc in scenes:
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(sc, f)
    ratios = []
    for r in range(5):
        if r % 2 == 0:
            a = run(f.name, False); b = run(f.name, True)
        else:
            b = run(f.name, True); a = run(f.name, False)
        ratios.append(b / a)
    os.unlink(f.name)
    ratios.sort()
    print("| %s | %.3f | %s |" % (label, ratios[2], ", ".join("%.3f" % x for x in ratios)))
PY
