#!/bin/sh
# Checkpoints and exact resume through the real program: resume, kill -9, corruption, SIGTERM (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
PY=/usr/bin/python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/resume_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }

if ! "$PY" -c 'import h5py, numpy' 2>/dev/null; then
	echo "1..0 # SKIP python3-h5py not installed (./quickstart installs it)"
	exit 0
fi

# same A B: every dataset of the two trajectories bit for bit, and the two
# progress streams line for line (wall-clock fields aside). Prints why not.
cat >"$tmp/same.py" <<'PYEOF'
import json, sys
import h5py, numpy as np
a, b = sys.argv[1], sys.argv[2]
fa, fb = h5py.File(a + "/trajectory.h5", "r"), h5py.File(b + "/trajectory.h5", "r")
names, bad = [], []
def visit(name, obj):
    if isinstance(obj, h5py.Dataset):
        names.append(name)
fa.visititems(visit)
nb = []
fb.visititems(lambda name, o: nb.append(name) if isinstance(o, h5py.Dataset) else None)
if sorted(names) != sorted(nb):
    bad.append("dataset lists differ")
for name in names:
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
frames = sum(g["position/value"].shape[0] for g in fa["particles"].values()) if "particles" in fa else 0
if bad:
    print("differ: " + ", ".join(bad[:6]))
    sys.exit(1)
groups = len(fa["particles"]) if "particles" in fa else 0
print("%d datasets, %d frames%s, %d progress lines identical" % (len(names), frames,
      " in %d particles groups" % groups if groups > 1 else "", len(la)))
PYEOF
same() { "$PY" "$tmp/same.py" "$1" "$2"; }

# Scenes: 2D/3D, elastic/inelastic with TC, cell lists (dilute) and neighbour lists (dense).
cat >"$tmp/2d-dilute.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":1500,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "run":{"seed":31,"until":{"time":40}},
 "output":{"every":{"time":2},"observables":["kinetic_energy","pressure","collision_rate","momentum"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}}}
JSON
cat >"$tmp/2d-dense-tc.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":1600,"volume_fraction":0.7},
 "collisions":{"restitution":0.8,"tc":0.0001},"run":{"seed":32,"until":{"collisions_per_particle":100}},
 "output":{"every":{"collisions_per_particle":10},"observables":["kinetic_energy","temperature","pressure","clusters"],
   "snapshots":{"every":{"collisions_per_particle":40}},"checkpoint":{"every":{"time":15}}}}
JSON
cat >"$tmp/3d-dilute-tc.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":1500,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.001},"run":{"seed":33,"until":{"time":12}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","collision_rate","clusters","momentum"],
   "snapshots":{"every":{"time":2}},"checkpoint":{"every":{"time":1.3}}}}
JSON
cat >"$tmp/3d-dense.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":1372,"volume_fraction":0.45,"initial":{"relax":{"collisions_per_particle":5}}},
 "run":{"seed":34,"until":{"time":3}},
 "output":{"every":{"collisions_per_particle":15},"snapshots":{"every":{"time":1}},"checkpoint":{"every":{"time":0.4}}}}
JSON
# Walls and gravity (issue 12): wall phases, the wall random stream and the
# wall impulse accumulators are state too.
cat >"$tmp/2d-walls-gravity.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":1500,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.0001},
 "boundaries":{"y":{"type":"walls","lower":{"type":"vibrating","amplitude":0.3,"frequency":0.7,"restitution":0.9},
   "upper":{"type":"thermal","temperature":1,"accommodation":0.5}}},
 "gravity":[0,-0.5],"run":{"seed":39,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","wall_force","center_of_mass_height","potential_energy"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}}}
JSON
cat >"$tmp/3d-walls.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":1500,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"z":{"type":"walls","lower":{"type":"moving","velocity":[-0.5,0,0]},"upper":{"type":"moving","velocity":[0.5,0,0]}},
   "x":{"type":"walls","lower":{"type":"rough","probability":0.5},"upper":{"type":"specular","restitution":0.8}}},
 "run":{"seed":40,"until":{"time":12}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","wall_force","momentum"],
   "snapshots":{"every":{"time":2}},"checkpoint":{"every":{"time":1.3}}}}
JSON
# Obstacles and open walls: the obstacles' impulses and hits, the particles
# that left (NaN rows in the frames) and the outflow counts are state too.
cat >"$tmp/2d-obstacles-open.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":1500,"box":[120,60],
   "initial":{"positions":"random","temperature":0.5,"velocity":[0.6,0]}},
 "collisions":{"restitution":0.95,"tc":0.0001},"gravity":[0,-0.01],
 "boundaries":{"x":{"type":"walls","lower":{"type":"open"},"upper":{"type":"open"}},
   "y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "obstacles":[{"type":"slip","center":[40,30],"radius":6,"restitution":0.9},
   {"type":"no_slip","center":[80,20],"radius":4,"temperature":0.5},{"type":"random_sign","center":[80,45],"radius":3}],
 "run":{"seed":43,"until":{"time":60}},
 "output":{"every":{"time":3},"observables":["kinetic_energy","obstacle_force","outflow","wall_force"],
   "snapshots":{"every":{"time":20}},"checkpoint":{"every":{"time":13}}}}
JSON
# Reservoir walls (inlet): the slots, the free-slot stack, the particle ids
# (H5MD particles/all/id), the entry timers and their random stream are state.
cat >"$tmp/2d-reservoir.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":800,"box":[120,60],
   "initial":{"positions":"random","temperature":0.5,"velocity":[0.3,0]}},
 "collisions":{"restitution":0.95,"tc":0.0001},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.05,"velocity":[0.3,0],"temperature":0.5},
   "upper":{"type":"reservoir","volume_fraction":0.05,"velocity":[0.3,0],"temperature":0.5}}},
 "obstacles":[{"type":"slip","center":[60,30],"radius":6}],
 "run":{"seed":47,"until":{"time":60}},
 "output":{"every":{"time":3},"observables":["kinetic_energy","obstacle_force","outflow"],
   "snapshots":{"every":{"time":20}},"checkpoint":{"every":{"time":13}}}}
