#!/bin/sh
# The libFuzzer harnesses of tests/fuzz/ (ASan+UBSan): every seed and regression input, then a short fuzzing run (TAP).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${BUILDDIR:=$SRCDIR}"
# Short by design (make check); docs/fuzzing.md has the long campaigns.
: "${FUZZ_RUNS:=3000}"   # ckpt_fuzz: a tenth (each input is an HDF5 file written and opened, ~10 ms)
HARNESSES="scene cfg api http ckpt"

missing=
for h in $HARNESSES; do
	[ -x "$BUILDDIR/tests/fuzz/${h}_fuzz" ] || missing="$missing ${h}_fuzz"
done
if [ -n "$missing" ]; then
	if ! command -v clang >/dev/null 2>&1; then
		echo "1..0 # SKIP clang is not installed (./quickstart check installs it; then ./configure)"
	else
		echo "1..0 # SKIP harnesses not built:$missing (configure found no clang with libFuzzer; see docs/fuzzing.md)"
	fi
	exit 0
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/fuzz_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
# A report of a leak in the harness process fails the run too (detect_leaks is on by default).
ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:detect_leaks=1}
UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export ASAN_OPTIONS UBSAN_OPTIONS

echo "1..$(( $(echo $HARNESSES | wc -w) * 2 ))"
for h in $HARNESSES; do
	bin="$BUILDDIR/tests/fuzz/${h}_fuzz" corpus="$SRCDIR/tests/fuzz/corpus/$h"
	nseeds=$(ls "$corpus" | wc -l)
	# 1. Each seed and regression input once (the corpus is the regression suite).
	"$bin" -artifact_prefix="$tmp/" "$corpus"/* >"$tmp/$h.replay" 2>&1
	r=$?
	ok "$r" "${h}_fuzz: all $nseeds corpus inputs run clean"
	[ "$r" = 0 ] || sed 's/^/# /' "$tmp/$h.replay" | tail -40
	# 2. A short mutation run from the corpus (new inputs go to a scratch dir).
	mkdir "$tmp/$h"
	runs=$FUZZ_RUNS; [ "$h" = ckpt ] && runs=$((FUZZ_RUNS / 10))
	"$bin" -runs="$runs" -seed=1 -artifact_prefix="$tmp/" -print_final_stats=1 "$tmp/$h" "$corpus" >"$tmp/$h.run" 2>&1
	r=$?
	ok "$r" "${h}_fuzz: $runs mutated inputs without a crash, leak or UB ($(grep -o 'cov: [0-9]*' "$tmp/$h.run" | tail -1))"
	if [ "$r" != 0 ]; then
		sed 's/^/# /' "$tmp/$h.run" | tail -40
		for a in "$tmp"/crash-* "$tmp"/leak-* "$tmp"/timeout-* "$tmp"/oom-*; do
			[ -f "$a" ] && echo "# artifact $(basename "$a"): $(od -c "$a" | head -3 | tr '\n' ' ')"
		done
	fi
done
[ "$failed" = 0 ]
