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
gd_start "$tmp/state" --slots 2
mkdir -p "$BUILDDIR/tests"
NODE_PATH=$pw node "$SRCDIR/tests/browser_test.js" "$URL" "$TOKEN" "$BUILDDIR/tests/dashboard.png"
rc=$?
gd_stop
exit $rc