JSON
# Rough particles through reservoir walls: the entering spins (drawn from the entry stream), the spins of
# the slots (frames' angular_velocity with slot rows) and the rotational observables.
cat >"$tmp/2d-reservoir-rough.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"box":[80,40]},
 "collisions":{"restitution":0.95,"tc":0.0001,"rough":{"tangential_restitution":0.5}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.05,"velocity":[0.3,0],"temperature":0.5},
   "upper":{"type":"open"}}},
 "run":{"seed":48,"until":{"time":60}},
 "output":{"every":{"time":3},"observables":["kinetic_energy","rotational_temperature","outflow","velocity_distribution"],
   "snapshots":{"every":{"time":20}},"checkpoint":{"every":{"time":13}}}}
JSON
# A dense hard-sphere reservoir gas ("gas": "hard_spheres", 3D): its entry rate is set at load from the
# scene (no state of its own); the timers, stream, slots and ids resume as with the ideal gas.
cat >"$tmp/3d-reservoir-dense.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":300,"box":[16,10,10],
   "initial":{"positions":"random","temperature":1,"velocity":[0.2,0,0]}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.15,"velocity":[0.2,0,0],"temperature":1,
     "gas":"hard_spheres"},
   "upper":{"type":"reservoir","volume_fraction":0.15,"velocity":[0.2,0,0],"temperature":1,"gas":"hard_spheres"}}},
 "run":{"seed":49,"until":{"time":40}},
 "output":{"every":{"time":2},"observables":["kinetic_energy","outflow"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":9}}}}
JSON
# A reservoir of a rough binary mixture: each species' slots on its own stack, the species drawn per entry
# from the entry stream, spins per species.
cat >"$tmp/2d-reservoir-mixture.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"name":"A","count":150,"radius":0.5,"mass":1},
   {"name":"B","count":100,"radius":0.3,"mass":0.25}],"box":[60,40],"initial":{"positions":"random","temperature":0.5}},
 "collisions":{"restitution":0.95,"tc":0.0001,"rough":{"tangential_restitution":0.5}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.05,"velocity":[0.3,0],"temperature":0.5,
     "composition":[1,2]},
   "upper":{"type":"reservoir","volume_fraction":0.04,"velocity":[0.3,0],"temperature":0.5}}},
 "run":{"seed":50,"until":{"time":60}},
 "output":{"every":{"time":3},"observables":["kinetic_energy","temperature","rotational_temperature","outflow"],
   "snapshots":{"every":{"time":20}},"checkpoint":{"every":{"time":13}}}}
JSON
# Dispenser and filter (seed 001's dense stream): the piston's recharge
# time, the frozen flags and counts, slots and ids are state too.
cat >"$tmp/2d-dispenser-filter.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":500,"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},
 "collisions":{"restitution":0.97,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.65,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0],"temperature":0.02}}}},
 "run":{"seed":49,"until":{"time":120}},
 "output":{"every":{"time":6},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":40}},"checkpoint":{"every":{"time":27}}}}
JSON
# The same in 3D, walled across y (templates between walls there too).
cat >"$tmp/3d-dispenser-filter.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":440,"box":[16,6,6],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0,0]}},
 "collisions":{"restitution":0.97,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.4,"velocity":[0.1,0,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0,0],"temperature":0.02}}},
   "y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":51,"until":{"time":120}},
 "output":{"every":{"time":6},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":40}},"checkpoint":{"every":{"time":27}}}}
JSON
# A mixture from a dispenser (two species, pair restitution) with a filter:
# the per-species free-slot stacks (in free_slots, their depths rebuilt from
# the presence flags) and the rows' fixed species.
cat >"$tmp/2d-dispenser-mixture.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"name":"A","count":300,"radius":0.5,"mass":1},
   {"name":"B","count":130,"radius":0.35,"mass":0.5}],"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},
 "collisions":{"restitution":0.97,"tc":0.05,"restitution_pairs":[{"a":"A","b":"B","restitution":0.9}]},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.6,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0],"temperature":0.02}}}},
 "run":{"seed":57,"until":{"time":120}},
 "output":{"every":{"time":6},"observables":["kinetic_energy","temperature","outflow","wall_force"],
   "snapshots":{"every":{"time":40}},"checkpoint":{"every":{"time":27}}}}
JSON
# A polydisperse species from a dispenser: its empty rows' radii fixed at
# load (H5MD diameter time-independent), a layer particle takes a free row of
# its species at random (the order of the per-species free stacks is state).
cat >"$tmp/2d-dispenser-poly.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"name":"A","count":300,"radius":0.5,"mass":1},
   {"name":"B","count":130,"radius_range":[0.3,0.4],"mass":0.5}],"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},
 "collisions":{"restitution":0.97,"tc":0.05,"restitution_pairs":[{"a":"A","b":"B","restitution":0.9}]},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.55,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0],"temperature":0.02}}}},
 "run":{"seed":59,"until":{"time":120}},
 "output":{"every":{"time":6},"observables":["kinetic_energy","temperature","outflow","wall_force"],
   "snapshots":{"every":{"time":40}},"checkpoint":{"every":{"time":27}}}}
JSON
# Rough particles from a dispenser: the layers' spins are state too.
cat >"$tmp/2d-dispenser-rough.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"box":[40,20],
   "initial":{"positions":"random","temperature":0.02,"rotational_temperature":0.02}},
 "collisions":{"restitution":0.95,"tc":0.05,"rough":{"tangential_restitution":0.5}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.5,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open"}}},
 "run":{"seed":53,"until":{"time":120}},
 "output":{"every":{"time":6},"observables":["kinetic_energy","rotational_temperature","outflow"],
   "snapshots":{"every":{"time":40}},"checkpoint":{"every":{"time":27}}}}
