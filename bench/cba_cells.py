#!/usr/bin/python3
"""The CBA offset's pressure against the cell size (issue 13): dsmc and hsmc with correction "cba" in a periodic
2D box of 4000 disks at volume fraction 0.3, elastic, t = 10..60 (about 150 collisions per particle), one seed.
Prints the compressibility Z from the collision virial (mean and standard error of 51 samples one time unit
apart; successive samples are nearly independent at ~3 collisions per particle between them) against
Henderson's Z for cells of 2, 3, 4, 6 diameters and the default. By hand: `bench/cba_cells.py engine/granular-engine`.
"""
import json, math, os, statistics, subprocess, sys, tempfile

ENGINE = sys.argv[1]
NU = 0.3


def run(scene):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        json.dump(scene, fh)
    try:
        p = subprocess.run([ENGINE, "run", fh.name], capture_output=True, text=True)
    finally:
        os.unlink(fh.name)
    if p.returncode:
        raise SystemExit("engine failed: " + p.stderr.strip()[:300])
    return [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{")]


print("| method | cell (diameters) | Z (virial) | Henderson Z | Z / Henderson - 1 |")
print("|---|---|---|---|---|")
zh = (1 + NU * NU / 8) / (1 - NU) ** 2
for method in ("dsmc", "hsmc"):
    for cell in (2, 3, 4, 6, None):
        mc = {"correction": "cba"}
        if cell:
            mc["cell_size"] = cell
        s = {"method": method, "dimensions": 2,
             "particles": {"count": 4000, "volume_fraction": NU, "initial": {"positions": "random", "temperature": 1}},
             "run": {"seed": 1, "until": {"time": 60}},
             "output": {"every": {"time": 1}, "observables": ["compressibility"]}, method: mc}
        z = [r["compressibility"] for r in run(s) if r.get("type") == "progress" and r["time"] >= 10]
        m, se = statistics.fmean(z), statistics.stdev(z) / math.sqrt(len(z))
        print("| %s | %s | %.4f +- %.4f | %.4f | %+.3f |" % (method, cell or "default", m, se, zh, m / zh - 1))
