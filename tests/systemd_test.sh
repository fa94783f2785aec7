#!/bin/sh
# The shipped systemd unit: syntax of the directives we rely on, and systemd-analyze's sandboxing score.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${BUILDDIR:=$SRCDIR}"
unit=$BUILDDIR/systemd/granulard.service
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
grep -q '^Type=notify$' "$unit" && grep -q '^StateDirectory=granulard$' "$unit" && grep -q '^DynamicUser=yes$' "$unit"
ok $? "unit is Type=notify with a state directory and a dedicated (dynamic) user"
grep -q "^ExecStart=/.*/granulard " "$unit"
ok $? "ExecStart has an absolute path: $(sed -n 's/^ExecStart=//p' "$unit")"
# Resources: memory bounded relative to the host, no swap, an OOM-killed engine does not stop the service,
# and enough tasks for this host's slots (HTTP threads + daemon + 7 per slot: docs/daemon.md).
grep -q '^MemoryMax=[0-9]*%$' "$unit" && grep -q '^MemorySwapMax=0$' "$unit" && grep -q '^OOMPolicy=continue$' "$unit"
ok $? "memory: $(grep -E '^Memory(Max|SwapMax)=' "$unit" | tr '\n' ' ')OOMPolicy=$(sed -n 's/^OOMPolicy=//p' "$unit")"
tasks=$(sed -n 's/^TasksMax=//p' "$unit")
need=$((512 + 8 + 7 * $(nproc)))
ok $([ -n "$tasks" ] && [ "$tasks" -ge "$need" ]; echo $?) "TasksMax=$tasks covers 512 connections + 8 + 7 x $(nproc) slots ($need)"
if command -v systemd-analyze >/dev/null 2>&1; then
	score=$(systemd-analyze security --offline=true "$unit" 2>/dev/null | sed -n 's/.*Overall exposure level for granulard.service: \([0-9.]*\).*/\1/p')
	ok $([ -n "$score" ] && awk -v s="$score" 'BEGIN { exit !(s <= 2.0) }'; echo $?) "systemd-analyze security exposure $score (<= 2.0 is OK)"
else
	n=$((n + 1)); echo "ok $n # SKIP systemd-analyze not installed"
fi
echo "1..$n"
[ $failed -eq 0 ]