JSON
# A dispenser in a field (the gravity kernels with the moving piston).
cat >"$tmp/2d-dispenser-gravity.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"box":[20,60],
   "initial":{"positions":"random","temperature":0.02}},"gravity":[0,-0.05],
 "collisions":{"restitution":0.95,"tc":0.05},
 "boundaries":{"y":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.3,"velocity":[0,0.1],"temperature":0.02,
   "thickness":8},"upper":{"type":"specular"}}},
 "run":{"seed":55,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","potential_energy","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":70}}}}
JSON
# A filter in a field (along and across the stream; the FILTG kernels): the
# frozen flags decide who falls, the frozen count and velocity sum are
# rebuilt from them on restore.
cat >"$tmp/2d-filter-gravity.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":230,"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},"gravity":[0.01,-0.004],
 "collisions":{"restitution":0.9,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.3,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":4,"velocity":[0.1,0],"temperature":0.02}}},
   "y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":58,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","potential_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":37}}}}
JSON
# Dispensers on two axes (out of phase): each layer leaves out what lies
# behind the other axis' piston (its position from the state's piston times).
cat >"$tmp/2d-dispensers-two-axes.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"radius":0.5,"box":[40,40],
   "initial":{"positions":"random","temperature":0.02}},
 "collisions":{"restitution":0.95,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.5,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open"}},
   "y":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.4,"velocity":[0,0.1],"temperature":0.02,"thickness":3},
   "upper":{"type":"open"}}},
 "run":{"seed":61,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":37}}}}
JSON
# Dispensers and filters on two axes: a diagonal stream (velocity along the other stream axis), layer
# particles beyond the other axis' filter plane placed frozen; and (2D) a filter's frozen particles caught
# by the other axis' piston leave through its wall.
cat >"$tmp/3d-dispensers-two-axes-filters.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":700,"radius":0.5,"box":[16,16,5],"capacity":3000,
   "initial":{"positions":"random","temperature":0.02,"velocity":[0.1,0.1,0]}},
 "collisions":{"restitution":0.95,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.3,"velocity":[0.1,0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0.1,0],"temperature":0.02}}},
   "y":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.3,"velocity":[0.1,0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0.1,0],"temperature":0.02}}}},
 "run":{"seed":62,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":37}}}}
JSON
cat >"$tmp/2d-filter-piston.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":300,"radius":0.5,"box":[30,30],"capacity":3000,
   "initial":{"positions":"random","temperature":0.02}},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.4,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":4,"velocity":[0.1,0],"temperature":0.02}}},
   "y":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.4,"velocity":[0,0.1],"temperature":0.02},
   "upper":{"type":"open"}}},
 "run":{"seed":63,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":37}}}}
JSON
# A mixture's filter in a field (the FILTG species kernels): the frozen
# counts per species and the mass present are rebuilt from the flags.
cat >"$tmp/2d-filter-gravity-mixture.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"name":"A","count":150,"radius":0.5,"mass":1},
   {"name":"B","count":60,"radius":0.35,"mass":0.5}],"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},"gravity":[0.01,-0.004],
 "collisions":{"restitution":0.9,"tc":0.05,"restitution_pairs":[{"a":"A","b":"B","restitution":0.8}]},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.3,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":4,"velocity":[0.1,0],"temperature":0.02}}},
   "y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":60,"until":{"time":200}},
 "output":{"every":{"time":10},"observables":["kinetic_energy","potential_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":50}},"checkpoint":{"every":{"time":37}}}}
JSON
# Rough particles (spins, angular_velocity frames) and driving (kick times,
# the thermostat's random stream and local means) are state too.
cat >"$tmp/3d-rough-drive.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":1500,"volume_fraction":0.2,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.001,"rough":{"tangential_restitution":0.4,"friction":0.3}},
 "driving":{"type":"stochastic","temperature":1,"interval":2,"grid":3,"average_time":4},
 "run":{"seed":43,"until":{"time":12}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","rotational_energy","rotational_temperature"],
   "snapshots":{"every":{"time":2}},"checkpoint":{"every":{"time":1.3}}}}
JSON
cat >"$tmp/2d-rough-noise.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":1600,"volume_fraction":0.7},
 "collisions":{"restitution":0.8,"tc":0.0001,"rough":{"tangential_restitution":0.5}},
 "driving":{"type":"white_noise","strength":0.2,"interval":0.5},
 "run":{"seed":44,"until":{"collisions_per_particle":100}},
 "output":{"every":{"collisions_per_particle":10},"observables":["temperature","rotational_temperature"],
   "snapshots":{"every":{"collisions_per_particle":40}},"checkpoint":{"every":{"time":3}}}}
JSON
# Mixtures (particles.species): the species kernels; species rebuilt from
# the scene indices on restore. Dense 2D (neighbour lists), dilute 3D with TC.
cat >"$tmp/2d-mixture-dense.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"name":"a","count":800,"radius":0.5,"mass":1},
   {"name":"b","count":800,"radius":0.7,"mass":2}],"volume_fraction":0.47,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.0001,"restitution_pairs":[{"a":"a","b":"b","restitution":0.8}]},
 "run":{"seed":45,"until":{"collisions_per_particle":100}},
 "output":{"every":{"collisions_per_particle":10},"observables":["kinetic_energy","temperature","pressure"],
   "snapshots":{"every":{"collisions_per_particle":40}},"checkpoint":{"every":{"time":3}}}}
JSON
cat >"$tmp/3d-mixture-dilute.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"species":[{"count":1000,"radius":0.5,"mass":1},
   {"count":300,"radius":1,"mass":8},{"count":200,"radius":0.3,"mass":0.2}],"volume_fraction":0.1,
   "initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.001},"driving":{"type":"stochastic","temperature":1,"interval":2,"grid":2,"average_time":4},
 "run":{"seed":46,"until":{"time":12}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","temperature","momentum"],
   "snapshots":{"every":{"time":2}},"checkpoint":{"every":{"time":1.3}}}}
