#!/bin/sh
# The engine's H5MD output read back with h5py, h5dump, an XML parser and MDAnalysis (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/h5md_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
skip() { n=$((n + 1)); echo "ok $n # SKIP $1"; }

if ! "$PY" -c 'import h5py, numpy' 2>/dev/null; then
	echo "1..0 # SKIP python3-h5py not installed (./quickstart installs it)"
	exit 0
fi

cat >"$tmp/3d.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":300,"volume_fraction":0.2,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.0001},"run":{"seed":11,"until":{"time":1.0}},
 "output":{"every":{"time":0.05},
   "observables":["kinetic_energy","temperature","pressure","compressibility","collision_rate","clusters","momentum"],
   "snapshots":{"every":{"time":0.25},"compression":4}}}
JSON
cat >"$tmp/2d.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.7},
 "run":{"seed":12,"until":{"collisions_per_particle":20}},
 "output":{"every":{"collisions_per_particle":2},"snapshots":{"every":{"collisions_per_particle":5},"compression":0}}}
JSON
# The Monte Carlo methods write the same layout (particle identity kept through their cell sorts).
cat >"$tmp/2d-dsmc.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":2000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":13,"until":{"time":10}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","temperature","pressure","collision_rate","clusters","momentum"],
   "snapshots":{"every":{"time":2.5}}}}
JSON
cat >"$tmp/3d-hsmc.json" <<'JSON'
{"method":"hsmc","dimensions":3,"particles":{"count":1500,"volume_fraction":0.3},
 "collisions":{"restitution":0.8},"run":{"seed":14,"until":{"collisions_per_particle":20}},
 "output":{"every":{"collisions_per_particle":2},"snapshots":{"every":{"collisions_per_particle":5},"compression":1}}}
JSON
cat >"$tmp/nosnap.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":100,"volume_fraction":0.3},
 "run":{"until":{"time":2}},"output":{"observables":["temperature"]}}
JSON

for s in 3d 2d nosnap 2d-dsmc 3d-hsmc; do
	"$ENGINE" run "$tmp/$s.json" --out "$tmp/$s" >"$tmp/$s.out" 2>"$tmp/$s.err"
	rc=$?
	[ $rc -eq 0 ] && [ -s "$tmp/$s/trajectory.h5" ] && [ -s "$tmp/$s/trajectory.xdmf" ] && [ -s "$tmp/$s/progress.jsonl" ]
	ok $? "$s: exit $rc, trajectory.h5, trajectory.xdmf and progress.jsonl written $(head -c 200 "$tmp/$s.err")"
done

# Layout and values, with h5py.
for s in 3d 2d nosnap 2d-dsmc 3d-hsmc; do
	"$PY" - "$tmp/$s/trajectory.h5" "$tmp/$s.json" "$tmp/$s/progress.jsonl" >"$tmp/check.$s" 2>&1 <<'PYEOF'
import json, sys
import h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
scene = json.load(open(sys.argv[2]))
prog = [json.loads(l) for l in open(sys.argv[3]) if '"progress"' in l]
D, N = scene["dimensions"], scene["particles"]["count"]
def check(cond, what):
    if not cond:
        raise SystemExit("FAILED: " + what)
