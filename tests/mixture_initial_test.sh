#!/bin/sh
# Initial states of mixtures (particles.species) through the real program: random and lattice placement in a region, and a run continued from a frame (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/mixture_initial_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
PY=/usr/bin/python3

# dump FILE DATASET OUT [START COUNT]: raw little-endian values of a dataset (a hyperslab with START, COUNT).
dump() {
	if [ $# -gt 3 ]; then
		h5dump -d "$2" -s "$4" -c "$5" -b LE -o "$3" "$1" >/dev/null 2>&1
	else
		h5dump -d "$2" -b LE -o "$3" "$1" >/dev/null 2>&1
	fi
}

# inregion NAME DIR N D LO HI COUNTS [OBST]: frame 0 of DIR's trajectory: every
# particle's centre at least its own radius (diameter / 2 from the file)
# inside the region [LO, HI] (comma lists), no two particles closer than the
# sum of their radii (minimum image on the periodic axes, here all but the
# walled y of the 2D scenes: BOX), the species counts COUNTS (comma list),
# and with OBST (cx,cy,R) every particle clear of the obstacle by its radius.
inregion() {
	name=$1 dir=$2 np=$3 d=$4
	dump "$dir/trajectory.h5" /particles/all/position/value "$tmp/$name.pos" "0,0,0" "1,$np,$d" &&
	dump "$dir/trajectory.h5" /particles/all/diameter "$tmp/$name.diam" &&
	dump "$dir/trajectory.h5" /particles/all/species "$tmp/$name.spc" &&
	"$PY" - "$tmp/$name" "$np" "$d" "$5" "$6" "$7" "$8" "$9" <<'EOF'
import struct, sys
base, n, d = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
lo = [float(x) for x in sys.argv[4].split(",")]
hi = [float(x) for x in sys.argv[5].split(",")]
counts = [int(x) for x in sys.argv[6].split(",")]
box = [float(x) for x in sys.argv[7].split(",")]
periodic = [b > 0 for b in box]   # negative edge: a walled axis
box = [abs(b) for b in box]
obst = [float(x) for x in sys.argv[8].split(",")] if sys.argv[8] else None
def read(f, fmt):
    b = open(f, "rb").read()
    return struct.unpack("<%d%s" % (len(b) // struct.calcsize(fmt), fmt), b)
p = read(base + ".pos", "d"); r = [x / 2 for x in read(base + ".diam", "d")]; s = read(base + ".spc", "i")
bad = []
if len(p) != n * d or len(r) != n or len(s) != n:
    bad.append("sizes %d %d %d" % (len(p), len(r), len(s)))
else:
    got = [s.count(k) for k in range(len(counts))]
    if got != counts:
        bad.append("species counts %s, want %s" % (got, counts))
    for i in range(n):
        for a in range(d):
            x = p[i * d + a]
            # a region spanning a periodic axis whole leaves it periodic: any centre in [0, L)
            whole = periodic[a] and lo[a] == 0 and hi[a] == box[a]
            if not (0 <= x < box[a] if whole else lo[a] + r[i] <= x <= hi[a] - r[i]):
                bad.append("particle %d axis %d at %.15g, radius %g, region [%g, %g]" % (i, a, x, r[i], lo[a], hi[a]))
        if obst:
            dd = sum((p[i * d + a] - obst[a]) ** 2 for a in range(d)) ** 0.5
            if dd < obst[d] + r[i]:
                bad.append("particle %d overlaps the obstacle (%.15g < %.15g)" % (i, dd, obst[d] + r[i]))
    for i in range(n):
        for j in range(i):
            q = 0.0
            for a in range(d):
                x = p[i * d + a] - p[j * d + a]
                if periodic[a]:
                    x -= box[a] * round(x / box[a])
                q += x * x
            if q < (r[i] + r[j]) ** 2:
                bad.append("particles %d and %d overlap (%.15g < %.15g)" % (j, i, q ** 0.5, r[i] + r[j]))
    if len(set(r)) < 3:
        bad.append("expected several radii, found %s" % sorted(set(r)))
print("# " + ("; ".join(bad[:3]) if bad else "all %d particles in the region, no overlaps" % n))
sys.exit(1 if bad else 0)
EOF
}

# 1. 2D, walls on y and gravity, random placement of two species and a polydisperse one in a region.
cat >"$tmp/a1.json" <<'EOF'
{"method":"ed","dimensions":2,
 "particles":{"species":[{"name":"big","count":60,"radius":1.0,"mass":4},{"name":"small","count":200,"radius":0.4,"mass":1},
   {"name":"poly","count":100,"radius_range":[0.3,0.7],"mass":1}],
  "box":[30,40],"initial":{"positions":"random","region":{"lower":[2,1],"upper":[28,32]}}},
 "collisions":{"restitution":0.9,"tc":1e-4},
 "boundaries":{"y":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},
 "gravity":[0,-1],"run":{"seed":2,"until":{"time":1}},
 "output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
"$ENGINE" run "$tmp/a1.json" --out "$tmp/A1" >/dev/null 2>"$tmp/err1"
ok $? "mix2d-bed: runs from random placement in a region ($(head -n 1 "$tmp/err1"))"
inregion mix2d-bed "$tmp/A1" 360 2 2,1 28,32 60,200,100 30,-40 ""
ok $? "mix2d-bed: every particle its own radius inside the region, no overlaps, 60/200/100 per species"

# 2. 2D periodic with an obstacle: random placement around it, dense enough that sizes matter.
cat >"$tmp/a2.json" <<'EOF'
{"method":"ed","dimensions":2,
 "particles":{"species":[{"name":"a","count":150,"radius":0.8,"mass":2},{"name":"b","count":300,"radius_range":[0.2,0.5],"mass":1}],
  "box":[40,40],"initial":{"positions":"random","region":{"lower":[0,5],"upper":[40,35]}}},
 "collisions":{"restitution":1},"obstacles":[{"type":"slip","center":[20,20],"radius":4}],
 "run":{"seed":9,"until":{"time":0.5}},"output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
"$ENGINE" run "$tmp/a2.json" --out "$tmp/A2" >/dev/null 2>"$tmp/err2"
ok $? "mix2d-obstacle: runs from random placement in a region around an obstacle ($(head -n 1 "$tmp/err2"))"
inregion mix2d-obstacle "$tmp/A2" 450 2 0,5 40,35 150,300 40,40 20,20,4
ok $? "mix2d-obstacle: in the region (x spans the periodic axis whole), clear of the obstacle, no overlaps"

# 3. 3D lattice in a slab: the lattice of the largest radius, sites shuffled among the species.
cat >"$tmp/a3.json" <<'EOF'
{"method":"ed","dimensions":3,
 "particles":{"species":[{"name":"a","count":100,"radius":0.5,"mass":1},{"name":"b","count":100,"radius_range":[0.2,0.4],"mass":0.5}],
  "box":[10,10,20],"initial":{"region":{"lower":[0,0,5],"upper":[10,10,12]}}},
 "collisions":{"restitution":1},"run":{"seed":4,"until":{"time":0.5}},
 "output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
"$ENGINE" run "$tmp/a3.json" --out "$tmp/A3" >/dev/null 2>"$tmp/err3"
ok $? "mix3d-slab: runs from a lattice in a region ($(head -n 1 "$tmp/err3"))"
inregion mix3d-slab "$tmp/A3" 200 3 0,0,5 10,10,12 100,100 10,10,20 ""
ok $? "mix3d-slab: every particle its own radius inside the slab, no overlaps, 100/100 per species"
# the species mix over the lattice: both species in the lower and in the upper half of the slab
"$PY" - "$tmp/mix3d-slab" <<'EOF'
import struct, sys
b = open(sys.argv[1] + ".pos", "rb").read(); p = struct.unpack("<%dd" % (len(b) // 8), b)
b = open(sys.argv[1] + ".spc", "rb").read(); s = struct.unpack("<%di" % (len(b) // 4), b)
low = [s[i] for i in range(len(s)) if p[3 * i + 2] < 8.5]
sys.exit(0 if 0 in low and 1 in low and len(set(s)) == 2 and 0 < len(low) < len(s) else 1)
EOF
ok $? "mix3d-slab: the species mix over the lattice (both in the lower half of the slab)"

# 4. A mixture continued from its own frames starts in them bit for bit (as tests/initial_test.sh for one species).
# frame FILE WHAT K N D OUT: frame K of /particles/all/WHAT/value.
frame() { dump "$1" "/particles/all/$2/value" "$6" "$3,0,0" "1,$4,$5"; }
frames() {
	h5dump -H -d /particles/all/position/value "$1" 2>/dev/null | sed -n 's/.*DATASPACE *SIMPLE { ( \([0-9]*\),.*/\1/p'
}
# continued NAME N D A-DIR B.json K [DW]: B (from A-DIR's frame K) starts in it bit for bit (with DW, rough
# particles, the DW components of the angular velocities too).
continued() {
	name=$1 np=$2 d=$3 adir=$4 k=$6 dw=${7:-}
	"$ENGINE" run "$5" --out "$tmp/$name.B" >/dev/null 2>"$tmp/$name.err"
	rc=$?
	if [ "$k" -lt 0 ]; then k=$(( $(frames "$adir/trajectory.h5") + k )); fi
	same=0
	for what in position velocity ${dw:+angular_velocity}; do
		dd=$d; [ $what = angular_velocity ] && dd=$dw
		frame "$adir/trajectory.h5" $what "$k" "$np" "$dd" "$tmp/$name.a.$what" &&
		frame "$tmp/$name.B/trajectory.h5" $what 0 "$np" "$dd" "$tmp/$name.b.$what" &&
		[ -s "$tmp/$name.a.$what" ] && cmp -s "$tmp/$name.a.$what" "$tmp/$name.b.$what" || same=1
	done
	# and the diameters it wrote are the frame's
	dump "$adir/trajectory.h5" /particles/all/diameter "$tmp/$name.a.diam" &&
	dump "$tmp/$name.B/trajectory.h5" /particles/all/diameter "$tmp/$name.b.diam" &&
	cmp -s "$tmp/$name.a.diam" "$tmp/$name.b.diam" || same=1
	[ $rc -eq 0 ] && [ $same -eq 0 ]
	ok $? "$name: the run from frame $6 starts in it bit for bit, same diameters (exit $rc; $(head -n 1 "$tmp/$name.err"))"
}
sed 's|"positions":"random","region":{"lower":\[2,1\],"upper":\[28,32\]}|"from":{"file":"A1/trajectory.h5","frame":-1}|' \
	"$tmp/a1.json" >"$tmp/b1.json"
continued mix2d-bed-from 360 2 "$tmp/A1" "$tmp/b1.json" -1
sed 's|"region":{"lower":\[0,0,5\],"upper":\[10,10,12\]}|"from":{"file":"A3/trajectory.h5","frame":0}|' \
	"$tmp/a3.json" >"$tmp/b3.json"
continued mix3d-slab-from 200 3 "$tmp/A3" "$tmp/b3.json" 0
# rough mixture between walls under gravity, placed in a region: continued with its spins
cat >"$tmp/a4.json" <<'EOF'
{"method":"ed","dimensions":3,
 "particles":{"species":[{"name":"a","count":80,"radius":0.6,"mass":2},{"name":"b","count":120,"radius_range":[0.3,0.5],"mass":1}],
  "box":[10,10,16],"initial":{"positions":"random","region":{"upper":[10,10,9]},"rotational_temperature":0.5}},
 "collisions":{"restitution":0.9,"tc":1e-4,"rough":{"tangential_restitution":0.4}},
 "boundaries":{"z":{"type":"walls","lower":{"type":"specular"},"upper":{"type":"specular"}}},"gravity":[0,0,-0.5],
 "run":{"seed":6,"until":{"time":1}},"output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
"$ENGINE" run "$tmp/a4.json" --out "$tmp/A4" >/dev/null 2>"$tmp/err4"
inregion rough3d-bed "$tmp/A4" 200 3 0,0,0 10,10,9 80,120 10,10,-16 ""
ok $? "rough3d-bed: a rough mixture placed in a region (its own radius from the floor and the region's top)"
sed 's|"positions":"random","region":{"upper":\[10,10,9\]},"rotational_temperature":0.5|"from":{"file":"A4/trajectory.h5"}|' "$tmp/a4.json" >"$tmp/b4.json"
continued rough3d-bed-from 200 3 "$tmp/A4" "$tmp/b4.json" -1 3

# 5. Bad cases: exit 2, one line on stderr naming the key.
bad() {
	"$ENGINE" run "$1" >/dev/null 2>"$tmp/bad.err"
	rc=$?
	lines=$(wc -l <"$tmp/bad.err")
	case "$(head -n 1 "$tmp/bad.err")" in
	"$2"*) prefix=0 ;;
	*) prefix=1 ;;
	esac
	[ $rc -eq 2 ] && [ "$lines" -eq 1 ] && [ $prefix -eq 0 ]
	ok $? "$3: exit $rc, $lines line(s): $(head -n 1 "$tmp/bad.err")"
}
# another seed draws other polydisperse radii: the frame's diameters do not match (particle 260: the first polydisperse one)
sed 's/"seed":2/"seed":3/' "$tmp/b1.json" >"$tmp/bad1.json"
bad "$tmp/bad1.json" "particles.initial.from: particle 260 has diameter" "a polydisperse mixture from a frame of another seed"
# a species of another radius: the diameters do not match
sed 's/{"name":"big","count":60,"radius":1.0,"mass":4}/{"name":"big","count":60,"radius":0.9,"mass":4}/' "$tmp/b1.json" >"$tmp/bad2.json"
bad "$tmp/bad2.json" "particles.initial.from: particle 0 has diameter" "a mixture whose radii differ from the frame's"
# a one-species frame (constant diameters 1) into a mixture of the same count
cat >"$tmp/one.json" <<'EOF'
{"method":"ed","dimensions":3,"particles":{"count":200,"box":[10,10,20]},"collisions":{"restitution":1},
 "run":{"seed":4,"until":{"time":0.5}},"output":{"every":{"time":0.5},"snapshots":{"every":{"time":0.5}}}}
EOF
"$ENGINE" run "$tmp/one.json" --out "$tmp/ONE" >/dev/null 2>&1
sed 's|A3/trajectory.h5|ONE/trajectory.h5|' "$tmp/b3.json" >"$tmp/bad3.json"
bad "$tmp/bad3.json" "particles.initial.from: particle 100 has diameter" "a mixture from a one-species frame of other diameters"

echo "1..$n"
[ $failed -eq 0 ]