JSON
cat >"$tmp/2d-mixture-walls.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"species":[{"count":600,"radius":0.4,"mass":1},
   {"count":300,"radius_range":[0.6,1],"mass":4}],"box":[80,50],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":0.0001},
 "boundaries":{"y":{"type":"walls","lower":{"type":"thermal","temperature":1,"accommodation":0.5},
   "upper":{"type":"vibrating","amplitude":0.3,"frequency":0.7}},"x":{"type":"walls","lower":{"type":"open"},"upper":{"type":"specular"}}},
 "obstacles":[{"type":"no_slip","center":[40,25],"radius":5,"temperature":0.5}],"gravity":[0,-0.02],
 "run":{"seed":47,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","temperature","wall_force","obstacle_force","center_of_mass_height","potential_energy","outflow"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}}}
JSON
# Long enough to be killed: wall-clock checkpoints, ~2-3 s of work.
cat >"$tmp/3d-kill.json" <<'JSON'
{"method":"ed","dimensions":3,"particles":{"count":3000,"volume_fraction":0.4},
 "collisions":{"restitution":0.95,"tc":0.001},"run":{"seed":35,"until":{"collisions_per_particle":700}},
 "output":{"every":{"collisions_per_particle":25},"observables":["kinetic_energy","pressure","clusters"],
   "snapshots":{"every":{"collisions_per_particle":150}},"checkpoint":{"every":{"wall_seconds":0.05}}}}
JSON
cat >"$tmp/2d-kill.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":4000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "run":{"seed":36,"until":{"collisions_per_particle":400}},
 "output":{"every":{"collisions_per_particle":20},"snapshots":{"every":{"collisions_per_particle":100}},
   "checkpoint":{"every":{"wall_seconds":0.05}}}}
JSON

# The Monte Carlo methods: state = particles, identities, cell offsets, NTC
# remainders, hsmc cell stamps, RNG, clock, counters, accumulators.
cat >"$tmp/2d-dsmc.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":3000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":41,"until":{"time":30}},
 "output":{"every":{"time":1},"observables":["kinetic_energy","temperature","pressure","collision_rate","clusters","momentum"],
   "snapshots":{"every":{"time":5}},"checkpoint":{"every":{"time":3.7}}},
 "dsmc":{"correction":"cba"}}
JSON
cat >"$tmp/3d-hsmc.json" <<'JSON'
{"method":"hsmc","dimensions":3,"particles":{"count":2000,"volume_fraction":0.35,"initial":{"relax":{"collisions_per_particle":3}}},
 "collisions":{"restitution":0.9},"run":{"seed":42,"until":{"collisions_per_particle":60}},
 "output":{"every":{"collisions_per_particle":4},"observables":["kinetic_energy","pressure","clusters","momentum"],
   "snapshots":{"every":{"collisions_per_particle":20}},"checkpoint":{"every":{"time":0.9}}},
 "hsmc":{"cell_size":2}}
JSON
cat >"$tmp/2d-dsmc-kill.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":40000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":37,"until":{"time":192}},
 "output":{"every":{"time":4},"observables":["kinetic_energy","pressure","collision_rate","clusters"],
   "snapshots":{"every":{"time":32}},"checkpoint":{"every":{"wall_seconds":0.05}}},
 "dsmc":{"correction":"enskog","time_step":0.05}}
JSON
cat >"$tmp/3d-hsmc-kill.json" <<'JSON'
{"method":"hsmc","dimensions":3,"particles":{"count":30000,"volume_fraction":0.35},
 "collisions":{"restitution":0.95},"run":{"seed":38,"until":{"collisions_per_particle":500}},
 "output":{"every":{"collisions_per_particle":20},"observables":["kinetic_energy","temperature","pressure","momentum"],
   "snapshots":{"every":{"collisions_per_particle":125}},"checkpoint":{"every":{"wall_seconds":0.05}}},
 "hsmc":{"cell_size":2}}
JSON

# dsmc/hsmc with walls and gravity: wall counters and impulses, and the
# random draws of thermal and rough walls, are state too.
cat >"$tmp/2d-hsmc-walls.json" <<'JSON'
{"method":"hsmc","dimensions":2,"particles":{"count":2000,"volume_fraction":0.2,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"y":{"type":"walls","lower":{"type":"rough","probability":0.3,"restitution":0.8},
   "upper":{"type":"thermal","temperature":1,"accommodation":0.5,"velocity":[0.2,0]}},
   "x":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"moving","velocity":[0,0.3]}}},
 "gravity":[0,-0.05],"run":{"seed":43,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","wall_force","center_of_mass_height","potential_energy"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}},
 "hsmc":{"cell_size":2}}
JSON
# dsmc with vibrating walls (a floor with r_w < 1, so particles ride it, and
# a lid): the walls' phases follow the clock, which the checkpoint holds.
cat >"$tmp/2d-dsmc-vib.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":1000,"box":[40,60],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"y":{"type":"walls","lower":{"type":"vibrating","amplitude":0.8,"frequency":0.3,"phase":0.2,"restitution":0.6},
   "upper":{"type":"vibrating","amplitude":0.5,"frequency":0.17}}},
 "gravity":[0,-0.5],"run":{"seed":45,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","wall_force","center_of_mass_height","potential_energy"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}},
 "dsmc":{"cell_size":2}}
