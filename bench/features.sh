#!/bin/sh
# Scene-feature rows of docs/benchmarks.md: periodic, walls, thermal walls, gravity, an obstacle, rough particles (constant beta, Walton); rounds interleaved, median of R.
# usage: bench/features.sh ED_BENCH [R]  (prints markdown table rows)
set -eu
bench=$1
reps=${2:-3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cases="2:10000 3:10976"
for r in $(seq "$reps"); do
	for c in $cases; do
		for f in ${FEATURES:-periodic walls thermal gravity obstacle walls-obstacle rough walton}; do
			"$bench" "${c%%:*}" "${c##*:}" 0.3 1 20 200 0 0 $f >>"$tmp/${c%%:*}-$f"
		done
	done
done
for c in $cases; do
	for f in ${FEATURES:-periodic walls thermal gravity obstacle walls-obstacle rough walton}; do
		/usr/bin/python3 -c '
import json, sys
runs = sorted((json.loads(l) for l in open(sys.argv[1]) if l.strip()), key=lambda d: d["collisions_per_second"])
d = runs[len(runs) // 2]
label = "%dD %s (runs: %s)" % (d["dim"], sys.argv[2], ", ".join("%.3g" % r["collisions_per_second"] for r in runs))
print("| %s | %d | %d | %g | %g | %.3g | %.3g | %.0f | %s | `%s` |" % (label, d["dim"], d["n"], d["phi"], d["restitution"],
      d["collisions_per_second"], d["events_per_second"], d["bytes_per_particle"],
      "x".join(str(c) for c in d["cells"][:d["dim"]]), sys.argv[3]))' "$tmp/${c%%:*}-$f" "$f" \
			"bench/ed_bench ${c%%:*} ${c##*:} 0.3 1 20 200 0 0 $f"
	done
done
