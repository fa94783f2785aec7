#!/bin/sh
# The parallel ED core of two builds (e.g. before and after a change, issue 14) against the serial engine and each other:
# wall times of the serial engine, of each build's core on 2 MPI ranks and of build A's core on 1 rank, the same
# initial state and horizon (the same collisions, checked), interleaved (the order rotates), median of 5 ratios.
# usage: bench/ped_ab.sh BUILD_A BUILD_B DIM N PHI T_END   (BUILD_*/bench/ped_bench; the serial engine from BUILD_A)
set -eu
a=$1/bench/ped_bench; b=$2/bench/ped_bench; dim=$3; n=$4; phi=$5; tend=$6
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ped_ab.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
one() {
	case $1 in
	s) "$a" serial "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/s" ;;
	a2) mpirun --mca mpi_yield_when_idle 1 -np 2 "$a" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/a2" ;;
	b2) mpirun --mca mpi_yield_when_idle 1 -np 2 "$b" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/b2" ;;
	a1) mpirun --mca mpi_yield_when_idle 1 -np 1 "$a" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/a1" ;;
	esac
}
echo "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in 1 2 3 4 5; do
	case $r in
	1) order="s a2 b2 a1" ;; 2) order="a2 b2 a1 s" ;; 3) order="b2 a1 s a2" ;; 4) order="a1 s a2 b2" ;; *) order="s b2 a2 a1" ;;
	esac
	for x in $order; do one "$x"; done
done
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
d = sys.argv[1]
s, a2, b2, a1 = ([json.loads(l) for l in open("%s/%s" % (d, f))] for f in ("s", "a2", "b2", "a1"))
same = all(x["collisions"] == s[0]["collisions"] for x in s + a2 + b2 + a1) and all(x["rc"] == 0 for x in a2 + b2 + a1)
med = lambda v: sorted(v)[len(v) // 2]
def row(label, num, den):
    r = [x["wall"] / y["wall"] for x, y in zip(num, den)]
    print("| %s | **%.3f** | %s |" % (label, med(r), ", ".join("%.3f" % v for v in sorted(r))))
print("Same collision count (%d) in every run: %s. Rounds at 2 ranks: A %d, B %d." % (
    s[0]["collisions"], "yes" if same else "NO", a2[0]["rounds"], b2[0]["rounds"]))
print()
print("| ratio of wall times | median | the 5 |")
print("|---|---|---|")
row("serial / A on 2 ranks (speed-up of A)", s, a2)
row("serial / B on 2 ranks (speed-up of B)", s, b2)
row("B on 2 ranks / A on 2 ranks (A's gain over B)", b2, a2)
row("A on 1 rank / A on 2 ranks", a1, a2)
row("serial / A on 1 rank", s, a1)
print()
PY
