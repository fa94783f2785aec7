#!/bin/sh
# Method md (issue 18): checkpoints and exact --resume through the real program, SIGTERM, ensembles (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/md_resume_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()

if ! "$PY" -c 'import h5py, numpy' 2>/dev/null; then
	echo "1..0 # SKIP python3-h5py not installed (./quickstart installs it)"
	exit 0
fi

# same A B: every dataset of the two trajectories bit for bit and the two progress streams line for line
# (wall-clock fields aside), as tests/resume_test.sh compares them. Prints why not.
cat >"$tmp/same.py" <<'PYEOF'
import json, sys
import h5py, numpy as np
a, b = sys.argv[1], sys.argv[2]
fa, fb = h5py.File(a + "/trajectory.h5", "r"), h5py.File(b + "/trajectory.h5", "r")
na, nb, bad = [], [], []
fa.visititems(lambda name, o: na.append(name) if isinstance(o, h5py.Dataset) else None)
fb.visititems(lambda name, o: nb.append(name) if isinstance(o, h5py.Dataset) else None)
if sorted(na) != sorted(nb):
    bad.append("dataset lists differ")
for name in na:
    x, y = fa[name][()], fb[name][()]
    if isinstance(x, np.ndarray):
        if x.shape != y.shape or x.tobytes() != y.tobytes():
            bad.append(name)
    elif x != y:
        bad.append(name)
def lines(d):
    out = []
    for l in open(d + "/progress.jsonl"):
        r = json.loads(l)
        for k in ("wall_seconds", "events_per_second", "collisions_per_second"):
            r.pop(k, None)
        out.append(json.dumps(r, sort_keys=True))
    return out
la, lb = lines(a), lines(b)
if la != lb:
    bad.append("progress.jsonl (%d vs %d lines)" % (len(la), len(lb)))
if bad:
    print("differ: " + ", ".join(bad[:6]))
    sys.exit(1)
frames = sum(g["position/value"].shape[0] for g in fa["particles"].values())
print("%d datasets, %d frames, %d progress lines identical" % (len(na), frames, len(la)))
PYEOF
same() { "$PY" "$tmp/same.py" "$1" "$2"; }
# springs CKPT [GROUP]: the tangential springs held in a checkpoint (the state a resume must carry over)
springs() {
	"$PY" -c 'import h5py, sys; print(int(h5py.File(sys.argv[1], "r")[sys.argv[2] + "springs_held"][()].sum()))' \
		"$1" "${2:-md/}"
}

