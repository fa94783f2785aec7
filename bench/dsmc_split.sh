#!/bin/sh
# One dsmc system over MPI ranks (issue 15): strong scaling at 1 and 2 ranks (3D, N = 10^6 and 10^7), weak
# scaling 1 -> 2 ranks (10^6 per rank), the serial dsmc.c step as reference, all interleaved round by round,
# medians of ROUNDS (default 5); then 4, 8 and 16 ranks oversubscribed for migrants, bytes, messages and
# imbalance per step (their times mean nothing on 2 cores). docs/benchmarks.md "One dsmc system over ranks".
# Waiting ranks yield the core (mpi_yield_when_idle): the cores are shared. Besides wall time per step the
# bench reports CPU seconds per step outside MPI calls (the slowest rank and all ranks): the work apart from
# how the shared cores were handed out. Raw JSON lines first, then the summary.
# usage: bench/dsmc_split.sh BUILDDIR [ROUNDS]
set -eu
B=${1:-.}
ROUNDS=${2:-5}
X="$B/bench/dsmcp_bench"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
out=$(mktemp "${TMPDIR:-/tmp}/dsmc_split.XXXXXX")
trap 'rm -f "$out"' EXIT
for r in $(seq "$ROUNDS"); do
	for N in 1000000 10000000; do
		steps=$([ $N = 1000000 ] && echo 10 || echo 4)
		"$X" 3 $N $steps serial >>"$out"
		"$X" 3 $N $steps >>"$out"
		mpirun -np 2 "$X" 3 $N $steps >>"$out"
	done
	mpirun -np 2 "$X" 3 2000000 10 >>"$out"   # weak: 10^6 per rank (against the 1-rank 10^6 runs above)
done
for P in 4 8 16; do
	mpirun --oversubscribe -np $P "$X" 3 1000000 3 >>"$out"
done
cat "$out"
/usr/bin/python3 - "$out" <<'EOF'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
def med(mode, N, P, key="s_per_step"):
    v = [r[key] for r in rows if r["mode"] == mode and r["N"] == N and r["ranks"] == P]
    return statistics.median(v), len(v)
for N in (1000000, 10000000):
    s, k = med("serial", N, 1); p1, _ = med("split", N, 1); p2, _ = med("split", N, 2)
    c1, _ = med("split", N, 1, "cpu_compute_s_per_step_max"); c2, _ = med("split", N, 2, "cpu_compute_s_per_step_max")
    cs, _ = med("split", N, 2, "cpu_compute_s_per_step_sum")
    print("3D N=%d (%d rounds, medians): wall s/step serial dsmc.c %.4g, split 1 rank %.4g, 2 ranks %.4g; "
          "split-1/serial %.2f; strong speed-up 1->2 ranks: wall %.2f, CPU outside MPI (slowest rank) %.2f, "
          "CPU of both ranks / 1 rank %.2f" % (N, k, s, p1, p2, p1 / s, p1 / p2, c1 / c2, cs / c1))
p1, k = med("split", 1000000, 1); p2, _ = med("split", 2000000, 2)
c1, _ = med("split", 1000000, 1, "cpu_compute_s_per_step_max"); c2, _ = med("split", 2000000, 2, "cpu_compute_s_per_step_max")
print("weak 10^6 per rank (%d rounds, medians): wall 1 rank %.4g s/step, 2 ranks (N=2*10^6) %.4g s/step, "
      "efficiency %.2f; CPU outside MPI (slowest rank) %.4g -> %.4g, efficiency %.2f" % (k, p1, p2, p1 / p2, c1, c2, c1 / c2))
for r in rows:
    if r["mode"] == "split" and r["N"] in (1000000, 2000000) and r["ranks"] >= 2 and (r["ranks"] > 2 or r["N"] == 2000000):
        print("P=%d N=%d planes=%d: migrants/step %.0f (%.2f%% of N), bytes/step %.0f, messages/step %.1f, "
              "imbalance particles %.3f, CPU outside MPI max/mean %.2f" % (r["ranks"], r["N"], r["planes"],
              r["migrants_per_step"], 100 * r["migrants_per_step"] / r["N"], r["bytes_per_step"],
              r["messages_per_step"], r["imbalance_particles"],
              r["cpu_compute_s_per_step_max"] / (r["cpu_compute_s_per_step_sum"] / r["ranks"])))
EOF