# /h5md
check(list(f["h5md"].attrs["version"]) == [1, 1], "h5md version [1,1]")
check(f["h5md/author"].attrs["name"] == b"granulard" or f["h5md/author"].attrs["name"] == "granulard", "author name")
check(f["h5md/creator"].attrs["name"] in (b"granular-engine", "granular-engine"), "creator name")
check(len(f["h5md/creator"].attrs["version"]) > 0, "creator version")
check(list(f["h5md/modules/units"].attrs["version"]) == [1, 0], "units module")
# box
box = f["particles/all/box"]
check(int(box.attrs["dimension"]) == D, "box dimension")
check([b.decode() if isinstance(b, bytes) else b for b in box.attrs["boundary"]] == ["periodic"] * D, "boundary")
E = box["edges/value"][()]
check(E.ndim == 3 and E.shape[1:] == (D, D), "edges: time-dependent [frames][D][D]")
edges = np.diag(E[0])
check(np.all(edges > 0) and all(np.array_equal(e, np.diag(edges)) for e in E), "edges: constant diagonal box")
check(box["edges/step"].id == f["particles/all/position/step"].id, "edges share position's step")
vol = float(np.prod(edges))
# frames
pos, vel = f["particles/all/position"], f["particles/all/velocity"]
P, V = pos["value"][()], vel["value"][()]
check(P.shape[1:] == (N, D) and V.shape == P.shape, "position/velocity value [frames][N][D]")
check(pos["value"].maxshape[0] is None and pos["value"].chunks is not None, "frames chunked, unlimited")
check(pos["step"].id == vel["step"].id or np.array_equal(pos["step"][()], vel["step"][()]), "velocity shares step")
check(np.all(P >= 0) and np.all(P < edges), "positions folded into the box")
ft, fs = pos["time"][()], pos["step"][()]
check(len(ft) == P.shape[0] and np.all(np.diff(ft) > 0) and np.all(np.diff(fs) >= 0), "frame time increasing, step non-decreasing")
check(ft[0] == 0.0, "first frame at time 0")
check("unit" not in pos["value"].attrs and "unit" not in pos["time"].attrs, "no unit attributes under /particles (MDAnalysis)")
check(f["h5md/modules/units"].attrs["system"] in (b"granulard-reduced", "granulard-reduced"), "units system")
check(f["particles/all/diameter"].shape == (N,) and f["particles/all/mass"].shape == (N,), "diameter and mass [N]")
# observables
obs = f["observables"]
t = obs["collision_count/time"][()]
check(obs["collision_count/time"].attrs["unit"] in (b"t0", "t0"), "observable time unit t0")
st = obs["collision_count/step"][()]
check(len(t) == len(prog) and np.all(np.diff(t) >= 0) and np.all(np.diff(st) >= 0), "observable time/step monotone, one row per progress line")
check(np.array_equal(t, [p["time"] for p in prog]), "observable times equal the progress stream's")
check(np.array_equal(obs["collision_count/value"][()], [p["collisions"] for p in prog]), "collision_count")
want = set(scene.get("output", {}).get("observables", ["kinetic_energy", "temperature", "pressure", "compressibility", "collision_rate"]))
for name in want - {"clusters"}:
    check(name in obs and obs[name + "/value"].shape[0] == len(t), "observable " + name)
    check(obs[name]["time"].id == obs["collision_count/time"].id, name + " time hard-linked")
if "temperature" in want:
    check(np.array_equal(obs["temperature/value"][()], [p["temperature"] for p in prog]), "temperature equals the progress stream's")
if "kinetic_energy" in want:
    ek = obs["kinetic_energy/value"][()]
    check(ek.dtype == np.float64 and np.allclose(ek * N, [p["kinetic_energy"] for p in prog], rtol=1e-15, atol=0), "kinetic_energy per particle")
    # the stored E_kin equals the one from the stored velocities at the same times
    m = f["particles/all/mass"][0]
    both = 0
    for k, tk in enumerate(ft):
        rows = np.nonzero(t == tk)[0]
        if len(rows):
            e = 0.5 * m * np.sum(V[k] ** 2) / N
            check(abs(e - ek[rows[-1]]) <= 1e-12 * e, "E_kin from velocities at t=%g" % tk)
            both += 1
    check(both >= 2, "frames and observables share times")
if "momentum" in want:
    check(obs["momentum/value"].shape == (len(t), D), "momentum [rows][D]")
if "pressure" in want:
    p = obs["pressure/value"][()]
    check(np.isnan(p[0]) and np.all(np.isfinite(p[1:])), "pressure NaN at the first row only")
    check(obs["pressure/value"].attrs["unit"] in (b"e0 l0-%d" % D, "e0 l0-%d" % D), "pressure unit")
if "clusters" in want:
    for k in ("count", "largest", "largest_fraction", "mean_size", "m2", "m2_reduced", "histogram"):
        check(("clusters_" + k) in obs, "clusters_" + k)
    h = obs["clusters_histogram/value"][()]
    check(np.array_equal(h.sum(axis=1), obs["clusters_count/value"][()]), "histogram sums to the cluster count")
