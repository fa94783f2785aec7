#!/bin/sh
# The decomposed dsmc path on one rank against dsmc.c's own step (issue 15: "a single rank is no slower"): 3D,
# N = 10^6 (10 timed steps) and 10^7 (4 steps), interleaved (each round alternates which goes first), medians
# of ROUNDS paired ratios split / serial of the CPU seconds per step and the wall seconds per step, and each
# path's peak resident memory per particle (VmHWM / N, set-up included). docs/benchmarks.md.
# usage: bench/dsmcp_serial.sh BENCH [ROUNDS [SIZES]]   (BENCH: a build's bench/dsmcp_bench)
set -eu
X=$1
ROUNDS=${2:-5}
SIZES=${3:-"1000000 10000000"}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=$(mktemp "${TMPDIR:-/tmp}/dsmcp_serial.XXXXXX")
trap 'rm -f "$out"' EXIT
for r in $(seq "$ROUNDS"); do
	for N in $SIZES; do
		steps=$([ "$N" -le 1000000 ] && echo 10 || echo 4)
		if [ $((r % 2)) -eq 1 ]; then
			"$X" 3 "$N" $steps serial >>"$out"; "$X" 3 "$N" $steps >>"$out"
		else
			"$X" 3 "$N" $steps >>"$out"; "$X" 3 "$N" $steps serial >>"$out"
		fi
	done
done
cat "$out"
/usr/bin/python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| N (3D) | CPU s/step, split 1 rank / serial dsmc.c (median; ratios) | wall s/step, split / serial (median) | peak RSS per particle, serial, split |")
print("|---|---|---|---|")
for N in sorted({r["N"] for r in rows}):
    s = [r for r in rows if r["N"] == N and r["mode"] == "serial"]
    p = [r for r in rows if r["N"] == N and r["mode"] == "split"]
    cr = sorted(y["cpu_compute_s_per_step_max"] / x["cpu_s_per_step"] for x, y in zip(s, p))
    wr = sorted(y["s_per_step"] / x["s_per_step"] for x, y in zip(s, p))
    print("| %.0e | %.3f (%s) | %.3f | %.1f B, %.1f B |" % (N, statistics.median(cr), ", ".join("%.3f" % v for v in cr),
          statistics.median(wr), statistics.median(x["peak_rss_bytes_max"] for x in s) / N,
          statistics.median(x["peak_rss_bytes_max"] for x in p) / N))
PY
