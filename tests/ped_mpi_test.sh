#!/bin/sh
# The parallel ED core over real MPI ranks (TAP): mpirun -np 2, 4, 8 (oversubscribed) runs exactly the rounds,
# collisions and final state of the same ranks simulated in one process, which tests/ped_test compares with
# the serial engine; also with load balancing (a density step: the same rebalances, moves and collisions).
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${BUILDDIR:=$SRCDIR}"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ped_mpi_test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
. "$SRCDIR/tests/tap_lib.sh"   # ok(), report()
if ! command -v mpirun >/dev/null 2>&1; then
	echo "1..0 # SKIP no mpirun"
	exit 0
fi
for np in 2 4 8; do
	mpirun --oversubscribe -np $np "$BUILDDIR/tests/ped_mpi" >"$tmp/out" 2>"$tmp/err"
	rc=$?
	ok $rc "mpirun -np $np: exit $rc"
	[ -s "$tmp/err" ] && sed 's/^/# stderr: /' "$tmp/err" | head -5
	report "$tmp/out"
done
echo "1..$n"
[ "$failed" = 0 ]
