#!/bin/sh
# Angle of repose of md (issue 18): a 2D heap of frictional disks against the friction mu, with and without rolling
# resistance mu_r, over seeds. The heap: N polydisperse disks (d 0.8-1, m 1) released from rest (temperature 0.01)
# from a column (lattice, 20 wide and 15 tall) onto the floor of a 100 x 60 box, g = 1, e = 0.3, k_n = 2e4
# (the static overlap at the foot of the heap < 1e-3 d), until t = 40 (kinetic energy then < 1e-10 m g d per
# grain with rolling resistance; without it disks that reached the floor may still roll on). The angle: the
# surface profile h(x) (observable surface_profile, 50 bins of 2) at t = 40, the bins whose height is between 20%
# and 80% of the apex fitted by h = a - tan(theta) |x - x_c| (x_c the grains' mean x), both flanks together.
# usage: bench/md_repose.sh [ENGINE]   (default engine/granular-engine; prints a markdown table)
# environment: MUS (default "0.1 0.3 0.6 1.0"), MURS (rolling_friction values, default "0 0.2"), SEEDS (default
# "1 2 3"), N (grains, default 300), JOBS (runs at a time, default 2), RAW=1: one line "mu mu_r angle..." per setting.
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
engine=${1:-$here/engine/granular-engine}
exec /usr/bin/python3 - "$engine" <<'PY'
import json, math, os, subprocess, sys, tempfile, time
from concurrent.futures import ThreadPoolExecutor

engine = sys.argv[1]
mus = [float(x) for x in os.environ.get("MUS", "0.1 0.3 0.6 1.0").split()]
murs = [float(x) for x in os.environ.get("MURS", "0 0.2").split()]
seeds = [int(x) for x in os.environ.get("SEEDS", "1 2 3").split()]
n = int(os.environ.get("N", "300"))
jobs = int(os.environ.get("JOBS", "2"))
raw = os.environ.get("RAW") == "1"

def scene(mu, mur, seed):
    md = {"stiffness": 20000, "impact_speed": 8, "friction": mu}
    if mur > 0:
        md["rolling_friction"] = mur
    return {"method": "md", "dimensions": 2,
            "particles": {"species": [{"count": n, "radius_range": [0.4, 0.5], "mass": 1}], "box": [100, 60],
                          "initial": {"positions": "lattice", "temperature": 0.01,
                                      "region": {"lower": [40, 0.5], "upper": [60, 15.5]}}},
            "boundaries": {"x": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}},
                           "y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
            "collisions": {"restitution": 0.3}, "gravity": [0, -1],
            "run": {"seed": seed, "until": {"time": 40}},
            "output": {"every": {"time": 10}, "observables": ["kinetic_energy", "surface_profile"],
                       "surface_profile": {"bins": 50}},
            "md": md}

def angle(d):
    c = [json.loads(l) for l in open(d + "/observables.jsonl")][-1]
    t = c["tables"][0]
    xs, h, cnt = t["centres"], t["columns"]["h"], t["columns"]["n"]
    xc = sum(x * k for x, k in zip(xs, cnt)) / sum(cnt)
    hm = max(v for v in h if v is not None)
    pts = [(abs(x - xc), v) for x, v in zip(xs, h) if v is not None and 0.2 * hm <= v <= 0.8 * hm]
    m = len(pts)
    if m < 3:
        return float("nan"), hm
    sx = sum(p[0] for p in pts); sy = sum(p[1] for p in pts)
    sxx = sum(p[0] ** 2 for p in pts); sxy = sum(p[0] * p[1] for p in pts)
    b = -(m * sxy - sx * sy) / (m * sxx - sx * sx)
    return math.degrees(math.atan(b)), hm

def one(args):
    mu, mur, seed, tmp = args
    d = os.path.join(tmp, "%g-%g-%d" % (mu, mur, seed))
    json.dump(scene(mu, mur, seed), open(d + ".json", "w"))
    t0 = os.times()
    subprocess.run([engine, "run", d + ".json", "--out", d], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    prog = [json.loads(l) for l in open(d + "/progress.jsonl")]
    ke = prog[-1]["kinetic_energy"] / n
    a, hm = angle(d)
    return mu, mur, seed, a, hm, ke, prog[-1].get("wall_seconds", 0.0)

with tempfile.TemporaryDirectory() as tmp:
    work = [(mu, mur, s, tmp) for mur in murs for mu in mus for s in seeds]
    with ThreadPoolExecutor(max_workers=jobs) as ex:
        res = list(ex.map(one, work))
if not raw:
    print("| mu | mu_r | angle (deg), seeds %s | mean ± sd | apex h | max E_kin/N at t = 40 | wall s per run |"
          % " ".join(map(str, seeds)))
    print("|---|---|---|---|---|---|---|")
for mur in murs:
    for mu in mus:
        rs = [r for r in res if r[0] == mu and r[1] == mur]
        a = [r[3] for r in rs]
        mean = sum(a) / len(a)
        sd = math.sqrt(sum((x - mean) ** 2 for x in a) / (len(a) - 1)) if len(a) > 1 else float("nan")
        if raw:
            print(mu, mur, " ".join("%.4f" % x for x in a))
        else:
            print("| %g | %g | %s | %.1f ± %.1f | %.1f | %.1e | %.1f |" % (mu, mur, " ".join("%.1f" % x for x in a),
                  mean, sd, sum(r[4] for r in rs) / len(rs), max(r[5] for r in rs), sum(r[6] for r in rs) / len(rs)))
PY
