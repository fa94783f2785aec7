#!/bin/sh
# Build bench/ed_pair: this tree's engine against the event-driven engine of another tree (OLD: a git
# revision, checked out to a temporary directory, or a source directory), linked into one program.
# usage: bench/ed_pair.sh OLD [OUT]   (run from a configured and built source tree; OUT: /tmp/ed_pair)
# Then: OUT DIM N PHI RESTITUTION WARMUP_CPP SEGMENT_CPP PAIRS [new-first]
set -eu
old=$1
out=${2:-/tmp/ed_pair}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ -d "$old" ]; then src=$old; else git archive "$old" engine | tar -x -C "$tmp"; src=$tmp; fi
flags="-std=c11 -D_POSIX_C_SOURCE=200809L -O3 -fno-math-errno -g -DHAVE_CONFIG_H -I. -I./engine"
gcc $flags -I"$src/engine" -c "$src/engine/ed/ed.c" -o "$tmp/old_ed.o"
nm -g --defined-only "$tmp/old_ed.o" | awk '$3 ~ /^ed_/ {print $3, "old_" $3}' >"$tmp/syms"
objcopy --redefine-syms="$tmp/syms" "$tmp/old_ed.o"
gcc $flags -c bench/ed_pair.c -o "$tmp/ed_pair.o"
gcc -o "$out" "$tmp/ed_pair.o" "$tmp/old_ed.o" engine/libgranular.a $(pkg-config --libs jansson) -lfftw3 -lm
echo "$out"
