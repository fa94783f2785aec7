#!/bin/sh
# A/B of the decomposed dsmc path (issue 15): two builds of bench/dsmcp_bench, 3D, N = 10^6 (10 timed steps) and
# 10^7 (4 steps), 1 and 2 ranks, interleaved (each round alternates which build goes first), medians of ROUNDS
# paired ratios NEW / BASE of the CPU seconds per step outside MPI (slowest rank: the work apart from how the
# shared cores were handed out) and of the wall seconds per step, and each build's peak resident memory per
# particle (VmHWM of the largest rank / N, set-up included; 2 ranks: per particle held, N / 2).
# docs/benchmarks.md "Memory per particle of the decomposed path".
# usage: bench/dsmcp_ab.sh BASE_BENCH NEW_BENCH [ROUNDS [SIZES]]   (SIZES default "1000000 10000000")
set -eu
base=$1
new=$2
ROUNDS=${3:-5}
SIZES=${4:-"1000000 10000000"}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
out=$(mktemp "${TMPDIR:-/tmp}/dsmcp_ab.XXXXXX")
trap 'rm -f "$out"' EXIT
one() {   # build label, P, N, steps
	if [ "$2" = 1 ]; then "$1" 3 "$3" "$4"; else mpirun -np "$2" "$1" 3 "$3" "$4"; fi | sed "s/^{/{\"build\":\"$5\",/"
}
for r in $(seq "$ROUNDS"); do
	for N in $SIZES; do
		steps=$([ "$N" -le 1000000 ] && echo 10 || echo 4)
		for P in 1 2; do
			if [ $((r % 2)) -eq 1 ]; then
				one "$base" $P $N $steps base >>"$out"; one "$new" $P $N $steps new >>"$out"
			else
				one "$new" $P $N $steps new >>"$out"; one "$base" $P $N $steps base >>"$out"
			fi
		done
	done
done
cat "$out"
/usr/bin/python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| N (3D) | ranks | CPU s/step outside MPI, new / base (median; ratios) | wall s/step, new / base (median) | peak RSS per particle held, base -> new | dsmcp_memory() per particle, base -> new |")
print("|---|---|---|---|---|---|")
for N in sorted({r["N"] for r in rows}):
    for P in (1, 2):
        b = [r for r in rows if r["N"] == N and r["ranks"] == P and r["build"] == "base"]
        n = [r for r in rows if r["N"] == N and r["ranks"] == P and r["build"] == "new"]
        if not b or not n:
            continue
        cr = sorted(y["cpu_compute_s_per_step_max"] / x["cpu_compute_s_per_step_max"] for x, y in zip(b, n))
        wr = sorted(y["s_per_step"] / x["s_per_step"] for x, y in zip(b, n))
        rb = statistics.median(x["peak_rss_bytes_max"] for x in b) * P / N
        rn = statistics.median(x["peak_rss_bytes_max"] for x in n) * P / N
        print("| %.0e | %d | %.3f (%s) | %.3f | %.1f -> %.1f B | %.1f -> %.1f B |" % (N, P, statistics.median(cr),
              ", ".join("%.3f" % v for v in cr), statistics.median(wr), rb, rn,
              b[0]["bytes_per_particle_held"], n[0]["bytes_per_particle_held"]))
PY
