#!/bin/sh
# Periodic fast path against a baseline build: collisions per CPU second, ratio this build / baseline, interleaved runs, median of 5.
# usage: bench/compare.sh BASELINE_ED_BENCH THIS_ED_BENCH  (prints markdown table rows)
set -eu
base=$1
new=$2
for args in "2 10000 0.3 0.9 30 300 1e-4" "2 10000 0.8 1 50 200" "3 10976 0.45 1 50 200" "3 10976 0.1 1 20 200"; do
	ratios=""
	for r in 1 2 3 4 5; do
		# alternate which build goes first, so drifts of the machine cancel
		if [ $((r % 2)) -eq 1 ]; then
			b=$("$base" $args); n=$("$new" $args)
		else
			n=$("$new" $args); b=$("$base" $args)
		fi
		ratios="$ratios $(printf '%s\n%s\n' "$b" "$n" | /usr/bin/python3 -c '
import json, sys
b, n = (json.loads(l) for l in sys.stdin)
# per CPU second: less sensitive than wall time to other load on the machine
print("%.4f" % ((n["collisions"] / n["cpu_seconds"]) / (b["collisions"] / b["cpu_seconds"])))')"
	done
	echo "$ratios" | /usr/bin/python3 -c '
import sys
r = sorted(float(x) for x in sys.stdin.read().split())
print("| `ed_bench %s` | %.3f | %s |" % (sys.argv[1], r[len(r) // 2], ", ".join("%.3f" % x for x in r)))' "$args"
done