# parameters
txt = f["parameters/scene"][()]
txt = txt.decode() if isinstance(txt, bytes) else txt
check(json.loads(txt) == scene and txt == open(sys.argv[2]).read(), "scene stored verbatim")
check(int(f["parameters"].attrs["particles"]) == N, "parameters particles")
# without output.snapshots: first and last state only
if "snapshots" not in scene.get("output", {}):
    check(P.shape[0] == 2 and ft[-1] == t[-1], "first and last frame only")
print("N=%d D=%d frames=%d rows=%d" % (N, D, P.shape[0], len(t)))
PYEOF
	ok $? "$s: H5MD layout, units, values ($(tail -n 1 "$tmp/check.$s"))"
done

# h5dump can read every object.
h5dump "$tmp/3d/trajectory.h5" >"$tmp/dump" 2>&1
rc=$?
[ $rc -eq 0 ] && grep -q 'GROUP "h5md"' "$tmp/dump" && grep -q 'DATASET "value"' "$tmp/dump"
ok $? "h5dump reads the whole file (exit $rc)"

# XDMF: well-formed; every referenced dataset exists with the stated shape.
for s in 3d 2d 2d-dsmc 3d-hsmc; do
	"$PY" - "$tmp/$s" >"$tmp/x.$s" 2>&1 <<'PYEOF'
import os, sys
import xml.etree.ElementTree as ET
import h5py
d = sys.argv[1]
root = ET.parse(os.path.join(d, "trajectory.xdmf")).getroot()
col = root.find("Domain/Grid")
assert col.get("CollectionType") == "Temporal", "temporal collection"
grids = col.findall("Grid")
f = h5py.File(os.path.join(d, "trajectory.h5"), "r")
times = f["particles/all/position/time"][()]
assert len(grids) == len(times), "one grid per frame"
for k, g in enumerate(grids):
    assert float(g.find("Time").get("Value")) == times[k], "frame time"
    assert g.find("Topology").get("TopologyType") == "Polyvertex"
    for item in g.iter("DataItem"):
        if item.get("Format") == "HDF":
            fn, path = item.text.strip().split(":")
            ds = h5py.File(os.path.join(d, fn), "r")[path]
            assert " ".join(map(str, ds.shape)) == item.get("Dimensions"), (ds.shape, item.get("Dimensions"))
        if item.get("Format") == "XML":
            start = int(item.text.split()[0])
            assert start == k, "hyperslab selects frame k"
print(len(grids), "frames")
PYEOF
	ok $? "$s: trajectory.xdmf well-formed, datasets exist ($(tail -n 1 "$tmp/x.$s"))"
done

# ParaView's XDMF reader (when installed: paraview + python3-paraview, not
# installed by ./quickstart) sees every frame at its time with the stored
# positions and velocities.
if command -v pvbatch >/dev/null 2>&1 && pvbatch -c 'import paraview.simple' >/dev/null 2>&1; then
	for s in 3d 2d; do
		cat >"$tmp/pv.py" <<'PYEOF'
import sys
import h5py, numpy as np
from paraview.simple import XDMFReader, servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy
d = sys.argv[1]
f = h5py.File(d + "/trajectory.h5", "r")
P, V = f["particles/all/position/value"][()], f["particles/all/velocity/value"][()]
T = f["particles/all/position/time"][()]
r = XDMFReader(FileNames=[d + "/trajectory.xdmf"])
r.UpdatePipelineInformation()
assert np.array_equal(np.array(r.TimestepValues), T), "frame times"
D = P.shape[2]
for k, t in enumerate(T):
    r.UpdatePipeline(t)
    g = servermanager.Fetch(r)
    g = g.GetBlock(0) if g.IsA("vtkMultiBlockDataSet") else g
    pts = vtk_to_numpy(g.GetPoints().GetData())
    vel = vtk_to_numpy(g.GetPointData().GetArray("velocity"))
    assert np.array_equal(pts[:, :D], P[k]) and np.array_equal(vel[:, :D], V[k]), "frame %d" % k
print("ParaView read %d frames of %d points" % (len(T), P.shape[1]))
PYEOF
		pvbatch "$tmp/pv.py" "$tmp/$s" >"$tmp/pv.$s" 2>&1
		ok $? "$s: ParaView XDMF reader: $(grep -v '^$' "$tmp/pv.$s" | tail -n 1)"
	done
