#!/bin/sh
# make bench: serial event statistics for one system over P ranks (issue 14, bench/par_model); prints a markdown section.
# usage: bench/par_model.sh BUILD_DIR   (not a parallel run: see docs/parallel.md)
set -eu
build=${1:-.}
pm="$build/bench/par_model"

echo "## One system over many ranks: serial event statistics and speed-up model (issue 14)"
echo
echo "Not a parallel run. One serial run of the engine (the bench-only traced build, bench/par_model) records every"
echo "event's cells; the Morton-order decompositions of engine/par/decomp over P ranks are applied to that stream."
echo "Definitions, the model and its assumptions: docs/parallel.md. Columns of the first table (equal-cell"
echo "contiguous Z ranges): cells per rank; rank 0's border cells, ghost cells and neighbour ranks; the fraction of"
echo "events that are border events, against seed 003's 2D (P/C)^(1/D); events per border event on a rank; events per"
echo "communication phase system-wide (events / sum over windows of the busiest rank's border events: an upper"
echo "bound, one phase per border event), against seed 003's C^(1/D) P^(1-1/D); collisions whose partners lie on two"
echo "ranks; cell crossings into another rank per event. Second table: load imbalance (sum over windows of the busiest"
echo "rank's events / sum of the mean; window 0 excluded) and the real cells that change owner per window (percent"
echo "of all cells), for equal cells (static), the prefix-sum split recomputed each window from the previous window's"
echo "events per cell, the same recomputed only when the imbalance on those costs exceeds the Poisson noise level"
echo "1 + sqrt(2 ln P / m) (m: mean events per rank; how many windows of how many were rebalanced), the split with a"
echo "hysteresis of one binomial deviation (decomp_balance_prefix_keep), seed 003's buddy blocks (triple merge/split"
echo "each window); then the modelled speed-up for static and noise-gated prefix balancing (moving a particle costs"
echo "one event time) at a cost per communication phase alpha of 0, 1 and 5 microseconds."
echo
case_() { # label, par_model arguments
	label=$1; shift
	echo "### $label"
	echo
	echo "Command: \`bench/par_model $*\`"
	echo
	"$pm" "$@"
	echo
}
case_ "3D elastic, N = 10^5, volume fraction 0.25" 3 100000 0.25 1 0 1 4
case_ "3D elastic, N = 10^6, volume fraction 0.25" 3 1000000 0.25 1 0 0.5 2
case_ "2D elastic, N = 10^5, volume fraction 0.3" 2 100000 0.3 1 0 1 4
case_ "2D elastic, N = 10^6, volume fraction 0.3" 2 1000000 0.3 1 0 0.5 2
case_ "2D clustering, N = 10^5, volume fraction 0.3, restitution 0.8, TC 1e-4 (after 100 collisions per particle)" \
	2 100000 0.3 0.8 1e-4 100 6
case_ "The same on a 256 x 256 cell grid (a power of two per axis: seed 003's buddy blocks without padding)" \
	2 100000 0.3 0.8 1e-4 100 6 2,4,8,16,64,128 10 1.995
case_ "2D clustering as above, a longer trace cut into 4 windows (rebalancing every ~5 events per particle instead of ~0.6)" \
	2 100000 0.3 0.8 1e-4 100 20 2,4,8,16,64,128 4
