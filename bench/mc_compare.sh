#!/bin/sh
# DSMC/HSMC periodic path against a baseline build: moves per CPU second, ratio this build / baseline, interleaved runs, median of 5.
# usage: bench/mc_compare.sh BASELINE_DSMC_BENCH THIS_DSMC_BENCH  (prints markdown table rows)
# Both binaries must print cpu_seconds and moves (bench/dsmc_bench.c of this tree, linked against each build's
# engine/libgranular.a).
set -eu
base=$1
new=$2
for args in "dsmc 2 100000 0.05 0.9 200" "dsmc 3 100000 0.05 0.9 200" "dsmc 3 100000 0.25 0.9 200 enskog" \
	"hsmc 2 100000 0.4 0.9 200 cba" "hsmc 3 100000 0.25 0.9 200 cba"; do
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
print("%.4f" % ((n["moves"] / n["cpu_seconds"]) / (b["moves"] / b["cpu_seconds"])))')"
	done
	echo "$ratios" | /usr/bin/python3 -c '
import sys
r = sorted(float(x) for x in sys.stdin.read().split())
print("| `dsmc_bench %s` | %.3f | %s |" % (sys.argv[1], r[len(r) // 2], ", ".join("%.3f" % x for x in r)))' "$args"
done