else
	skip "ParaView (pvbatch, python3-paraview) not installed: XDMF not opened in ParaView"
	skip "ParaView not installed"
fi

# MDAnalysis reads the 3D trajectory (its H5MD reader takes 3D periodic boxes only).
if "$PY" -c 'import MDAnalysis' 2>/dev/null; then
	"$PY" -W ignore - "$tmp/3d/trajectory.h5" >"$tmp/mda" 2>&1 <<'PYEOF'
import sys, warnings
import numpy as np
import h5py
import MDAnalysis as mda
from MDAnalysis.coordinates.H5MD import H5MDReader
f = h5py.File(sys.argv[1], "r")
P = f["particles/all/position/value"][()]
N = P.shape[1]
u = mda.Universe.empty(N, trajectory=True)
u.load_new(sys.argv[1], format=H5MDReader, convert_units=False)
assert len(u.trajectory) == P.shape[0], "frame count"
for k, ts in enumerate(u.trajectory):
    assert np.allclose(ts.positions, P[k], rtol=1e-6, atol=1e-5), "positions frame %d" % k
    assert np.allclose(ts.dimensions[:3], np.diag(f["particles/all/box/edges/value"][k]), rtol=1e-6), "box"
    assert ts.has_velocities
print("MDAnalysis %s read %d frames of %d particles" % (mda.__version__, len(u.trajectory), N))
PYEOF
	ok $? "MDAnalysis H5MD reader: $(tail -n 1 "$tmp/mda")"
else
	skip "python3-mdanalysis not installed"
fi

# Ensembles: --out writes progress.jsonl and the observables (the means of
# the progress stream); without output.snapshots no frames and no XDMF;
# without a checkpoint --resume has nothing to continue from (exit 2).
for f in 2d-ed-replicas.json 2d-dsmc-replicas.json; do
	d="$tmp/other-${f%.json}"
	"$ENGINE" run "$SRCDIR/tests/scenes/good/$f" --out "$d" >"$d.out" 2>"$d.err"
	rc=$?
	"$PY" - "$d" "$d.out" >"$d.py" 2>&1 <<'PYEOF'
import json, os, sys
import h5py, numpy as np
d, out = sys.argv[1], sys.argv[2]
lines = [json.loads(l) for l in open(out)]
prog = [l for l in lines if l["type"] == "progress"]
assert lines[-1]["type"] == "summary" and lines[-1]["status"] == "completed", "summary"
assert open(os.path.join(d, "progress.jsonl")).read() == open(out).read(), "progress.jsonl is a copy"
assert not os.path.exists(os.path.join(d, "trajectory.xdmf")), "no XDMF without frames"
assert not os.path.exists(os.path.join(d, "checkpoint.h5")), "no checkpoint"
with h5py.File(os.path.join(d, "trajectory.h5"), "r") as h:
    t = h["observables/temperature/time"][:]
    T = h["observables/temperature/value"][:]
    assert len(t) == len(prog), "one observable row per progress line (%d, %d)" % (len(t), len(prog))
    assert np.array_equal(t, [p["time"] for p in prog]), "times"
    assert np.array_equal(T, [p["temperature"] for p in prog]), "temperatures"
    pos = h.get("particles/all/position/value")
    assert pos is None or pos.shape[0] == 0, "no frames"
print("%d observable rows, no frames" % len(t))
PYEOF
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "$f --out: exit $rc, $(tail -n 1 "$d.py")"
	"$ENGINE" run "$SRCDIR/tests/scenes/good/$f" --out "$d" --resume "$d/checkpoint.h5" >/dev/null 2>"$d.err"
	rc=$?
	ok $(( rc == 2 ? 0 : 1 )) "$f --resume without a checkpoint: exit $rc, $(tail -n 1 "$d.err")"
done

# Ensemble standard errors in the file: with 2 replicas the sample standard
# error of the mean is |x0 - x1| / 2 = |mean - x0|, and replica 0 (random
# stream 0) is the single run of the same scene, so the stored NAME_se can be
# checked against an independent single run.
for f in 2d-ed-replicas.json 2d-dsmc-replicas.json; do
	d="$tmp/se-${f%.json}"
	mkdir -p "$d"
	"$PY" - "$SRCDIR/tests/scenes/good/$f" "$d" <<'PYEOF'
