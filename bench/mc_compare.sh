#!/bin/sh
# DSMC/HSMC periodic path against a baseline build: moves per CPU second, ratio this build / baseline, interleaved runs, median of 5.
# usage: bench/mc_compare.sh BASELINE_DSMC_BENCH THIS_DSMC_BENCH  (prints markdown table rows)
# Both binaries must print cpu_seconds and moves (bench/dsmc_bench.c of this tree, linked against each build's
# engine/libgranular.a).
set -eu
exec sh "$(dirname "$0")/ab.sh" "$1" "$2" moves dsmc_bench \
	"dsmc 2 100000 0.05 0.9 200" "dsmc 3 100000 0.05 0.9 200" "dsmc 3 100000 0.25 0.9 200 enskog" \
	"hsmc 2 100000 0.4 0.9 200 cba" "hsmc 3 100000 0.25 0.9 200 cba"