# Scenes: a 3D frictional bed falling onto a floor (linear law; springs with the floor and between
# spheres, periodic images, Verlet rebuilds), and 2D Hertz disks with friction under gravity; wall_force (the
# walls' impulses since the last record and their forces at the last step are state too).
cat >"$tmp/3d-bed.json" <<'JSON'
{"method": "md", "dimensions": 3,
 "particles": {"count": 300, "volume_fraction": 0.2, "initial": {"temperature": 1}},
 "boundaries": {"z": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "collisions": {"restitution": 0.5}, "gravity": [0, 0, -5],
 "run": {"seed": 5, "until": {"time": 5}},
 "output": {"every": {"time": 0.25}, "observables": ["kinetic_energy", "momentum", "center_of_mass_height", "potential_energy", "wall_force"],
   "snapshots": {"every": {"time": 1}}, "checkpoint": {"every": {"time": 1.9}}},
 "md": {"friction": 0.5}}
JSON
cat >"$tmp/2d-hertz.json" <<'JSON'
{"method": "md", "dimensions": 2,
 "particles": {"count": 200, "volume_fraction": 0.5, "initial": {"temperature": 1}},
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "collisions": {"restitution": 0.8}, "gravity": [0, -10],
 "run": {"seed": 7, "until": {"time": 3}},
 "output": {"every": {"time": 0.2}, "observables": ["kinetic_energy", "momentum", "center_of_mass_height", "wall_force"],
   "snapshots": {"every": {"time": 0.5}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"force_law": "hertz", "friction": 0.3}}
JSON

# 2D frictional disks on a vibrating floor under a lid that moves along x (the walls' motion is a function
# of the step count, which the checkpoint holds)
cat >"$tmp/2d-vibro.json" <<'JSON'
{"method": "md", "dimensions": 2,
 "particles": {"count": 150, "volume_fraction": 0.3, "initial": {"temperature": 1}},
 "boundaries": {"y": {"type": "walls", "lower": {"type": "vibrating", "amplitude": 0.5, "frequency": 2, "phase": 0.3},
   "upper": {"type": "moving", "velocity": [2, 0]}}},
 "collisions": {"restitution": 0.7}, "gravity": [0, -10],
 "run": {"seed": 3, "until": {"time": 3}},
 "output": {"every": {"time": 0.2}, "observables": ["kinetic_energy", "momentum", "center_of_mass_height", "wall_force"],
   "snapshots": {"every": {"time": 0.5}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"friction": 0.4}}
JSON

# a frictional mixture under gravity, one species polydisperse (radii and masses come from the scene)
cat >"$tmp/2d-mix.json" <<'JSON'
{"method": "md", "dimensions": 2,
 "particles": {"species": [{"count": 100, "radius": 0.5, "mass": 1}, {"count": 60, "radius_range": [0.6, 0.9], "mass": 3}],
   "volume_fraction": 0.3, "initial": {"temperature": 1}},
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "collisions": {"restitution": 0.8}, "gravity": [0, -10],
 "run": {"seed": 4, "until": {"time": 3}},
 "output": {"every": {"time": 0.2}, "observables": ["kinetic_energy", "temperature", "momentum", "center_of_mass_height", "wall_force"],
   "snapshots": {"every": {"time": 0.5}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"friction": 0.3}}
JSON

# a periodic frictional gas with the virial pressure (its interval integrals are state: field "virial")
cat >"$tmp/3d-press.json" <<'JSON'
{"method": "md", "dimensions": 3,
 "particles": {"count": 200, "volume_fraction": 0.25, "initial": {"temperature": 1}},
 "collisions": {"restitution": 0.9},
 "run": {"seed": 6, "until": {"time": 3}},
 "output": {"every": {"time": 0.4}, "observables": ["kinetic_energy", "pressure", "compressibility"],
   "snapshots": {"every": {"time": 1}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"friction": 0.3}}
JSON

# frictional disks under gravity around two fixed obstacles (springs held with obstacles; their impulses are state)
cat >"$tmp/2d-obst.json" <<'JSON'
{"method": "md", "dimensions": 2,
 "particles": {"count": 150, "box": [24, 24], "initial": {"temperature": 1}},
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "obstacles": [{"center": [8, 6], "radius": 2, "type": "slip"}, {"center": [17, 4], "radius": 1.5, "type": "slip"}],
 "collisions": {"restitution": 0.7}, "gravity": [0, -10],
 "run": {"seed": 8, "until": {"time": 4.5}},
 "output": {"every": {"time": 0.2}, "observables": ["kinetic_energy", "momentum", "obstacle_force", "wall_force"],
   "snapshots": {"every": {"time": 0.5}}, "checkpoint": {"every": {"time": 2.1}}},
 "md": {"friction": 0.5}}
JSON

# rolling resistance (its rolling springs are state: field "rolling_spring") and a restitution per pair of species,
# 2D disks and 3D spheres under gravity
cat >"$tmp/2d-roll.json" <<'JSON'
{"method": "md", "dimensions": 2,
 "particles": {"species": [{"name": "a", "count": 100, "radius": 0.5, "mass": 1}, {"name": "b", "count": 60, "radius": 0.7, "mass": 2}],
   "volume_fraction": 0.3, "initial": {"temperature": 1}},
 "boundaries": {"y": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "collisions": {"restitution": 0.8, "restitution_pairs": [{"a": "a", "b": "b", "restitution": 0.4}, {"a": "b", "b": "b", "restitution": 0.6}]},
 "gravity": [0, -10],
 "run": {"seed": 9, "until": {"time": 3}},
 "output": {"every": {"time": 0.2}, "observables": ["kinetic_energy", "temperature", "momentum", "rotational_energy", "wall_force"],
   "snapshots": {"every": {"time": 0.5}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"friction": 0.5, "rolling_friction": 0.3}}
JSON
cat >"$tmp/3d-roll.json" <<'JSON'
{"method": "md", "dimensions": 3,
 "particles": {"count": 200, "volume_fraction": 0.2, "initial": {"temperature": 1}},
 "boundaries": {"z": {"type": "walls", "lower": {"type": "specular"}, "upper": {"type": "specular"}}},
 "collisions": {"restitution": 0.5}, "gravity": [0, 0, -5],
 "run": {"seed": 10, "until": {"time": 3}},
 "output": {"every": {"time": 0.25}, "observables": ["kinetic_energy", "momentum", "rotational_energy", "wall_force"],
   "snapshots": {"every": {"time": 1}}, "checkpoint": {"every": {"time": 1.1}}},
 "md": {"force_law": "hertz", "friction": 0.5, "rolling_friction": 0.2}}
JSON

ref() { "$ENGINE" run "$tmp/$1.json" --out "$tmp/$1.ref" >/dev/null 2>"$tmp/$1.ref.err"; }

# (a) checkpoint at a simulated time, resume: identical to the uninterrupted run (frames, records, summary).
for s in 3d-bed 2d-hertz 2d-vibro 2d-mix 3d-press 2d-obst 2d-roll 3d-roll; do
	ref $s
	rc=$?
	for which in checkpoint.prev.h5 checkpoint.h5; do
		rm -rf "$tmp/$s.res"
		cp -r "$tmp/$s.ref" "$tmp/$s.res"
		k=$(springs "$tmp/$s.res/$which")
		"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.res/$which" --out "$tmp/$s.res" >/dev/null 2>"$tmp/err"
		rc2=$?
		why=$(same "$tmp/$s.ref" "$tmp/$s.res")
		ok $(( rc == 0 && rc2 == 0 && $? == 0 && k > 0 ? 0 : 1 )) \
			"$s: resume from $which ($k springs held): $why $(head -c 200 "$tmp/err")"
	done
done

# (b) SIGTERM (the daemon's stop): a checkpoint, exit 4, the summary says interrupted; the resume is exact.
await_ckpt() {   # DIR PID: until DIR/checkpoint.h5 exists or PID is gone (60 s at most)
	i=0
	while [ ! -f "$1/checkpoint.h5" ] && kill -0 "$2" 2>/dev/null && [ $i -lt 600 ]; do
		sleep 0.1; i=$((i + 1))
	done
}
s=3d-bed
d="$tmp/$s.term"
"$ENGINE" run "$tmp/$s.json" --out "$d" >/dev/null 2>"$tmp/err" &
pid=$!
await_ckpt "$d" $pid
sleep 0.3
kill -TERM $pid
wait $pid
rc=$?
last=$(tail -n 1 "$d/progress.jsonl")
t=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$d/checkpoint.h5")
"$ENGINE" run "$tmp/$s.json" --resume "$d/checkpoint.h5" --out "$d" >/dev/null 2>>"$tmp/err"
rc2=$?
why=$(same "$tmp/$s.ref" "$d")
res=$?
case "$last" in *'"status":"interrupted"'*) st=0 ;; *) st=1 ;; esac
ok $(( rc == 4 && st == 0 && rc2 == 0 && res == 0 ? 0 : 1 )) \
	"$s: SIGTERM exit $rc at time $t (summary interrupted), resume exit $rc2: $why $(head -c 200 "$tmp/err")"

# (c) kill -9 with wall-clock checkpoints (every 0.3 s, taken at the end of the chunk of steps that finds one
# due): killed 0.4 s after its first checkpoint, resumed from whatever is on disk; the result is the
# uninterrupted run's.
"$PY" - "$tmp/3d-bed.json" "$tmp/3d-bed-wall.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["output"]["checkpoint"] = {"every": {"wall_seconds": 0.3}}
json.dump(d, open(sys.argv[2], "w"))
PYEOF
ref 3d-bed-wall
d="$tmp/3d-bed.kill"
"$ENGINE" run "$tmp/3d-bed-wall.json" --out "$d" >/dev/null 2>"$tmp/err" &
pid=$!
await_ckpt "$d" $pid
sleep 0.4
kill -KILL $pid 2>/dev/null && killed=1 || killed=0
wait $pid 2>/dev/null
t=$("$PY" -c 'import h5py, sys; print(h5py.File(sys.argv[1], "r").attrs["time"])' "$d/checkpoint.h5")
"$ENGINE" run "$tmp/3d-bed-wall.json" --resume "$d/checkpoint.h5" --out "$d" >/dev/null 2>>"$tmp/err"
rc2=$?
why=$(same "$tmp/3d-bed-wall.ref" "$d")
ok $(( killed == 1 && rc2 == 0 && $? == 0 ? 0 : 1 )) \
	"3d-bed: kill -9 (wall-clock checkpoints), resumed from time $t: $why $(head -c 200 "$tmp/err")"

# (d) Ensembles (run.replicas 3): each replica its own stream (placement and velocities), one checkpoint
# file for all; resume exact from either checkpoint, also written under mpirun -np 2 and resumed under -np 3.
"$PY" - "$tmp/2d-hertz.json" "$tmp/ens.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["run"]["replicas"] = 3
json.dump(d, open(sys.argv[2], "w"))
PYEOF
s=ens
ref $s
rc=$?
for which in checkpoint.prev.h5 checkpoint.h5; do
	rm -rf "$tmp/$s.res"
	cp -r "$tmp/$s.ref" "$tmp/$s.res"
	k=$(springs "$tmp/$s.res/$which" replica_1/)
	"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.res/$which" --out "$tmp/$s.res" >/dev/null 2>"$tmp/err"
	rc2=$?
	why=$(same "$tmp/$s.ref" "$tmp/$s.res")
	ok $(( rc == 0 && rc2 == 0 && $? == 0 && k > 0 ? 0 : 1 )) \
		"ensemble: resume from $which (replica 1 holds $k springs): $why $(head -c 200 "$tmp/err")"
done
# the replicas are different systems: their first frames differ, and the records carry standard errors
"$PY" - "$tmp/ens.ref" >"$tmp/ens.check" <<'PYEOF'
import json, sys
import h5py, numpy as np
t = h5py.File(sys.argv[1] + "/trajectory.h5", "r")["particles"]
first = [t["replica_%d/position/value" % r][0] for r in range(3)]
dmin = min(float(np.max(np.abs(first[a] - first[b]))) for a, b in ((0, 1), (0, 2), (1, 2)))
last = [json.loads(l) for l in open(sys.argv[1] + "/progress.jsonl") if '"progress"' in l][-1]
good = dmin > 0.5 and last["replicas"] == 3 and last["kinetic_energy_se"] > 0
print(("ok" if good else "not ok") + " - ensemble: the replicas' first frames differ (by %.3g at least), "
      "kinetic energy %.4g +- %.2g over %d replicas" % (dmin, last["kinetic_energy"], last["kinetic_energy_se"],
                                                          last["replicas"]))
PYEOF
report "$tmp/ens.check"
if command -v mpirun >/dev/null 2>&1; then
	rm -rf "$tmp/$s.np"
	mpirun -np 2 "$ENGINE" run "$tmp/$s.json" --out "$tmp/$s.np" >/dev/null 2>"$tmp/err"
	rc=$?
	mpirun -np 3 "$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.np/checkpoint.prev.h5" --out "$tmp/$s.np" \
		>/dev/null 2>>"$tmp/err"
	rc2=$?
	why=$(same "$tmp/$s.ref" "$tmp/$s.np")
	ok $(( rc == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) \
		"ensemble: written under mpirun -np 2, resumed under -np 3: $why $(head -c 200 "$tmp/err")"
fi

echo "1..$n"
[ "$failed" = 0 ]