import json, sys
s = json.load(open(sys.argv[1]))
s["run"]["replicas"] = 2
json.dump(s, open(sys.argv[2] + "/r2.json", "w"))
s["run"]["replicas"] = 1
json.dump(s, open(sys.argv[2] + "/r1.json", "w"))
PYEOF
	"$ENGINE" run "$d/r2.json" --out "$d/r2" >/dev/null 2>"$d.err" && "$ENGINE" run "$d/r1.json" --out "$d/r1" >/dev/null 2>>"$d.err"
	rc=$?
	"$PY" - "$d" >"$d.py" 2>&1 <<'PYEOF'
import json, sys
import h5py, numpy as np
d = sys.argv[1]
e, one = h5py.File(d + "/r2/trajectory.h5", "r")["observables"], h5py.File(d + "/r1/trajectory.h5", "r")["observables"]
prog = [json.loads(l) for l in open(d + "/r2/progress.jsonl") if '"progress"' in l]
checked = 0
for name in ("temperature", "kinetic_energy", "pressure", "compressibility", "collision_rate",
             "clusters_largest_fraction", "clusters_mean_size"):
    if name not in e:
        continue
    m, se, x0 = e[name + "/value"][()], e[name + "_se/value"][()], one[name + "/value"][()]
    assert e[name + "_se/time"].id == e[name + "/time"].id, name + "_se shares time"
    assert len(m) == len(se) == len(x0) == len(prog), name + ": rows"
    ok = np.isnan(m) == np.isnan(se)
    want = np.abs(m - x0)
    fin = ~np.isnan(m)
    assert ok.all() and np.allclose(se[fin], want[fin], rtol=1e-9, atol=1e-13 * np.abs(m[fin]).max()), \
        "%s: stored SE %s, |mean - replica 0| %s" % (name, se[fin][:3], want[fin][:3])
    assert np.any(se[fin] > 0), name + ": some SE > 0"
    key = {"clusters_largest_fraction": None, "clusters_mean_size": None}.get(name, name)
    if key:
        p = np.array([np.nan if q[key + "_se"] is None else q[key + "_se"] for q in prog], dtype=float)
        scale = len(prog) and (h5py.File(d + "/r2/trajectory.h5", "r")["parameters"].attrs["particles"] if name == "kinetic_energy" else 1)
        assert np.array_equal(np.isnan(p), np.isnan(se)) and np.all(se[fin] == p[fin] / scale), name + "_se equals the progress stream's"
    checked += 1
assert "time_se" in e and checked >= 3
print("%d observables: NAME_se = |mean - replica 0| (2 replicas), = progress KEY_se" % checked)
PYEOF
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "$f, 2 replicas: $(tail -n 1 "$d.py") $(head -c 200 "$d.err")"
done

# Ensemble frames (output.snapshots with run.replicas = 2): particles/replica_K
# per replica, taken at output times. With the snapshot interval a multiple
# of output.every, replica 0 (random stream 0) must give bit for bit the
# frames of the single run of the same scene, and the file must not depend
# on the number of ranks. ed with a time schedule, dsmc with a collision
# schedule (replica frame times then differ).
cat >"$tmp/ens-ed.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"volume_fraction":0.3},"collisions":{"restitution":0.9},
 "run":{"seed":21,"until":{"time":2},"replicas":2},
 "output":{"every":{"time":0.1},"observables":["temperature"],"snapshots":{"every":{"time":0.5}}}}
JSON
cat >"$tmp/ens-dsmc.json" <<'JSON'
{"method":"dsmc","dimensions":3,"particles":{"count":1000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.8},"run":{"seed":22,"until":{"collisions_per_particle":12},"replicas":2},
 "output":{"every":{"collisions_per_particle":1},"observables":["temperature"],
   "snapshots":{"every":{"collisions_per_particle":3},"compression":1}}}
