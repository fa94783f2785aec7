#!/bin/sh
# Method md (issue 18): the angle of a heap grows with the friction mu (TAP). bench/md_repose.sh's heap, small:
# 150 disks released from a column onto the floor, rolling resistance mu_r 0.2, mu 0.1 and 1.0, three seeds each
# (the seed draws the initial velocities at temperature 0.01). The full table is docs/benchmarks.md's.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${ENGINE:=$SRCDIR/engine/granular-engine}"
out=$(RAW=1 N=150 MUS="0.1 1.0" MURS="0.2" SEEDS="1 2 3" JOBS=1 sh "$SRCDIR/bench/md_repose.sh" "$ENGINE" 2>&1)
rc=$?
echo "1..1"
# Each setting's three angles: mean and standard error (sd / sqrt 3). The two means must differ by more than
# 4 combined standard errors, and every angle at mu 1.0 must exceed every one at mu 0.1 (the spread over seeds).
echo "$out" | /usr/bin/python3 -c '
import math, sys
rows = {}
for line in sys.stdin:
    f = line.split()
    if len(f) == 5:
        rows[float(f[0])] = [float(x) for x in f[2:]]
lo, hi = rows.get(0.1, []), rows.get(1.0, [])
def ms(a):
    m = sum(a) / len(a)
    return m, math.sqrt(sum((x - m) ** 2 for x in a) / (len(a) - 1) / len(a))
if len(lo) != 3 or len(hi) != 3 or any(math.isnan(x) for x in lo + hi):
    print("not ok 1 - heap angles: no result (%r)" % rows)
    sys.exit(0)
(m1, s1), (m2, s2) = ms(lo), ms(hi)
good = m2 - m1 > 4 * math.hypot(s1, s2) and min(hi) > max(lo)
print("%s 1 - heap angle at mu 1.0 %.1f +- %.1f deg above mu 0.1 %.1f +- %.1f deg (mu_r 0.2; seeds %s and %s)"
      % ("ok" if good else "not ok", m2, s2, m1, s1, " ".join("%.1f" % x for x in hi), " ".join("%.1f" % x for x in lo)))
'
[ $rc = 0 ] || echo "# bench/md_repose.sh: exit $rc: $out"