JSON
# hsmc with an open lid: particles leave (present count, outflow counters).
cat >"$tmp/2d-hsmc-open.json" <<'JSON'
{"method":"hsmc","dimensions":2,"particles":{"count":1000,"box":[40,60],"initial":{"positions":"random","temperature":2}},
 "collisions":{"restitution":0.95},
 "boundaries":{"y":{"type":"walls","lower":{"type":"vibrating","amplitude":0.5,"frequency":0.3},"upper":{"type":"open"}}},
 "gravity":[0,-0.1],"run":{"seed":46,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","wall_force","outflow","center_of_mass_height"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}},
 "hsmc":{"cell_size":2}}
JSON
cat >"$tmp/3d-dsmc-pipe.json" <<'JSON'
{"method":"dsmc","dimensions":3,"particles":{"count":2000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.95},
 "boundaries":{"x":{"type":"walls","lower":{"type":"rough","probability":0.1},"upper":{"type":"rough","probability":0.1}},
   "y":{"type":"walls","lower":{"type":"thermal","temperature":0.5},"upper":{"type":"specular","restitution":0.9}}},
 "gravity":[0,0,-0.02],"run":{"seed":44,"until":{"time":40}},
 "output":{"every":{"time":2},"observables":["kinetic_energy","momentum","wall_force"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":9}}}}
JSON
# dsmc mixture with fixed walls, gravity and obstacles (each particle's own
# radius and mass in the flights; no new state).
cat >"$tmp/2d-dsmc-mixture-walls.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"species":[{"count":1200,"radius":0.4,"mass":1},
   {"count":600,"radius_range":[0.6,1],"mass":4}],"box":[80,50],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"y":{"type":"walls","lower":{"type":"thermal","temperature":1,"accommodation":0.5},
   "upper":{"type":"moving","velocity":[0.3,0]}},"x":{"type":"walls","lower":{"type":"rough","probability":0.3},"upper":{"type":"specular"}}},
 "obstacles":[{"type":"no_slip","center":[40,25],"radius":5,"temperature":0.5}],"gravity":[0,-0.02],
 "run":{"seed":48,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","temperature","wall_force","obstacle_force","center_of_mass_height","potential_energy"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}},
 "dsmc":{"correction":"cba"}}
JSON
cat >"$tmp/2d-dsmc-mixture-vib.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"species":[{"count":1200,"radius":0.4,"mass":1},
   {"count":600,"radius_range":[0.6,1],"mass":4}],"box":[80,50],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"y":{"type":"walls","lower":{"type":"vibrating","amplitude":0.5,"frequency":0.3,"restitution":0.8},
   "upper":{"type":"open"}}},"gravity":[0,-0.02],
 "run":{"seed":49,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","temperature","wall_force","outflow","center_of_mass_height"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}}}
JSON
# hsmc mixtures: dense (full cells by particle volume, cell collisions with
# the cells' masses) and bounded (own radii at walls and obstacles); the
# cells' particle volumes are recomputed from the records: no new state.
cat >"$tmp/2d-hsmc-mixture.json" <<'JSON'
{"method":"hsmc","dimensions":2,"particles":{"species":[{"count":1500,"radius":0.5,"mass":1},
   {"count":300,"radius_range":[0.8,1.2],"mass":4}],"volume_fraction":0.5,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":50,"until":{"time":10}},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","temperature","pressure","momentum"],
   "snapshots":{"every":{"time":5}},"checkpoint":{"every":{"time":2.3}}},
 "hsmc":{"cell_size":2}}
JSON
cat >"$tmp/2d-hsmc-mixture-walls.json" <<'JSON'
{"method":"hsmc","dimensions":2,"particles":{"species":[{"count":1200,"radius":0.4,"mass":1},
   {"count":600,"radius_range":[0.6,1],"mass":4}],"box":[80,50],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},
 "boundaries":{"y":{"type":"walls","lower":{"type":"thermal","temperature":1,"accommodation":0.5},
   "upper":{"type":"moving","velocity":[0.3,0]}},"x":{"type":"walls","lower":{"type":"rough","probability":0.3},"upper":{"type":"specular"}}},
 "obstacles":[{"type":"no_slip","center":[40,25],"radius":5,"temperature":0.5}],"gravity":[0,-0.1],
 "run":{"seed":51,"until":{"time":30}},
 "output":{"every":{"time":1.5},"observables":["kinetic_energy","temperature","wall_force","obstacle_force","center_of_mass_height","potential_energy"],
   "snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":7}}},
 "hsmc":{"cell_size":1.5}}
JSON

ref() { # uninterrupted reference run of scene $1 into $tmp/$1.ref
	"$ENGINE" run "$tmp/$1.json" --out "$tmp/$1.ref" >/dev/null 2>"$tmp/$1.ref.err"
}