JSON
for s in ens-ed ens-dsmc; do
	sed 's/"replicas":2/"replicas":1/' "$tmp/$s.json" >"$tmp/$s-single.json"
	"$ENGINE" run "$tmp/$s.json" --out "$tmp/$s.np1" >/dev/null 2>"$tmp/$s.err" &&
		"$ENGINE" run "$tmp/$s-single.json" --out "$tmp/$s.single" >/dev/null 2>>"$tmp/$s.err"
	rc=$?
	np2=
	if command -v mpirun >/dev/null 2>&1; then
		mpirun -np 2 "$ENGINE" run "$tmp/$s.json" --out "$tmp/$s.np2" >/dev/null 2>>"$tmp/$s.err" || rc=1
		np2="$tmp/$s.np2"
	fi
	"$PY" - "$tmp/$s" "$tmp/$s.json" $np2 >"$tmp/$s.py" 2>&1 <<'PYEOF'
import json, os, sys
import xml.etree.ElementTree as ET
import h5py, numpy as np
base, scene = sys.argv[1], json.load(open(sys.argv[2]))
N, D, R = scene["particles"]["count"], scene["dimensions"], scene["run"]["replicas"]
e, one = h5py.File(base + ".np1/trajectory.h5", "r"), h5py.File(base + ".single/trajectory.h5", "r")
assert sorted(e["particles"]) == ["replica_%d" % k for k in range(R)], list(e["particles"])
sub = ["position/value", "velocity/value", "position/time", "position/step", "box/edges/value", "diameter", "mass"]
for k in sub:
    a, b = e["particles/replica_0/" + k][()], one["particles/all/" + k][()]
    assert a.shape == b.shape and a.tobytes() == b.tobytes(), "replica_0 %s differs from the single run" % k
g1 = e["particles/replica_1"]
assert g1["position/step"].id == g1["velocity/step"].id and g1["box/edges/time"].id == g1["position/time"].id, "hard links"
P0, P1 = e["particles/replica_0/position/value"][()], g1["position/value"][()]
assert P1.shape[1:] == (N, D) and not np.array_equal(P0[-1], P1[-1]), "replica 1 is another replica"
assert np.all(P1 >= 0) and np.all(P1 < np.diag(g1["box/edges/value"][0])), "replica 1 folded into the box"
# frames at output times: every frame time is an observable row time of that replica's schedule
t_obs = e["observables/collision_count/time"][()]
for r in range(R):
    ft = e["particles/replica_%d/position/time" % r][()]
    assert ft[0] == 0 and np.all(np.diff(ft) > 0) and len(ft) >= 4, "replica %d frame times %s" % (r, ft)
    if "time" in scene["output"]["every"]:
        assert set(ft) <= set(t_obs), "frames at output times"
# the XDMF: one temporal collection per replica, every frame, datasets of the right shape
root = ET.parse(base + ".np1/trajectory.xdmf").getroot()
cols = root.findall("Domain/Grid")
assert [c.get("Name") for c in cols] == ["replica_%d" % r for r in range(R)], "one collection per replica"
for r, c in enumerate(cols):
    assert c.get("CollectionType") == "Temporal"
    ft = e["particles/replica_%d/position/time" % r][()]
    grids = c.findall("Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == list(ft), "replica %d frame times" % r
    for item in c.iter("DataItem"):
        if item.get("Format") == "HDF":
            fn, path = item.text.strip().split(":")
            assert path.startswith("/particles/replica_%d/" % r), path
            assert " ".join(map(str, e[path].shape)) == item.get("Dimensions")
# the same file content from 2 ranks
if len(sys.argv) > 3:
    m = h5py.File(sys.argv[3] + "/trajectory.h5", "r")
    na, nb = [], []
    e.visititems(lambda n, o: na.append(n) if isinstance(o, h5py.Dataset) else None)
    m.visititems(lambda n, o: nb.append(n) if isinstance(o, h5py.Dataset) else None)
    assert sorted(na) == sorted(nb), "dataset lists under 1 and 2 ranks"
    for n in na:
        assert e[n][()].tobytes() == m[n][()].tobytes(), "%s differs under mpirun -np 2" % n
    assert open(base + ".np1/trajectory.xdmf").read() == open(sys.argv[3] + "/trajectory.xdmf").read(), "XDMF"
print("%d replicas, frames %s; replica 0 = single run%s" % (R, [len(e["particles/replica_%d/position/time" % r]) for r in range(R)],
      ", 1 and 2 ranks identical" if len(sys.argv) > 3 else ""))
PYEOF
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "$s: ensemble frames: $(tail -n 1 "$tmp/$s.py") $(head -c 200 "$tmp/$s.err")"
done

# Particle identity in dsmc/hsmc frames (the engines re-sort particles into
# cells every step): with frames after every time step, a particle's move is
# its free flight, x(k+1) = x(k) + v(k) dt folded into the box, because a
# step streams first and collides after. dsmc (no CBA offsets) must satisfy
# this for every particle. hsmc with its CBA offsets: for every particle
# whose velocity did not change in the step (no collision: an elastic
# collision always changes it) exactly, and such particles must be most of
# them (about 2% collide per step at 0.05 collisions per particle per step).
# hsmc cells of 10 diameters at volume fraction 0.05 are never full (0.82),
# so no move is rejected (checked in the summary). A shuffled index would
# break this for almost every particle.
cat >"$tmp/id-dsmc.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":2000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":1},"run":{"seed":31,"until":{"time":1}},
 "output":{"every":{"time":0.0625},"observables":["temperature"],"snapshots":{"every":{"time":0.0625}}},
 "dsmc":{"time_step":0.0625}}
