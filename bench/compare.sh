#!/bin/sh
# Periodic fast path against a baseline build: collisions per CPU second, ratio this build / baseline, interleaved runs, median of 5.
# usage: bench/compare.sh BASELINE_ED_BENCH THIS_ED_BENCH  (prints markdown table rows)
set -eu
exec sh "$(dirname "$0")/ab.sh" "$1" "$2" collisions ed_bench \
	"2 10000 0.3 0.9 30 300 1e-4" "2 10000 0.8 1 50 200" "3 10976 0.45 1 50 200" "3 10976 0.1 1 20 200"
