#!/bin/sh
# make bench: run the engine benchmarks and write docs/benchmarks.md (machine, N, density, command, result).
set -eu
build=${1:-.}
src=${2:-.}
bench="$build/bench/ed_bench"
mcbench="$build/bench/dsmc_bench"
out="$src/docs/benchmarks.md"
tmp=$(mktemp)
tmc=$(mktemp)
iotmp=$(mktemp)
tft=$(mktemp)
tcmp=$(mktemp)
ROWS=$tmp
trap 'rm -f "$tmp" "$tmc" "$iotmp" "$tft" "$tcmp"' EXIT

cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
cores=$(nproc)
mem=$(free -g | awk '/Mem:/ {print $2 " GiB"}')
cc=$(${CC:-cc} --version | head -n 1)

row() { # label dim n phi e warm meas [tc [cell]]; REPS=k: the median of k runs (by collisions/s)
	label=$1; shift
	line=$(for r in $(seq "${REPS:-1}"); do "$bench" "$@"; done | /usr/bin/python3 -c '
import json, sys
runs = sorted((json.loads(l) for l in sys.stdin if l.strip()), key=lambda d: d["collisions_per_second"])
d = runs[len(runs) // 2]
d["runs_collisions_per_second"] = [r["collisions_per_second"] for r in runs]
print(json.dumps(d))')
	echo "$line" >&2
	echo "$line" | /usr/bin/python3 -c '
import json, sys
d = json.loads(sys.stdin.read())
label, cmd = sys.argv[1], sys.argv[2]
runs = d.get("runs_collisions_per_second", [])
if len(runs) > 1:
    label += " (runs: %s)" % ", ".join("%.3g" % r for r in runs)
print("| %s | %d | %d | %g | %g | %.3g | %.3g | %.0f | %s | `%s` |" % (label, d["dim"], d["n"], d["phi"], d["restitution"],
      d["collisions_per_second"], d["events_per_second"], d["bytes_per_particle"],
      "x".join(str(c) for c in d["cells"][:d["dim"]]), cmd))' "$label" "bench/ed_bench $*" >>"$ROWS"
}

mcrow() { # label method dim n phi e steps [correction]
	label=$1; shift
	line=$("$mcbench" "$@")
	echo "$line" >&2
	echo "$line" | /usr/bin/python3 -c '
import json, sys
d = json.loads(sys.stdin.read())
label, cmd = sys.argv[1], sys.argv[2]
print("| %s | %s/%s | %d | %d | %g | %g | %.3g | %.3g | %.0f | %s | `%s` |" % (label, d["method"], d["correction"], d["dim"], d["n"],
      d["phi"], d["restitution"], d["moves_per_second"], d["collisions_per_second"], d["bytes_per_particle"],
      "x".join(str(c) for c in d["cells"][:d["dim"]]), cmd))' "$label" "bench/dsmc_bench $*" >>"$tmc"
}

# The peers are measured in their own section (bench/peers.py: same run, interleaved, medians of 5).
REPS=3
row "3D elastic, median of 3" 3 10976 0.45 1 200 100
row "3D elastic, median of 3" 3 10976 0.1 1 50 100
row "3D elastic, median of 3" 3 108000 0.45 1 100 20
row "3D elastic, median of 3" 3 108000 0.1 1 30 20
REPS=1
row "2D inelastic, TC" 2 10000 0.3 0.9 50 100 1e-4
row "2D inelastic, TC" 2 100000 0.3 0.9 30 20 1e-4
row "3D inelastic, TC" 3 10976 0.25 0.9 50 100 1e-4
row "2D dense elastic" 2 10000 0.8 1 100 100
row "2D very dilute" 2 10000 0.0001 1 5 100
row "3D large (10^7), lattice start" 3 10000000 0.3 1 0 2
# cell size (in diameters) against the automatic choice, dilute 2D and 3D
for c in 0 1 2 3; do row "cell size ${c} (0 = auto)" 2 10000 0.05 1 20 50 0 $c; done
for c in 0 1.2 1.5; do row "cell size ${c} (0 = auto)" 3 10976 0.1 1 20 50 0 $c; done

# Scene features (issue 12): the same gas with walls, thermal walls, gravity (medians of 3).
# Rounds interleaved over the features (a shared machine drifts), median of 3 each.
sh "$src/bench/features.sh" "$bench" 3 >"$tft"
# The periodic fast path against a baseline build (BASELINE_ED_BENCH=path/to/old/bench/ed_bench make bench).
if [ -n "${BASELINE_ED_BENCH:-}" ]; then
	sh "$src/bench/compare.sh" "$BASELINE_ED_BENCH" "$bench" >"$tcmp"
fi

# HDF5 output: checkpoint and frame cost at N = 10^6, and a run with checkpoints.
iorow() { # label dim n phi cpp every
	label=$1; shift
	line=$("$build/bench/io_bench" "$build/bench/io.tmp" "$@")
	echo "$line" >&2
	echo "$line" | /usr/bin/python3 -c '
import json, sys
d = json.loads(sys.stdin.read())
label, cmd = sys.argv[1], sys.argv[2]
per = d["ckpt_seconds_in_run"] / max(d["checkpoints"], 1)
print("| %s | %d | %d | %g | %.1f | %.2f | %.2f | %.1f / %.1f | %.2f / %.2f | %.1f | %.1f (%d) | %.2f%% | %.2f%% | `%s` |" % (
      label, d["dim"], d["n"], d["phi"], d["ckpt_bytes"] / 1e6, d["ckpt_write_seconds"], d["ckpt_read_seconds"],
      d["frame_bytes"][0] / 1e6, d["frame_bytes"][1] / 1e6, d["frame_seconds"][0], d["frame_seconds"][1],
      d["run_seconds"], d["run_ckpt_seconds"], d["checkpoints"],
      100.0 * (d["run_ckpt_seconds"] - d["run_seconds"]) / d["run_seconds"], 100.0 * per / 60.0, cmd))' "$label" "bench/io_bench DIR $*" >>"$iotmp"
}
iorow "3D dilute (cells)" 3 1000000 0.3 12 5
iorow "3D dense (neighbour lists)" 3 1000000 0.45 6 5
iorow "2D (cells)" 2 1000000 0.3 8 5

# DSMC/HSMC (against SPARTA: bench/peers.py)
mcrow "2D dilute" dsmc 2 100000 0.05 0.9 40
mcrow "3D dilute" dsmc 3 100000 0.05 0.9 40
mcrow "2D dilute" dsmc 2 1000000 0.05 0.9 8
mcrow "3D dilute" dsmc 3 1000000 0.05 0.9 8
mcrow "3D dense, Enskog" dsmc 3 100000 0.25 0.9 40 enskog
mcrow "3D dense, Enskog" dsmc 3 1000000 0.25 0.9 8 enskog
mcrow "2D dense, HSMC" hsmc 2 100000 0.4 0.9 40 cba
mcrow "2D dense, HSMC" hsmc 2 1000000 0.4 0.9 8 cba
mcrow "3D dense, HSMC" hsmc 3 1000000 0.25 0.9 8 cba

# Structure observables (issue 17): wall seconds per sample of each curve family at N = 10^5 and 10^6.
tob=$(mktemp)
for a in "3 100000 0.3" "3 1000000 0.3" "2 100000 0.3" "2 1000000 0.3"; do
	"$build/bench/obs_bench" $a 5 | /usr/bin/python3 -c '
import json, sys
cmd = sys.argv[1]
for l in sys.stdin:
    d = json.loads(l)
    print("| %s | %d | %d | %g | %.3g | %.3g | %.3g | %.0f | `%s` |" % (d["family"], d["dim"], d["n"], d["phi"],
          d["seconds"], d["min_seconds"], d["ns_per_particle"], d["bytes_per_particle"], cmd))' "bench/obs_bench $a 5" >>"$tob"
done

# Peers: EDMD and SPARTA from ../shared/peers (or $PEERS), in this run; absent peers are said so.
tpe=$(mktemp)
/usr/bin/python3 "$src/bench/peers.py" "$build" "$src" "${PEERS:-$src/../shared/peers}" >"$tpe"
# Soft-sphere MD against LAMMPS (issue 18; Debian package lammps), 10^4 spheres, about 2 minutes.
tmd=$(mktemp)
{
	echo "## Soft-sphere MD against LAMMPS on one core (issue 18)"
	echo
	if command -v lmp >/dev/null 2>&1 && [ -x "$build/bench/md_bench" ]; then
		echo "md_bench's settling bed and the same bed in LAMMPS (gran/hooke/history), per CPU second, interleaved,"
		echo "median of 5 (docs/benchmarks-notes.md, \"Soft-sphere MD core\")."
		echo
		echo "| command | median ours / LAMMPS | ratios |"
		echo "|---|---|---|"
		MD_BENCH="$build/bench/md_bench" sh "$src/bench/md_lammps.sh" 20 25 20 2000 | grep '^|'
	else
		echo "Not measured: lmp (Debian package lammps) or bench/md_bench missing."
	fi
	echo
} >"$tmd" 2>&1 || true

tdm=$(mktemp)
sh "$src/bench/daemon_bench.sh" "$build" "$src" >"$tdm"
tin=$(mktemp)
sh "$src/bench/ingest_bench.sh" "$build" "$src" >"$tin"
# One system over many ranks (issue 14): serial event statistics and the speed-up model (about 45 s CPU).
tpm=$(mktemp)
sh "$src/bench/par_model.sh" "$build" >"$tpm"
# The parallel ED core over MPI against the serial engine (issue 14; minutes: rounds are global collectives).
tpd=$(mktemp)
{
	echo "## Parallel ED core over MPI (issue 14)"
	echo
	echo "The exact parallel core (engine/par/ped, docs/parallel.md) against the serial engine on the same initial state"
	echo "and horizon (the same collisions, checked). bench/ped_bench.sh; wall times on this shared machine."
	echo
	sh "$src/bench/ped_bench.sh" "$build" 2 1000000 0.3 0.5
	sh "$src/bench/ped_bench.sh" "$build" 3 1000000 0.25 0.2
	echo "Rounds, messages and rollbacks, border events in global time order against the optimistic window"
	echo "(bench/ped_counts.sh: the ranks simulated in one process, counts only)."
	echo
	sh "$src/bench/ped_counts.sh" "$build" 2 100000 0.3 1
	sh "$src/bench/ped_counts.sh" "$build" 3 100000 0.25 0.6
} >"$tpd"

{
	echo "# Benchmarks"
	echo
	echo "Written by \`make bench\` (bench/run.sh); numbers from the last run. Do not edit by hand."
	echo
	echo "- Machine: $cpu, $cores cores, $mem; $cc; one run at a time, single thread."
	echo "- Date: $(date -u +%Y-%m-%d)."
	echo "- Systems: lattice start, elastic relaxation of WARMUP collisions per particle (not timed), then MEASURE"
	echo "  collisions per particle timed. Diameter 1, mass 1, T = 1. Columns: collisions per second, events per second"
	echo "  (collisions + cell crossings + cancelled predictions + neighbour-list rebuilds), bytes held per particle"
	echo "  (ed_memory()), cell grid, and the exact command (ed_bench DIM N PHI RESTITUTION WARMUP MEASURE [TC [CELL]])."
	echo
	echo "| case | D | N | volume fraction | restitution | collisions/s | events/s | bytes/particle | cells | command |"
	echo "|---|---|---|---|---|---|---|---|---|---|"
	cat "$tmp"
	echo
	echo "## Scene features"
	echo
	echo "The same elastic gas (lattice start, relaxed, then timed as above) in a periodic box, between specular walls on"
	echo "every axis, between thermal walls (T = 1) on the last axis, and under gravity (scale height T/(m g) = half the"
	echo "box) over a specular floor and lid. Each scene runs the kernels of its features only (chosen at load), so"
	echo "the difference is the price of the feature. Median of 3 runs, the runs of all rows interleaved (bench/features.sh)."
	echo
	echo "| case | D | N | volume fraction | restitution | collisions/s | events/s | bytes/particle | cells | command |"
	echo "|---|---|---|---|---|---|---|---|---|---|"
	cat "$tft"
	if [ -s "$tcmp" ]; then
		echo
		echo "## Periodic scenes against the baseline build"
		echo
		echo "Collisions per CPU second of this build over the baseline's (\`BASELINE_ED_BENCH=... make bench\`, bench/compare.sh),"
		echo "runs interleaved (alternating which goes first), median of 5 ratios. The features of issue 12 must cost a"
		echo "periodic scene nothing: within 3%, same trajectories bit for bit."
		echo
		echo "| command | median ratio | ratios |"
		echo "|---|---|---|"
		cat "$tcmp"
	fi
	echo
	echo "## DSMC and HSMC"
	echo
	echo "Random start, default cells (docs/scene.md) and adaptive step (0.2 collisions per particle per step), 2 untimed"
	echo "warm-up steps, then STEPS timed. A move is one particle advanced by one step (SPARTA's unit). Columns: moves"
	echo "per second, collisions per second, bytes held per particle (dsmc_memory(): particle records, identities, sort destinations, sort ring, cells; docs/engine.md),"
	echo "cell grid, command (dsmc_bench METHOD DIM N PHI RESTITUTION STEPS [CORRECTION])."
	echo
	echo "| case | method | D | N | volume fraction | restitution | moves/s | collisions/s | bytes/particle | cells | command |"
	echo "|---|---|---|---|---|---|---|---|---|---|---|"
	cat "$tmc"
	echo
	echo "## Structure observables: cost per sample (issue 17)"
	echo
	echo "An elastic ed gas (lattice start, 1 collision per particle, untimed); then 5 rounds in which each family's"
	echo "sample is computed once, families interleaved; the median and the fastest of the 5 (a shared machine"
	echo "drifts), per particle, and the workspace held (obs_memory()) per particle. \`scalars\` is what a progress"
	echo "record costs with velocity_distribution and pair_correlation (a2, a3, g(σ) from the pair histogram); the"
	echo "other rows are one curve sample at a snapshot time, with the defaults: g(r) to 5 diameters in 250 bins"
	echo "(cell lists: O(N), ~300 neighbours per particle in 3D at 0.3), S(k) and the velocity structure factors by FFTW"
	echo "on the grid of the power of 2 per axis whose cell is closest to a diameter, clusters at gap 0.1, fields on"
	echo "32^3 / 128^2 cells (one instant). Command: obs_bench DIM N PHI REPS."
	echo
	echo "| family | D | N | volume fraction | s per sample (median) | fastest | ns per particle | workspace bytes/particle | command |"
	echo "|---|---|---|---|---|---|---|---|---|"
	cat "$tob"
	echo
	echo "## HDF5 output"
	echo
	echo "Checkpoint (\`checkpoint.h5\`: full engine state, digest, written to a temporary file, fsync, rename, directory"
	echo "fsync; best of 3) and one trajectory frame (positions + velocities appended to \`trajectory.h5\`, flushed and"
	echo "fsynced) at deflate level 0 / 1, for the final state of a run of the given collisions per particle; then the"
	echo "same run (lattice start, elastic) timed without checkpoints and with a checkpoint every 5 wall seconds. The"
	echo "slowdown at a 1-minute interval is the measured time per checkpoint divided by 60 s (a 1-minute interval"
	echo "would make \`make bench\` too long); the measured slowdown at 5 s is shown too, but it includes the run-to-run"
	echo "noise of this shared VM (about ±10%). Command: io_bench DIR DIM N PHI CPP CKPT_WALL_SECONDS."
	echo
	echo "| case | D | N | volume fraction | checkpoint MB | write s | read s | frame MB (0 / 1) | frame write s (0 / 1) | run s | with checkpoints s (n) | slowdown measured (5 s) | slowdown at 1 min | command |"
	echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
	cat "$iotmp"
	echo
	cat "$tpe"
	cat "$tmd"; rm -f "$tmd"
	cat "$tdm"
	cat "$tin"
	echo
	cat "$tpm"
	cat "$tpd"
	if [ -f "$src/docs/benchmarks-notes.md" ]; then cat "$src/docs/benchmarks-notes.md"; fi
} >"$out"
rm -f "$tdm" "$tin" "$tpe" "$tob" "$tpm" "$tpd"
echo "wrote $out"
