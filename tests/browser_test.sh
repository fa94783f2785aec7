#!/bin/sh
# The dashboard in headless Chromium (tests/browser_test.js) against a real daemon and engine.
set -u
. "$(dirname "$0")/daemon_lib.sh"
pw=""
for d in "$SRCDIR/.npm-test/node_modules" "$BUILDDIR/.npm-test/node_modules"; do [ -d "$d/playwright-core" ] && pw=$d; done
if [ ! -x /usr/bin/chromium ] || ! command -v node >/dev/null || [ -z "$pw" ]; then
	echo "1..0 # SKIP needs /usr/bin/chromium, node and playwright-core in .npm-test (./quickstart installs them)"
	exit 0
fi
# Two browser sessions (default read_auth, then read_auth token), their TAP lines renumbered under one plan.
gd_start "$tmp/state" --slots 2
mkdir -p "$BUILDDIR/tests"
NODE_PATH=$pw node "$SRCDIR/tests/browser_test.js" "$URL" "$TOKEN" "$BUILDDIR/tests/dashboard.png" >"$tmp/b1"
rc=$?
gd_stop
# read_auth token: the dashboard sends the token on reads and on its event stream (a fetch stream, not EventSource).
gd_start "$tmp/state2" --slots 2 --read-auth token
NODE_PATH=$pw node "$SRCDIR/tests/browser_test.js" "$URL" "$TOKEN" "" read-auth-token >"$tmp/b2"
rc2=$?
gd_stop
{ cat "$tmp/b1"; sed 's/^\(\(not \)\{0,1\}ok [0-9]* - \)/\1[read_auth token] /' "$tmp/b2"; } |
	awk '/^(not )?ok [0-9]+/ { k++; sub(/ok [0-9]+/, "ok " k); print; next } /^1\.\./ { next } { print } END { print "1.." k }'
[ $rc = 0 ] && [ $rc2 = 0 ]