JSON
cat >"$tmp/id-hsmc.json" <<'JSON'
{"method":"hsmc","dimensions":3,"particles":{"count":2000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":1},"run":{"seed":32,"until":{"time":1}},
 "output":{"every":{"time":0.0625},"observables":["temperature"],"snapshots":{"every":{"time":0.0625}}},
 "hsmc":{"time_step":0.0625,"cell_size":10}}
JSON
for s in id-dsmc id-hsmc; do
	"$ENGINE" run "$tmp/$s.json" --out "$tmp/$s" >"$tmp/$s.out" 2>"$tmp/$s.err"
	rc=$?
	"$PY" - "$tmp/$s" "$tmp/$s.out" >"$tmp/$s.py" 2>&1 <<'PYEOF'
import json, sys
import h5py, numpy as np
f = h5py.File(sys.argv[1] + "/trajectory.h5", "r")
summary = json.loads(open(sys.argv[2]).read().splitlines()[-1])
assert summary.get("rejected_moves", 0) == 0, "no rejected moves"
g = f["particles/all"]
P, V, T = g["position/value"][()], g["velocity/value"][()], g["position/time"][()]
L = np.diag(g["box/edges/value"][0])
method = f["parameters"].attrs["method"]
method = method.decode() if isinstance(method, bytes) else method
assert len(T) == 17 and np.allclose(np.diff(T), 0.0625, rtol=0, atol=1e-12), "a frame after every step: %s" % T
worst, unchanged = 0.0, []
for k in range(len(T) - 1):
    d = P[k + 1] - P[k] - V[k] * (T[k + 1] - T[k])
    d -= L * np.round(d / L)                      # box wrapping
    err = np.abs(d).max(axis=1)
    same_v = np.all(V[k + 1] == V[k], axis=1)
    unchanged.append(same_v.mean())
    if method == "dsmc":
        worst = max(worst, err.max())
    else:
        worst = max(worst, err[same_v].max())
        # a collided particle's CBA offset is one diameter per collision
        assert err.max() < 4 * f["particles/all/diameter"][0], "step %d: a jump of %g" % (k, err.max())
assert worst < 1e-9 * L.max(), "free flight violated by %g" % worst
assert min(unchanged) > 0.9, "fraction without collision per step %s" % min(unchanged)
print("%s: %d frames, |x(k+1) - x(k) - v(k) dt| <= %.1e, %.3f of the particles without collision per step"
      % (method, len(T), worst, np.mean(unchanged)))
PYEOF
	ok $(( rc == 0 && $? == 0 ? 0 : 1 )) "$s: index i is one particle in every frame: $(tail -n 1 "$tmp/$s.py") $(head -c 200 "$tmp/$s.err")"
done

echo "1..$n"
[ $failed -eq 0 ]