# (a) checkpoint at simulated time T, resume: identical to the uninterrupted run.
for s in 2d-dilute 2d-dense-tc 3d-dilute-tc 3d-dense 2d-dsmc 3d-hsmc 2d-walls-gravity 3d-walls 2d-obstacles-open 3d-rough-drive \
	2d-rough-noise 2d-hsmc-walls 2d-dsmc-vib 2d-hsmc-open 3d-dsmc-pipe 2d-mixture-dense 3d-mixture-dilute \
	2d-mixture-walls 2d-dsmc-mixture-walls 2d-dsmc-mixture-vib 2d-hsmc-mixture 2d-hsmc-mixture-walls 2d-reservoir \
	2d-reservoir-rough 3d-reservoir-dense 2d-reservoir-mixture 2d-dispenser-filter 3d-dispenser-filter 2d-dispenser-rough 2d-dispenser-gravity 2d-filter-gravity \
	2d-dispenser-mixture 2d-dispenser-poly 2d-filter-gravity-mixture \
	2d-dispensers-two-axes 3d-dispensers-two-axes-filters 2d-filter-piston; do
	ref $s
	rc=$?
	for which in checkpoint.prev.h5 checkpoint.h5; do
		rm -rf "$tmp/$s.res"
		cp -r "$tmp/$s.ref" "$tmp/$s.res"
		t=$("$PY" -c 'import h5py,sys; print(h5py.File(sys.argv[1],"r").attrs["time"])' "$tmp/$s.res/$which")
		"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.res/$which" --out "$tmp/$s.res" >/dev/null 2>"$tmp/err"
		rc2=$?
		why=$(same "$tmp/$s.ref" "$tmp/$s.res")
		ok $(( rc == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "$s: resume from $which (time $t): $why $(head -c 200 "$tmp/err")"
	done
done

# (b) kill -9 at random moments (seeded), resume from whatever is on disk.
# The random delay counts from the moment a checkpoint exists (polled), not
# from the start: on a loaded machine set-up alone can outlast a fixed delay.
await_ckpt() {   # DIR PID: until DIR/checkpoint.h5 exists or PID is gone (60 s at most)
	i=0
	while [ ! -f "$1/checkpoint.h5" ] && kill -0 "$2" 2>/dev/null && [ $i -lt 600 ]; do
		sleep 0.1; i=$((i + 1))
	done
}
seed=20261121
# kill_resume SEEDOFF SPAN [LAUNCHER...]: run scene $s into $d (under LAUNCHER, e.g. mpirun -np 2), kill -9
# the launcher and its children three times at random delays of 0.1 + SPAN * U(0,1) s after a checkpoint
# exists (seeded by seed + SEEDOFF + k), resuming from whatever is on disk, then run to the end.
# Sets kills, resumes and rc (the last exit status).
kill_resume() {
	off=$1 span=$2; shift 2
	kills=0; resumes=0; k=0; rc=1
	while [ $k -lt 6 ]; do
		k=$((k + 1))
		if [ -f "$d/checkpoint.h5" ]; then
			"$@" "$ENGINE" run "$tmp/$s.json" --resume "$d/checkpoint.h5" --out "$d" >/dev/null 2>>"$tmp/$s.kill.err" &
			resumes=$((resumes + 1))
		else
			"$@" "$ENGINE" run "$tmp/$s.json" --out "$d" >/dev/null 2>>"$tmp/$s.kill.err" &
		fi
		pid=$!
		if [ $k -le 3 ]; then
			delay=$(awk -v s=$((seed + off + k)) -v w="$span" 'BEGIN { srand(s); printf "%.2f", 0.1 + w * rand() }')
			await_ckpt "$d" $pid
			sleep "$delay"
			if kill -KILL $(pgrep -P $pid) $pid 2>/dev/null; then
				kills=$((kills + 1))
			fi
			wait $pid 2>/dev/null
			rc=$?
		else
			wait $pid
			rc=$?
			[ $rc -eq 0 ] && break
		fi
	done
}
for s in 3d-kill 2d-kill 2d-dsmc-kill 3d-hsmc-kill; do
	ref $s
	d="$tmp/$s.kill"
	rm -rf "$d"
	kill_resume 0 0.5
	why=$(same "$tmp/$s.ref" "$d")
	ok $(( rc == 0 && kills >= 2 && resumes >= 2 && $? == 0 ? 0 : 1 )) "$s: $kills kill -9, $resumes resumes, exit $rc: $why $(head -c 200 "$tmp/$s.kill.err")"
done

# (c) damaged checkpoints are detected (one line on stderr) and checkpoint.prev.h5 is used.
s=3d-dilute-tc
damage() { # mode dir
	"$PY" - "$1" "$2/checkpoint.h5" <<'PYEOF'
import os, sys
import h5py
mode, path = sys.argv[1], sys.argv[2]
if mode == "truncate":
    os.truncate(path, os.path.getsize(path) // 2)
elif mode.startswith("scene"):
    # the scene stored in the checkpoint (issue 19.5): "scene" makes it
    # another valid scene (seed 33 -> 37: only the digest tells damage from
    # a checkpoint of another scene), "scenejunk" breaks its JSON
    with open(path, "r+b") as f:
        data = f.read()
        off = data.index(b'"seed":33') + (8 if mode == "scene" else 0)
        f.seek(off); f.write(b"7" if mode == "scene" else b"}")
else:
    # flip one byte inside the velocities: only the digest can tell
    off = h5py.File(path, "r")["ed/v"].id.get_offset() + 1000
    with open(path, "r+b") as f:
        f.seek(off); b = f.read(1); f.seek(off); f.write(bytes([b[0] ^ 0x10]))
PYEOF
}
for mode in truncate flip scene scenejunk; do
	rm -rf "$tmp/$s.dmg"
	cp -r "$tmp/$s.ref" "$tmp/$s.dmg"
	damage $mode "$tmp/$s.dmg"
	"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.dmg/checkpoint.h5" --out "$tmp/$s.dmg" >/dev/null 2>"$tmp/err"
	rc=$?
	lines=$(wc -l <"$tmp/err")
	why=$(same "$tmp/$s.ref" "$tmp/$s.dmg")
	res=$?
	grep -q 'corrupt checkpoint.*using .*checkpoint.prev.h5' "$tmp/err"
	ok $(( rc == 0 && lines == 1 && res == 0 && $? == 0 ? 0 : 1 )) "$mode checkpoint.h5: detected, prev used, exit $rc, $why: $(cat "$tmp/err")"
done
# both damaged: exit 2 and no run
rm -rf "$tmp/$s.dmg"
cp -r "$tmp/$s.ref" "$tmp/$s.dmg"
damage flip "$tmp/$s.dmg"
cp "$tmp/$s.dmg/checkpoint.h5" "$tmp/$s.dmg/checkpoint.prev.h5"
"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.dmg/checkpoint.h5" --out "$tmp/$s.dmg" >"$tmp/out" 2>"$tmp/err"
rc=$?
ok $(( rc == 2 && $(wc -l <"$tmp/err") == 2 ? 0 : 1 )) "both checkpoints damaged: exit $rc, $(tail -n 1 "$tmp/err")"
# a damaged chunk index in trajectory.h5 (issue 19: the 1.8 format's version-1 B-tree has no checksum, and
# HDF5 allocates a chunk's recorded size before it verifies the chunk): the record of the first chunk of the
# frame times, which a resume reads, claims 2 GiB; the resume refuses the file before HDF5 reads that chunk
rm -rf "$tmp/$s.dmg"
cp -r "$tmp/$s.ref" "$tmp/$s.dmg"
"$PY" - "$tmp/$s.dmg/trajectory.h5" <<'PYEOF' >"$tmp/why"
import struct, sys
import h5py
path = sys.argv[1]
with h5py.File(path, "r") as f:
    d = f["particles/all/position/time"]
    info = d.id.get_chunk_info(0)
    rank = len(d.shape)
data = open(path, "rb").read()
# a chunk record of the index: size (uint32), filter mask (uint32), rank + 1 offsets (uint64), child address
key = 8 + 8 * (rank + 1)
hits = [i - key for i in range(len(data)) if data.startswith(struct.pack("<Q", info.byte_offset), i)
        and i >= key and struct.unpack_from("<I", data, i - key)[0] == info.size]
if len(hits) != 1:
    sys.exit("found %d records of the chunk" % len(hits))
with open(path, "r+b") as f:
    f.seek(hits[0]); f.write(struct.pack("<I", 0x7fff0000))
print("chunk of %d bytes at %d recorded as 2 GiB" % (info.size, info.byte_offset))
PYEOF
prep=$?
"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.dmg/checkpoint.h5" --out "$tmp/$s.dmg" >"$tmp/out" 2>"$tmp/err"
rc=$?
ok $(( prep == 0 && rc != 0 && $(wc -l <"$tmp/err") == 1 ? 0 : 1 )) \
	"damaged chunk index of trajectory.h5 ($(cat "$tmp/why")): refused, exit $rc: $(cat "$tmp/err")"
grep -q 'damaged chunk index of the frames' "$tmp/err"
ok $? "... and the message says which index"
# a checkpoint of another scene is refused
sed 's/"seed":33/"seed":99/' "$tmp/$s.json" >"$tmp/other.json"
"$ENGINE" run "$tmp/other.json" --resume "$tmp/$s.ref/checkpoint.h5" --out "$tmp/$s.ref" >"$tmp/out" 2>"$tmp/err"
rc=$?
[ $rc -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ] && grep -q 'different scene' "$tmp/err"
ok $? "checkpoint of a different scene refused: exit $rc, $(cat "$tmp/err")"
"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.ref/checkpoint.h5" >"$tmp/out" 2>"$tmp/err"
ok $(( $? == 2 && $(wc -l <"$tmp/err") == 1 ? 0 : 1 )) "--resume without --out refused: $(cat "$tmp/err")"

# (d) SIGTERM: checkpoint, exit 4; resume: identical result.
for s in 3d-kill 2d-kill 2d-dsmc-kill 3d-hsmc-kill; do
	d="$tmp/$s.term"
	rm -rf "$d"
	"$ENGINE" run "$tmp/$s.json" --out "$d" >/dev/null 2>"$tmp/err" &
	pid=$!
	await_ckpt "$d" $pid   # under way (handler installed), then mid-run
	sleep 0.3
	kill -TERM $pid
	wait $pid
	rc=$?
	last=$(tail -n 1 "$d/progress.jsonl")
	"$ENGINE" run "$tmp/$s.json" --resume "$d/checkpoint.h5" --out "$d" >/dev/null 2>>"$tmp/err"
	rc2=$?
	why=$(same "$tmp/$s.ref" "$d")
	res=$?
	case "$last" in *'"status":"interrupted"'*) st=0 ;; *) st=1 ;; esac
	ok $(( rc == 4 && st == 0 && rc2 == 0 && res == 0 ? 0 : 1 )) "$s: SIGTERM exit $rc (summary interrupted), resume exit $rc2: $why $(head -c 200 "$tmp/err")"
done

# (e) Ensembles: one checkpoint file for all replicas (taken at output
# times); resume is exact, also under mpirun and with another rank count.
cat >"$tmp/ens.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":3000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":43,"until":{"time":20},"replicas":5},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","temperature","pressure","collision_rate","clusters"],
   "checkpoint":{"every":{"time":3}}},"dsmc":{"correction":"enskog"}}
