#!/bin/sh
# make bench: the parallel ED core (engine/par/pedmpi) against the serial engine on one system (issue 14); prints a markdown section.
# usage: bench/ped_bench.sh BUILD_DIR DIM N PHI T_END [RANKS...]
# P = 1: the core without communication against the serial engine (its cost per event).
# Speed-up at 2 ranks: wall time of the serial engine / wall time of pedmpi over mpirun -np 2 (MPI waits yield the
# core: on a shared machine busy polling loses it to other processes at every round), the same initial
# state and horizon (the same collisions), interleaved runs, median of 5. Then one oversubscribed run per rank
# count in RANKS (default 4 8 16) for the figures that do not depend on free cores.
set -eu
build=$1; dim=$2; n=$3; phi=$4; tend=$5
shift 5
ranks=${*:-4 8 16}
pb="$build/bench/ped_bench"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ped_bench.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
echo "### ${dim}D, N = $n, volume fraction $phi, elastic, to t = $tend"
echo
echo "Commands: \`$pb serial $dim $n $phi 1 $tend\` and \`mpirun --mca mpi_yield_when_idle 1 [--oversubscribe] -np P $pb par $dim $n $phi 1 $tend\`; load average at"
echo "the start: $(cut -d' ' -f1-3 /proc/loadavg)."
echo
for r in 1 2 3 4 5; do
	if [ $((r % 2)) -eq 1 ]; then
		"$pb" serial "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/s"
		mpirun --mca mpi_yield_when_idle 1 -np 2 "$pb" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/p"
		mpirun --mca mpi_yield_when_idle 1 -np 1 "$pb" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/q"
	else
		mpirun --mca mpi_yield_when_idle 1 -np 1 "$pb" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/q"
		mpirun --mca mpi_yield_when_idle 1 -np 2 "$pb" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/p"
		"$pb" serial "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/s"
	fi
done
for P in $ranks; do
	mpirun --oversubscribe --mca mpi_yield_when_idle 1 -np "$P" "$pb" par "$dim" "$n" "$phi" 1 "$tend" >>"$tmp/o"
done
/usr/bin/python3 - "$tmp/s" "$tmp/p" "$tmp/o" "$tmp/q" <<'PY'
import json, sys
s = [json.loads(l) for l in open(sys.argv[1])]
p = [json.loads(l) for l in open(sys.argv[2])]
o = [json.loads(l) for l in open(sys.argv[3])]
q = [json.loads(l) for l in open(sys.argv[4])]
ratios = sorted(a["wall"] / b["wall"] for a, b in zip(s, p))
same = all(x["collisions"] == s[0]["collisions"] for x in s + p + o + q) and all(x["rc"] == 0 for x in p + o + q)
print("Same collision count (%d) in every run: %s. Serial wall times (s): %s; 2 ranks: %s." % (
    s[0]["collisions"], "yes" if same else "NO",
    ", ".join("%.2f" % x["wall"] for x in s), ", ".join("%.2f" % x["wall"] for x in p)))
print()
print("Speed-up at 2 ranks (serial wall / parallel wall, interleaved, median of 5): **%.3f** (all: %s)" % (
    ratios[len(ratios) // 2], ", ".join("%.3f" % r for r in ratios)))
print()
r1 = sorted(a["wall"] / b["wall"] for a, b in zip(s, q))
print("The parallel core on 1 rank (no communication) against the serial engine, serial wall / its wall, median of 5: **%.3f** (all: %s)" % (
    r1[len(r1) // 2], ", ".join("%.3f" % r for r in r1)))
print()
print("| ranks | rounds | events per round | events processed per committed | rollbacks | events per rollback | messages per event | bytes per event | load imbalance (max/mean events) | wall (s) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for x in [p[0]] + o:
    print("| %d | %d | %.1f | %.4f | %d | %s | %.5f | %.2f | %.3f | %.2f |" % (
        x["P"], x["rounds"], x["events_per_round"], x["done_per_committed"], x["rollbacks"],
        "%.0f" % x["events_per_rollback"] if x["rollbacks"] else "none", x["messages_per_event"],
        x["bytes_per_event"], x["imbalance"], x["wall"]))
print()
PY
