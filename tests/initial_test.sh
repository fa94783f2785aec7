#!/bin/sh
# Initial states through the real program: a run continued from an earlier run's frame, placement in a region, and their bad cases (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/initial_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
PY=/usr/bin/python3

# frame FILE GROUP WHAT K N D OUT: frame K of GROUP/WHAT/value, raw little-endian doubles.
frame() {
	h5dump -d "/particles/$2/$3/value" -s "$4,0,0" -c "1,$5,$6" -b LE -o "$7" "$1" >/dev/null 2>&1
}
# frames FILE: number of frames in /particles/all.
frames() {
	h5dump -H -d /particles/all/position/value "$1" 2>/dev/null | sed -n 's/.*DATASPACE *SIMPLE { ( \([0-9]*\),.*/\1/p'
}

# continued NAME N D A.json B.json KA [DW]: B (from A's frame KA) starts in A's
# frame KA bit for bit: B's first frame equals it, positions and velocities
# (and with DW, rough particles, the DW components of the angular velocities).
continued() {
	name=$1 np=$2 d=$3
	mkdir -p "$tmp/$name"
	cp "$4" "$tmp/$name/a.json"
	cp "$5" "$tmp/$name/b.json"
	"$ENGINE" run "$tmp/$name/a.json" --out "$tmp/$name/A" >/dev/null 2>"$tmp/$name/err.a" &&
	"$ENGINE" run "$tmp/$name/b.json" --out "$tmp/$name/B" >"$tmp/$name/out.b" 2>"$tmp/$name/err.b"
	rc=$?
	k=$6
	if [ "$k" -lt 0 ]; then k=$(( $(frames "$tmp/$name/A/trajectory.h5") + k )); fi
	same=0
	for what in position velocity ${7:+angular_velocity}; do
		dd=$d; [ $what = angular_velocity ] && dd=$7
		frame "$tmp/$name/A/trajectory.h5" all $what "$k" "$np" "$dd" "$tmp/$name/a.$what" &&
		frame "$tmp/$name/B/trajectory.h5" all $what 0 "$np" "$dd" "$tmp/$name/b.$what" &&
		[ -s "$tmp/$name/a.$what" ] && cmp -s "$tmp/$name/a.$what" "$tmp/$name/b.$what" || same=1
	done
	[ $rc -eq 0 ] && [ $same -eq 0 ]
	ok $? "$name: the run from frame $6 starts in it bit for bit (exit $rc; $(cat "$tmp/$name/err.a" "$tmp/$name/err.b" | head -n 1))"
}

# 1. ed 2D periodic, inelastic: continued from the last frame.
cat >"$tmp/a1.json" <<'EOF'
{"method":"ed","dimensions":2,"particles":{"count":300,"box":[30,30],"initial":{"positions":"random"}},
 "collisions":{"restitution":0.9,"tc":1e-6},"run":{"seed":3,"until":{"time":3}},
 "output":{"every":{"time":1},"snapshots":{"every":{"time":1}}}}
EOF
cat >"$tmp/b1.json" <<'EOF'
{"method":"ed","dimensions":2,"particles":{"count":300,"box":[30,30],"initial":{"from":{"file":"A/trajectory.h5","frame":-1}}},
 "collisions":{"restitution":0.9,"tc":1e-6},"run":{"seed":5,"until":{"time":1}},
 "output":{"every":{"time":1},"snapshots":{"every":{"time":1}}}}
EOF
continued ed2d 300 2 "$tmp/a1.json" "$tmp/b1.json" -1
# a frame in the middle, counted from the start
sed 's/"frame":-1/"frame":1/' "$tmp/b1.json" >"$tmp/b1k.json"
continued ed2d-frame1 300 2 "$tmp/a1.json" "$tmp/b1k.json" 1

# 2. ed 2D bed: walls on y, gravity, placed in a region at the bottom; then continued.
cat >"$tmp/a2.json" <<'EOF'
{"method":"ed","dimensions":2,
 "particles":{"count":100,"box":[20,40],"initial":{"positions":"random","region":{"upper":[20,12]}}},
 "collisions":{"restitution":0.9,"tc":1e-4},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "gravity":[0,-1],"run":{"seed":2,"until":{"time":2}},
 "output":{"every":{"time":1},"snapshots":{"every":{"time":1}},"observables":["temperature","center_of_mass_height"]}}