JSON
# ed replicas with a collision-count schedule and a time stop: replicas end
# after different numbers of records, so finished replicas are checkpointed
# too, and their frames (particles/replica_K) differ in number and times:
# a resume must cut each replica's frames back to its own count.
cat >"$tmp/ens-ed.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":400,"volume_fraction":0.3},"collisions":{"restitution":0.9},
 "run":{"seed":44,"until":{"time":6},"replicas":3},
 "output":{"every":{"collisions_per_particle":0.5},"observables":["temperature","pressure","clusters"],
   "snapshots":{"every":{"collisions_per_particle":0.5}},"checkpoint":{"every":{"time":1.1}}}}
JSON
cat >"$tmp/ens-kill.json" <<'JSON'
{"method":"dsmc","dimensions":2,"particles":{"count":20000,"volume_fraction":0.1,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":45,"until":{"time":160},"replicas":5},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","temperature","pressure"],
   "snapshots":{"every":{"time":20}},"checkpoint":{"every":{"wall_seconds":0.1}}},
 "dsmc":{"correction":"enskog","time_step":0.05}}
JSON
# ed replicas of a bounded scene with fields (an exposure that straddles checkpoints), the density spectrum's
# ring, wall forces and the centre-of-mass height: all of it per replica in the checkpoint.
cat >"$tmp/ens-fld.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":150,"box":[40,40]},"gravity":[0,-0.1],
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "run":{"seed":46,"until":{"time":12},"replicas":3},
 "output":{"every":{"time":0.5},"observables":["kinetic_energy","wall_force","center_of_mass_height","fields",
   "density_spectrum"],"fields":{"cells":[2,4],"exposure":2.5,"samples":5},"density_spectrum":{"interval":0.25},
   "snapshots":{"every":{"time":4}},"checkpoint":{"every":{"time":2.6}}}}
JSON
# replicas with a reservoir inlet and an open outlet: slots, ids and the entry streams per replica.
cat >"$tmp/ens-res.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":100,"box":[60,60]},
 "boundaries":{"x":{"type":"walls","lower":{"type":"reservoir","volume_fraction":0.02,"temperature":1,
   "velocity":[0.5,0]},"upper":{"type":"open"}}},
 "run":{"seed":47,"until":{"time":40},"replicas":3},
 "output":{"every":{"time":2},"observables":["kinetic_energy","outflow","velocity_distribution","fields"],
   "fields":{"cells":[6,1]},"snapshots":{"every":{"time":10}},"checkpoint":{"every":{"time":15}}}}
JSON
# replicas with a dispenser and a filter: each replica its own templates (the
# scene's seed on its own stream), recharge draws, slots and ids.
cat >"$tmp/ens-disp.json" <<'JSON'
{"method":"ed","dimensions":2,"particles":{"count":400,"box":[30,20],
   "initial":{"positions":"lattice","temperature":0.02,"velocity":[0.1,0]}},
 "collisions":{"restitution":0.97,"tc":0.05},
 "boundaries":{"x":{"type":"walls","lower":{"type":"dispenser","volume_fraction":0.6,"velocity":[0.1,0],"temperature":0.02},
   "upper":{"type":"open","filter":{"distance":3,"velocity":[0.1,0],"temperature":0.02}}}},
 "run":{"seed":48,"until":{"time":90},"replicas":3},
 "output":{"every":{"time":3},"observables":["kinetic_energy","outflow","wall_force"],
   "snapshots":{"every":{"time":30}},"checkpoint":{"every":{"time":40}}}}
