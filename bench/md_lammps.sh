#!/bin/sh
# Soft-sphere MD against LAMMPS on one core: bench/md_bench's settling bed (NX x NY x NZ frictional spheres,
# linear law k_n = 2e5, e = 0.5, mu = 0.5, k_t = 2/7 k_n, eta_t = eta_n sqrt(2/7), floor and lid, gravity
# 100, dt = t_c/50) and the same bed in LAMMPS (bench/md_bed.lmp: gran/hooke/history with gamma = eta /
# m_eff, wall/gran with the same law, nve/sphere, skin 0.1 = 0.2 R), same initial positions and velocities.
# Both: STEPS untimed, then STEPS timed; particle-steps per CPU second (LAMMPS: its loop time times its
# "% CPU use"), 5 interleaved pairs, median ratio ours / LAMMPS.
# usage: bench/md_lammps.sh [NX NY NZ STEPS]   (default 20 25 20 2000: 10^4 spheres)
set -eu
src=$(cd "$(dirname "$0")/.." && pwd)
nx=${1:-20} ny=${2:-25} nz=${3:-20} steps=${4:-2000}
command -v lmp >/dev/null 2>&1 || { echo "md_lammps: lmp not found (Debian package lammps)" >&2; exit 2; }
mdb=${MD_BENCH:-$src/bench/md_bench}   # an out-of-tree build: MD_BENCH=BUILD/bench/md_bench
[ -x "$mdb" ] || { echo "md_lammps: build bench/md_bench first (make bench/md_bench)" >&2; exit 2; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/md_lammps.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
/usr/bin/python3 - "$nx" "$ny" "$nz" >"$tmp/bed.data" <<'PY'
import math, sys
nx, ny, nz = (int(a) for a in sys.argv[1:4])
a = 1.05; n = nx * ny * nz; s = 42; M = (1 << 64) - 1
rows = []
for i in range(n):   # md_bench's lattice and its LCG velocities, bit for bit
    c = [i % nx, i // (nx * nz), (i // nx) % nz]; p = []; v = []
    for k in range(3):
        s = (s * 6364136223846793005 + 1442695040888963407) & M
        p.append((c[k] + 0.5) * a); v.append(0.1 * ((s >> 11) * 2.0 ** -53 - 0.5))
    rows.append((p, v))
print('md_bench bed\n\n%d atoms\n1 atom types\n' % n)
print('0 %.17g xlo xhi\n0 %.17g ylo yhi\n0 %.17g zlo zhi\n\nAtoms # sphere\n' % (nx * a, 2 * ny * a, nz * a))
for i, (p, v) in enumerate(rows):   # diameter 1, density 6/pi: mass 1
    print('%d 1 1.0 %.17g %.17g %.17g %.17g' % (i + 1, 6 / math.pi, p[0], p[1], p[2]))
print('\nVelocities\n')
for i, (p, v) in enumerate(rows):
    print('%d %.17g %.17g %.17g 0 0 0' % (i + 1, v[0], v[1], v[2]))
PY
ours() { "$mdb" "$nx" "$ny" "$nz" "$steps" | sed -n 's/.*(wall) \([0-9.e+]*\) (cpu) contacts\/particle \([0-9.]*\).*/\1 \2/p'; }
theirs() {
	lmp -in "$src/bench/md_bed.lmp" -var data "$tmp/bed.data" -var steps "$steps" -log none >"$tmp/lmp.out" 2>&1
	/usr/bin/python3 - "$tmp/lmp.out" "$((nx * ny * nz))" "$steps" <<'PY'
import re, sys
t = open(sys.argv[1]).read(); n, st = int(sys.argv[2]), int(sys.argv[3])
loop = re.findall(r'Loop time of ([0-9.e+-]+) on', t)[-1]; cpu = re.findall(r'([0-9.]+)% CPU use', t)[-1]
rows = [l.split() for l in t.splitlines() if re.match(r'^\s+\d+\s+\S+\s+\S+\s*$', l)]
# thermo values are per atom in lj units (thermo_modify norm yes): contact/atom summed / N, each contact twice
print('%.6g %.3f' % (n * st / (float(loop) * float(cpu) / 100), float(rows[-1][2]) / 2))
PY
}
ratios=""
for r in 1 2 3 4 5; do
	if [ $((r % 2)) -eq 1 ]; then a=$(ours); b=$(theirs); else b=$(theirs); a=$(ours); fi
	echo "# run $r: ours ${a%% *} /cpu s (contacts/particle ${a##* }), LAMMPS ${b%% *} /cpu s (${b##* })"
	ratios="$ratios $(/usr/bin/python3 -c "print('%.4f' % (${a%% *} / ${b%% *}))")"
done
echo "$ratios" | /usr/bin/python3 -c '
import sys
r = sorted(float(x) for x in sys.stdin.read().split())
print("| `bench/md_lammps.sh %s` | %.3f | %s |" % (sys.argv[1], r[len(r) // 2], ", ".join("%.3f" % x for x in r)))' "$nx $ny $nz $steps"
