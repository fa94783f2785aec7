#!/bin/sh
# Two builds of the engine give the same decomposed dsmc/hsmc states (docs/benchmarks.md, "the ring sort"):
# four scenes (3D dsmc N = 150000; 2D dsmc/CBA N = 40000, nu 0.3; 2D hsmc/CBA N = 20000, nu 0.75; 3D hsmc/CBA
# N = 30000, nu 0.45) with --split and under mpirun -np 2 and 3, --out; the progress records (wall clock,
# rates and memory_bytes removed) and the SHA-256 of every dataset of trajectory.h5 compared. Prints one
# line per run and "same" or the differing files; exit 1 on a difference.
# usage: bench/dsmcp_same.sh BASE_ENGINE NEW_ENGINE
set -u
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dsmcp_same.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/a.json" <<'J'
{"method":"dsmc","dimensions":3,"particles":{"count":150000,"volume_fraction":0.05,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"run":{"seed":11,"until":{"time":2}},
 "output":{"every":{"time":0.5},"snapshots":{"every":{"time":1}},"observables":["kinetic_energy","temperature","collision_rate"]}}
J
cat >"$tmp/b.json" <<'J'
{"method":"dsmc","dimensions":2,"particles":{"count":40000,"volume_fraction":0.3,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.8},"dsmc":{"correction":"cba"},"run":{"seed":8,"until":{"collisions_per_particle":4}},
 "output":{"every":{"time":0.2},"snapshots":{"every":{"time":0.5}},"observables":["kinetic_energy","collision_rate"]}}
J
cat >"$tmp/c.json" <<'J'
{"method":"hsmc","dimensions":2,"particles":{"count":20000,"volume_fraction":0.75,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"hsmc":{"cell_size":2},"run":{"seed":4,"until":{"time":0.5}},
 "output":{"every":{"time":0.1},"snapshots":{"every":{"time":0.25}},"observables":["kinetic_energy","collision_rate"]}}
J
cat >"$tmp/d.json" <<'J'
{"method":"hsmc","dimensions":3,"particles":{"count":30000,"volume_fraction":0.45,"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9},"hsmc":{"cell_size":2,"correction":"cba"},"run":{"seed":6,"until":{"time":0.5}},
 "output":{"every":{"time":0.1},"snapshots":{"every":{"time":0.25}},"observables":["kinetic_energy","collision_rate"]}}
J
digest() {   # engine scene np tag
	o="$tmp/o_$4"
	rm -rf "$o"
	if [ "$3" = 1 ]; then "$1" run "$2" --split --out "$o" >"$tmp/p_$4" 2>/dev/null
	else mpirun --oversubscribe -np "$3" "$1" run "$2" --out "$o" >"$tmp/p_$4" 2>/dev/null; fi
	echo "rc=$?"
	sed 's/"wall_seconds":[^,}]*//; s/"events_per_second":[^,}]*//; s/"collisions_per_second":[^,}]*//;
	     s/"memory_bytes":[^,}]*//' "$tmp/p_$4"
	/usr/bin/python3 - "$o/trajectory.h5" <<'PY'
import sys, h5py, hashlib, numpy as np
def walk(g, p=""):
    for k in sorted(g):
        o = g[k]
        if isinstance(o, h5py.Dataset):
            print(p + "/" + k, hashlib.sha256(np.asarray(o[()]).tobytes()).hexdigest())
        else:
            walk(o, p + "/" + k)
walk(h5py.File(sys.argv[1], "r"))
PY
	rm -rf "$o"
}
bad=0
for s in a b c d; do
	for np in 1 2 3; do
		digest "$1" "$tmp/$s.json" $np base >"$tmp/base"
		digest "$2" "$tmp/$s.json" $np new >"$tmp/new"
		if cmp -s "$tmp/base" "$tmp/new" && grep -q '"type":"summary"' "$tmp/new"; then
			echo "scene $s, $np rank(s): same ($(grep -c '"progress"' "$tmp/new") records, $(grep -c '^/' "$tmp/new") datasets)"
		else
			echo "scene $s, $np rank(s): DIFFERENT"; bad=1
		fi
	done
done
exit $bad
