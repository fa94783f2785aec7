#!/bin/sh
# The parallel ED core's round, message and rollback counts (issue 14), border events in global time order (window 0,
# the scheme before the optimistic window) against the optimistic window (ped.h's default), P ranks simulated in one
# process (ped_bench sim: the same rounds, rollbacks and messages as over MPI, without MPI's latency); prints a
# markdown table. Counts only: its wall times mean nothing.
# usage: bench/ped_counts.sh BUILD_DIR DIM N PHI T_END [RANKS...]   (default ranks 2 4 8 16; sync interval 0.05)
set -eu
build=$1; dim=$2; n=$3; phi=$4; tend=$5
shift 5
ranks=${*:-2 4 8 16}
pb="$build/bench/ped_bench"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ped_counts.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
for P in $ranks; do
	for w in 0 -1; do
		"$pb" sim "$P" "$dim" "$n" "$phi" 1 "$tend" 0.05 "$w" >>"$tmp/o"
	done
done
echo "### ${dim}D, N = $n, volume fraction $phi, elastic, to t = $tend: \`bench/ped_counts.sh BUILD $dim $n $phi $tend $ranks\`"
echo
/usr/bin/python3 - "$tmp/o" <<'PY'
import json, sys
o = [json.loads(l) for l in open(sys.argv[1])]
same = all(x["collisions"] == o[0]["collisions"] and x["rc"] == 0 for x in o)
print("Same collision count (%d) in every run: %s." % (o[0]["collisions"], "yes" if same else "NO"))
print()
print("| ranks | scheme | global rounds | events per round | rounds per event | messages per event | bytes per event | rollbacks | syncs | rollbacks per sync | events re-done per committed |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for x in o:
    print("| %d | %s | %d | %.1f | %.4f | %.4f | %.1f | %d | %d | %.3f | %.4f |" % (
        x["P"], "global order" if x["window"] == 0 else "optimistic", x["rounds"], x["events_per_round"],
        1.0 / x["events_per_round"], x["messages_per_event"], x["bytes_per_event"], x["rollbacks"], x["syncs"],
        x["rollbacks"] / x["syncs"] if x["syncs"] else 0.0, x["done_per_committed"] - 1.0))
print()
PY