EOF
sed 's/"positions":"random","region":{"upper":\[20,12\]}/"from":{"file":"A\/trajectory.h5"}/' "$tmp/a2.json" >"$tmp/b2.json"
continued ed2d-bed 100 2 "$tmp/a2.json" "$tmp/b2.json" -1
# the region was respected at time 0: every centre at y <= 12 - radius
frame "$tmp/ed2d-bed/A/trajectory.h5" all position 0 100 2 "$tmp/bed0"
"$PY" - "$tmp/bed0" <<'EOF'
import struct, sys
b = open(sys.argv[1], "rb").read()
v = struct.unpack("<%dd" % (len(b) // 8), b)
ys = v[1::2]
sys.exit(0 if len(ys) == 100 and max(ys) <= 11.5 and min(ys) >= 0.5 else 1)
EOF
ok $? "ed2d-bed: region placement keeps every particle in the bed (y <= 11.5 for radius 0.5)"

# 3. ed 3D lattice in a slab, continued.
cat >"$tmp/a3.json" <<'EOF'
{"method":"ed","dimensions":3,
 "particles":{"count":200,"box":[10,10,20],"initial":{"region":{"lower":[0,0,5],"upper":[10,10,12]}}},
 "collisions":{"restitution":1},"run":{"seed":4,"until":{"time":1}},
 "output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
cat >"$tmp/b3.json" <<'EOF'
{"method":"ed","dimensions":3,"particles":{"count":200,"box":[10,10,20],"initial":{"from":{"file":"A/trajectory.h5"}}},
 "collisions":{"restitution":1},"run":{"seed":4,"until":{"time":1}},"output":{"every":{"time":0.5}}}
EOF
continued ed3d-slab 200 3 "$tmp/a3.json" "$tmp/b3.json" -1
frame "$tmp/ed3d-slab/A/trajectory.h5" all position 0 200 3 "$tmp/slab0"
"$PY" - "$tmp/slab0" <<'EOF'
import struct, sys
b = open(sys.argv[1], "rb").read()
v = struct.unpack("<%dd" % (len(b) // 8), b)
zs = v[2::3]
sys.exit(0 if len(zs) == 200 and min(zs) >= 5.5 and max(zs) <= 11.5 else 1)
EOF
ok $? "ed3d-slab: the lattice fills the slab 5 <= z <= 12 (centres in [5.5, 11.5])"

# 4. dsmc and hsmc: continued from an ed run's frame (the same state in another method) and from their own.
for m in dsmc hsmc; do
	cat >"$tmp/a-$m.json" <<EOF
{"method":"$m","dimensions":2,"particles":{"count":400,"box":[40,40],"initial":{"positions":"random","region":{"lower":[0,10],"upper":[40,30]}}},
 "collisions":{"restitution":0.8},"run":{"seed":7,"until":{"time":2}},
 "output":{"every":{"time":1},"snapshots":{"every":{"time":1}}}}
EOF
	cat >"$tmp/b-$m.json" <<EOF
{"method":"$m","dimensions":2,"particles":{"count":400,"box":[40,40],"initial":{"from":{"file":"A/trajectory.h5","frame":-2}}},
 "collisions":{"restitution":0.8},"run":{"seed":7,"until":{"time":1}},
 "output":{"every":{"time":1},"snapshots":{"every":{"time":1}}}}
EOF
	continued "$m" 400 2 "$tmp/a-$m.json" "$tmp/b-$m.json" -2
done

# 5. Rough spheres with an obstacle: spins come from the frame too; A places in a region around the obstacle.
cat >"$tmp/a-rough.json" <<'EOF'
{"method":"ed","dimensions":3,
 "particles":{"count":150,"box":[12,12,12],"initial":{"positions":"random","region":{"upper":[12,12,8]}}},
 "collisions":{"restitution":0.9,"tc":1e-6,"rough":{"tangential_restitution":0.4}},
 "obstacles":[{"type":"slip","center":[6,6,4],"radius":2}],
 "run":{"seed":8,"until":{"time":1}},"output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
sed 's/"positions":"random","region":{"upper":\[12,12,8\]}/"from":{"file":"A\/trajectory.h5"}/' "$tmp/a-rough.json" >"$tmp/b-rough.json"
continued rough3d-obstacle 150 3 "$tmp/a-rough.json" "$tmp/b-rough.json" -1 3

# 6. Bad cases: exit 2, one line on stderr naming the key.
bad() {
	want=$1 what=$2
	"$ENGINE" run "$tmp/bad.json" >"$tmp/bad.out" 2>"$tmp/bad.err"
	rc=$?
	lines=$(wc -l <"$tmp/bad.err")
	case "$(head -n 1 "$tmp/bad.err")" in
	"$want"*) prefix=0 ;;
	*) prefix=1 ;;
	esac
	[ $rc -eq 2 ] && [ "$lines" -eq 1 ] && [ $prefix -eq 0 ]
	ok $? "$what: exit $rc, $lines line(s): $(head -n 1 "$tmp/bad.err")"
}
A1="$tmp/ed2d/A/trajectory.h5"
from_scene() {   # from_scene FROM-OBJECT [PARTICLES-EXTRA] [DIM] [COUNT] [BOX]
	cat >"$tmp/bad.json" <<EOF
{"method":"ed","dimensions":${3:-2},"particles":{"count":${4:-300},"box":${5:-[30,30]},"initial":{"from":$1}$2},
 "collisions":{"restitution":0.9,"tc":1e-6},"run":{"seed":5,"until":{"time":1}}}
EOF
}
from_scene '{"file":"nowhere.h5"}' ''
bad particles.initial.from.file "missing file"
printf 'not hdf5\n' >"$tmp/text.h5"
from_scene "{\"file\":\"$tmp/text.h5\"}" ''
bad particles.initial.from.file "not an HDF5 file"
from_scene "{\"file\":\"$tmp/ed2d/A/progress.jsonl\"}" ''
bad particles.initial.from.file "a JSON file"
from_scene "{\"file\":\"$A1\",\"frame\":4}" ''
bad particles.initial.from.frame "frame 4 of 4 frames (0..3)"
from_scene "{\"file\":\"$A1\",\"frame\":-5}" ''
bad particles.initial.from.frame "frame -5 of 4 frames"
from_scene "{\"file\":\"$A1\",\"replica\":0}" ''
bad particles.initial.from.file "replica of a single run's trajectory"
from_scene "{\"file\":\"$A1\"}" '' 2 301
bad particles.initial.from "particle count 301 against 300 in the frame"
from_scene "{\"file\":\"$A1\"}" '' 3 300 '[30,30,30]'
bad particles.initial.from "3D scene from a 2D frame"
from_scene "{\"file\":\"$A1\"}" '' 2 300 '[20,30]'
bad particles.initial.from "a box too small for the frame (particles outside)"
from_scene "{\"file\":\"$A1\"}" ',"radius":0.9' 2 300
bad particles.initial.from "larger particles overlap (ed: hard spheres)"
from_scene "{\"file\":\"$A1\"}" '' 2 300 '[30,30]'
sed -i 's/"run"/"boundaries":{"x":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},"run"/' "$tmp/bad.json"
bad particles.initial.from "walls where the frame has particles within a radius of them"
# a damaged chunk index (the 1.8 format's B-tree has no checksum): the last frame's positions recorded as
# 4 GiB; refused before HDF5 allocates that (h5u_chunks_sane(), issue 19)
cp "$A1" "$tmp/dmg.h5"
"$PY" - "$tmp/dmg.h5" <<'PYEOF'
import struct, sys
import h5py
path = sys.argv[1]
with h5py.File(path, "r") as f:
    d = f["particles/all/position/value"]
    info = d.id.get_chunk_info_by_coord((d.shape[0] - 1, 0, 0))
data = open(path, "rb").read()
key = 8 + 8 * 4   # size, filter mask, 3 + 1 offsets; then the chunk's address
hits = [i - key for i in range(len(data)) if data.startswith(struct.pack("<Q", info.byte_offset), i)
        and i >= key and struct.unpack_from("<I", data, i - key)[0] == info.size]
assert len(hits) == 1, hits
with open(path, "r+b") as f:
    f.seek(hits[0]); f.write(struct.pack("<I", 0xfff00000))
PYEOF
from_scene "{\"file\":\"$tmp/dmg.h5\"}" ''
bad "particles.initial.from.file: $tmp/dmg.h5: cannot read frame 3 (damaged chunk index)" "a damaged chunk index of the frame read"
from_scene '{"job":12}' ''
bad particles.initial.from.job "a job reference outside the daemon (no --jobs-dir)"
"$ENGINE" run "$tmp/bad.json" --jobs-dir "$tmp/nojobs" >/dev/null 2>"$tmp/bad.err"
rc=$?; grep -q "^particles.initial.from.job: cannot read $tmp/nojobs/12/trajectory.h5" "$tmp/bad.err"
ok $(( $? == 0 && rc == 2 ? 0 : 1 )) "--jobs-dir DIR: job 12 is DIR/12/trajectory.h5 (exit $rc: $(cat "$tmp/bad.err"))"
from_scene '{"file":"x.h5"}' ',"volume_fraction":0.1' 2 300
sed -i 's/"box":\[30,30\],//' "$tmp/bad.json"
sed -i 's/"from":{"file":"x.h5"}/"from":{"file":"x.h5"},"temperature":2/' "$tmp/bad.json"
bad particles.initial.temperature "temperature beside from"

# rough particles from a smooth run's frame: no spins to start from
from_scene "{\"file\":\"$A1\"}" ''
sed -i 's/"tc":1e-6}/"tc":1e-6,"rough":{"tangential_restitution":0.5}}/' "$tmp/bad.json"
bad particles.initial.from "rough particles from a smooth run's frame (no angular velocities)"
# an obstacle where the frame has particles
from_scene "{\"file\":\"$A1\"}" ''
sed -i 's/"run"/"obstacles":[{"type":"slip","center":[15,15],"radius":4}],"run"/' "$tmp/bad.json"
bad particles.initial.from "an obstacle where the frame has particles"
from_scene '{"file":"x.h5"}' ',"volume_fraction":0.1' 2 300
sed -i 's/"box":\[30,30\],//; s/"from":{"file":"x.h5"}/"from":{"file":"x.h5"},"velocity":[1,0]/' "$tmp/bad.json"
bad particles.initial.velocity "a mean flow beside from"

# The validate command makes the same checks (a scene validate accepts is one run starts).
from_scene "{\"file\":\"$A1\"}" '' 2 301
"$ENGINE" validate "$tmp/bad.json" >/dev/null 2>"$tmp/bad.err"
rc=$?; grep -q '^particles.initial.from: ' "$tmp/bad.err"
ok $(( $? == 0 && rc == 2 ? 0 : 1 )) "validate loads and checks the frame too (exit $rc)"

# Regions that cannot hold the particles, or are not in the box.
region_scene() {   # region_scene METHOD REGION POSITIONS
	cat >"$tmp/bad.json" <<EOF
{"method":"$1","dimensions":2,"particles":{"count":100,"box":[20,40],"initial":{"positions":"$3","region":$2}},
 "collisions":{"restitution":0.9},"run":{"seed":2,"until":{"time":1}}}
EOF
}
region_scene ed '{"lower":[0,-1]}' lattice
bad 'particles.initial.region.lower[1]' "region below the box"
region_scene ed '{"upper":[20,41]}' lattice
bad 'particles.initial.region.upper[1]' "region above the box"
region_scene ed '{"lower":[0,10],"upper":[20,5]}' lattice
bad 'particles.initial.region.upper[1]' "upper below lower"
region_scene ed '{"upper":[20,0.8]}' lattice
bad particles.initial.region "a region thinner than a diameter"
region_scene ed '{"upper":[20,4]}' lattice
bad particles.initial.region "100 disks on a lattice in 20 x 4"
region_scene ed '{"upper":[20,5]}' lattice
bad particles.initial.region "no lattice of 100 disks fits 20 x 5 (nearest distance below a diameter)"
grep -q 'no lattice' "$tmp/bad.err"
ok $? "... and the line says why: $(cat "$tmp/bad.err")"
region_scene ed '{"upper":[20,6]}' random
bad particles.initial.region "random placement above jamming in the region (volume fraction 0.65)"
region_scene dsmc '{"upper":[20,4]}' random
bad particles.initial.region "dsmc: region above close packing"
region_scene ed '{"upper":[20,4]}' lattice
sed -i 's/"positions":"lattice",//; s/"region"/"from":{"file":"x.h5"},"region"/' "$tmp/bad.json"
bad particles.initial.region "region beside from"

# 7. Ensembles continued replica by replica (from.replica "each"): replica r of B starts in the last frame
# of replica r of A, positions and velocities bit for bit, on 1 rank and on 2 (each rank loads its own
# replicas' frames); B's output does not depend on the rank count; a replica A lacks is the scene's error.
mkdir -p "$tmp/ens"
cat >"$tmp/ens/a.json" <<'EOF'
{"method":"ed","dimensions":2,"particles":{"count":200,"volume_fraction":0.2},
 "collisions":{"restitution":0.9},"run":{"seed":4,"replicas":3,"until":{"collisions_per_particle":10}},
 "output":{"every":{"collisions_per_particle":5},"observables":["temperature"],
   "snapshots":{"every":{"collisions_per_particle":5}}}}
EOF
sed 's|"volume_fraction":0.2}|"volume_fraction":0.2,"initial":{"from":{"file":"A/trajectory.h5","replica":"each"}}}|' \
	"$tmp/ens/a.json" >"$tmp/ens/b.json"
"$ENGINE" run "$tmp/ens/a.json" --out "$tmp/ens/A" >/dev/null 2>"$tmp/ens/err.a" &&
	"$ENGINE" run "$tmp/ens/b.json" --out "$tmp/ens/B" >"$tmp/ens/out.b" 2>"$tmp/ens/err.b"
ok $? "ensemble of 3 replicas continued from an ensemble's trajectory (from.replica \"each\") $(head -c 200 "$tmp/ens/err.b")"
if command -v mpirun >/dev/null 2>&1; then
	OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 \
		mpirun -np 2 "$ENGINE" run "$tmp/ens/b.json" --out "$tmp/ens/B2" >"$tmp/ens/out.b2" 2>"$tmp/ens/err.b2"
	ok $? "... the same under mpirun -np 2 $(head -c 200 "$tmp/ens/err.b2")"
	for k in 1 2; do
		f="$tmp/ens/out.b"; [ $k = 2 ] && f="$tmp/ens/out.b2"
		sed 's/"wall_seconds":[^,}]*//; s/"[a-z_]*_per_second":[^,}]*//g' "$f" >"$tmp/ens/p$k"
	done
	cmp -s "$tmp/ens/p1" "$tmp/ens/p2"
	ok $? "... its progress records equal the 1-rank run's (wall-clock fields aside)"
else
	n=$((n + 1)); echo "ok $n # SKIP mpirun not installed"
	n=$((n + 1)); echo "ok $n # SKIP mpirun not installed"
fi
for r in 0 1 2; do
	for out in B B2; do
		[ -f "$tmp/ens/$out/trajectory.h5" ] || continue
		last=$(( $(h5dump -H -d /particles/replica_$r/position/value "$tmp/ens/A/trajectory.h5" 2>/dev/null |
			sed -n 's/.*DATASPACE *SIMPLE { ( \([0-9]*\),.*/\1/p') - 1 ))
		same=0
		for w in position velocity; do
			{ frame "$tmp/ens/A/trajectory.h5" replica_$r $w "$last" 200 2 "$tmp/ens/a.$w" &&
				frame "$tmp/ens/$out/trajectory.h5" replica_$r $w 0 200 2 "$tmp/ens/b.$w" &&
				[ -s "$tmp/ens/a.$w" ] && cmp -s "$tmp/ens/a.$w" "$tmp/ens/b.$w"; } || same=1
		done
		ok $same "replica $r of $out starts in A's replica $r last frame (frame $last), positions and velocities bit for bit"
	done
done
sed 's/"replicas":3/"replicas":4/' "$tmp/ens/b.json" >"$tmp/ens/bad.json"
( cd "$tmp/ens" && "$ENGINE" run bad.json >bad.out 2>bad.err )
rc=$?
[ $rc -eq 2 ] && [ "$(wc -l <"$tmp/ens/bad.err")" -eq 1 ] && grep -q '^particles.initial.from.*replica_3' "$tmp/ens/bad.err"
ok $? "4 replicas from a trajectory of 3: exit $rc, $(head -n 1 "$tmp/ens/bad.err")"

echo "1..$n"
[ $failed -eq 0 ]