JSON
for s in ens ens-ed ens-fld ens-res ens-disp; do
	ref $s
	rc=$?
	rm -rf "$tmp/$s.res"
	cp -r "$tmp/$s.ref" "$tmp/$s.res"
	"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.res/checkpoint.prev.h5" --out "$tmp/$s.res" >/dev/null 2>"$tmp/err"
	rc2=$?
	why=$(same "$tmp/$s.ref" "$tmp/$s.res")
	ok $(( rc == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "$s: ensemble resume from checkpoint.prev.h5: $why $(head -c 200 "$tmp/err")"
done
# Dispensers in an ensemble: each replica its own layers (templates from its
# own stream, its own recharge draws): the replicas' last frames differ,
# every replica placed layers (ids beyond the initial count) and its ids
# are unique.
"$PY" - "$tmp/ens-disp.ref" >"$tmp/ens-disp.check" 2>&1 <<'PYEOF'
import sys
import h5py
import numpy as np
t = h5py.File(sys.argv[1] + "/trajectory.h5", "r")["particles"]
last = [t["replica_%d/position/value" % r][-1] for r in range(3)]
ids = [t["replica_%d/id/value" % r][-1] for r in range(3)]
for r in range(3):
    present = ids[r][ids[r] >= 0]
    assert len(np.unique(present)) == len(present), "ids repeated in replica %d" % r
    assert present.max() >= 400, "replica %d placed no layer" % r
d = [float(np.nanmax(np.abs(last[0] - last[r]))) for r in (1, 2)]
assert min(d) > 1.0, d
print("replicas differ (largest position difference to replica 0: %.3g, %.3g); top ids %s" %
      (d[0], d[1], [int(i.max()) for i in ids]))
PYEOF
ok $? "ens-disp: $(tail -n 1 "$tmp/ens-disp.check")"
# The ensemble checkpoint resumed above lies inside the frame series: each
# replica had written some frames and wrote more after it (so the resume
# had frames to cut back and to continue), and the replicas' counts differ.
"$PY" - "$tmp/ens-ed.ref" >"$tmp/ens-ed.frames" 2>&1 <<'PYEOF'
import sys
import h5py
d = sys.argv[1]
c, t = h5py.File(d + "/checkpoint.prev.h5", "r"), h5py.File(d + "/trajectory.h5", "r")
R = int(c.attrs["replicas"])
at = [int(c["replica_%d/@frames" % r][0]) for r in range(R)]
final = [t["particles/replica_%d/position/value" % r].shape[0] for r in range(R)]
assert all(0 < a < f for a, f in zip(at, final)), (at, final)
assert sum(at) == int(c["output"].attrs["snap_rows"]), "snap_rows is the sum"
assert len(set(final)) > 1, "replicas with different frame counts %s" % final
print("frames per replica at the checkpoint %s, at the end %s" % (at, final))
PYEOF
ok $? "ens-ed: the checkpoint splits every replica's frame series: $(tail -n 1 "$tmp/ens-ed.frames")"
if command -v mpirun >/dev/null 2>&1; then
	for s in ens ens-ed ens-fld ens-res ens-disp; do
	for np in 2 3; do
		rm -rf "$tmp/$s.np$np"
		mpirun -np 2 "$ENGINE" run "$tmp/$s.json" --out "$tmp/$s.np$np" >/dev/null 2>"$tmp/err"
		rc=$?
		if [ $np = 3 ]; then
			mpirun -np 3 "$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.np$np/checkpoint.prev.h5" --out "$tmp/$s.np$np" >/dev/null 2>>"$tmp/err"
		else
			"$ENGINE" run "$tmp/$s.json" --resume "$tmp/$s.np$np/checkpoint.prev.h5" --out "$tmp/$s.np$np" >/dev/null 2>>"$tmp/err"
		fi
		rc2=$?
		why=$(same "$tmp/$s.ref" "$tmp/$s.np$np")
		ok $(( rc == 0 && rc2 == 0 && $? == 0 ? 0 : 1 )) "$s: checkpoints written under mpirun -np 2, resumed $([ $np = 3 ] && echo 'under -np 3' || echo serially): $why $(head -c 200 "$tmp/err")"
	done
	done
	# kill -9 of the whole job at random moments, resumed under mpirun -np 2
	s=ens-kill
	ref $s
	d="$tmp/$s.kill"
	rm -rf "$d"
	kill_resume 10 0.6 mpirun -np 2
	why=$(same "$tmp/$s.ref" "$d")
	ok $(( rc == 0 && kills >= 2 && resumes >= 2 && $? == 0 ? 0 : 1 )) "$s: mpirun -np 2, $kills kill -9, $resumes resumes, exit $rc: $why"
	# SIGTERM to the ranks (as granulard sends it): checkpoint, exit 4, exact resume under -np 3
	d="$tmp/$s.term"
	rm -rf "$d"
	mpirun -np 2 "$ENGINE" run "$tmp/$s.json" --out "$d" >/dev/null 2>"$tmp/err" &
	pid=$!
	await_ckpt "$d" $pid
	sleep 0.3
	kill -TERM $(pgrep -P $pid)
	wait $pid
	rc=$?
	last=$(tail -n 1 "$d/progress.jsonl")
	mpirun -np 3 "$ENGINE" run "$tmp/$s.json" --resume "$d/checkpoint.h5" --out "$d" >/dev/null 2>>"$tmp/err"
	rc2=$?
	why=$(same "$tmp/$s.ref" "$d")
	res=$?
	case "$last" in *'"status":"interrupted"'*) st=0 ;; *) st=1 ;; esac
	ok $(( rc == 4 && st == 0 && rc2 == 0 && res == 0 ? 0 : 1 )) "$s: SIGTERM to the ranks of mpirun -np 2: exit $rc (summary interrupted), resume under -np 3 exit $rc2: $why"
fi

echo "1..$n"
[ $failed -eq 0 ]
