#!/bin/sh
# A/B of two bench binaries: a counter per CPU second, ratio this build / baseline, interleaved runs, median of 5.
# usage: bench/ab.sh BASELINE THIS COUNTER LABEL ARGS...  (one markdown table row per ARGS, each ARGS one
# quoted string of the binaries' arguments). Both binaries print one JSON line with cpu_seconds and COUNTER.
set -eu
base=$1
new=$2
counter=$3
label=$4
shift 4
for args in "$@"; do
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
c = sys.argv[1]
b, n = (json.loads(l) for l in sys.stdin)
# per CPU second: less sensitive than wall time to other load on the machine
print("%.4f" % ((n[c] / n["cpu_seconds"]) / (b[c] / b["cpu_seconds"])))' "$counter")"
	done
	echo "$ratios" | /usr/bin/python3 -c '
import sys
r = sorted(float(x) for x in sys.stdin.read().split())
print("| `%s %s` | %.3f | %s |" % (sys.argv[1], sys.argv[2], r[len(r) // 2], ", ".join("%.3f" % x for x in r)))' "$label" "$args"
done
