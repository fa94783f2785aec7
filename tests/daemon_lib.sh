# Shared helpers for the daemon integration tests (sourced): TAP output, a real granulard on a temp dir.
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${BUILDDIR:=$SRCDIR}"
: "${GRANULARD:=$BUILDDIR/daemon/granulard}"
: "${ENGINE:=$BUILDDIR/engine/granular-engine}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/granulard_test.XXXXXX")
n=0; failed=0; GD_PID=
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
cleanup() {
	[ -n "$GD_PID" ] && kill -9 "$GD_PID" 2>/dev/null
	pkill -9 -f "$tmp/" 2>/dev/null
	rm -rf "$tmp"
}
trap cleanup EXIT

# gd_start STATE_DIR [flags...]: start granulard on an ephemeral port; sets URL, TOKEN, GD_PID.
gd_start() {
	st=$1; shift
	rm -f "$st/granulard.addr"
	"$GRANULARD" --state-dir "$st" --listen 127.0.0.1:0 --engine "$ENGINE" "$@" >>"$st.log" 2>&1 &
	GD_PID=$!
	i=0
	while [ ! -s "$st/granulard.addr" ] && [ $i -lt 100 ]; do sleep 0.05; i=$((i + 1)); done
	URL="http://$(cat "$st/granulard.addr" 2>/dev/null)"
	TOKEN=$(cat "$st/token" 2>/dev/null)
}
gd_stop() { kill -TERM "$GD_PID" 2>/dev/null; wait "$GD_PID" 2>/dev/null; GD_RC=$?; GD_PID=; }

# api METHOD PATH [curl args...]: prints the body, sets CODE.
api() {
	m=$1; p=$2; shift 2
	CODE=$(curl -s -o "$tmp/body" -w '%{http_code}' -X "$m" "$@" "$URL$p")
	echo "$CODE" >"$tmp/code"
	cat "$tmp/body"
}
post() { p=$1; shift; api POST "$p" -H "Authorization: Bearer $TOKEN" -H 'Content-Type: application/json' "$@"; }
# jq-like field access with python: field JSON-TEXT EXPR
# The JSON goes through a pipe from the shell's printf (a builtin), not argv: a long job's progress series
# exceeds the kernel's 128 KiB limit on one argument.
field() { printf '%s' "$1" | /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); print(eval(sys.argv[1]))' "$2" 2>/dev/null; }
# wait_state ID STATE [seconds]: poll until the job reaches STATE.
wait_state() {
	i=0; lim=$(( ${3:-60} * 10 ))
	while [ $i -lt $lim ]; do
		s=$(field "$(api GET "/api/v1/jobs/$1")" 'd["state"]')
		[ "$s" = "$2" ] && return 0
		sleep 0.1; i=$((i + 1))
	done
	return 1
}
# The status of the last api call, also when it ran in a $(...) subshell.
code() { cat "$tmp/code"; }
# alive PID: the process exists and is not a zombie (a container's PID 1 may never reap orphans).
alive() { st=$(sed 's/.*) //' "/proc/$1/stat" 2>/dev/null | cut -d' ' -f1); [ -n "$st" ] && [ "$st" != Z ]; }
# Built with --enable-sanitizers (docs/fuzzing.md): no ASan, LSan or UBSan
# report in any log of this test (the daemon's, the engine's stderr.log).
sanitizer_check() {
	grep -q __asan_init "$GRANULARD" 2>/dev/null || return 0
	rep=$(grep -rl --include='*.log' -e 'ERROR: AddressSanitizer' -e 'ERROR: LeakSanitizer' -e 'runtime error:' "$tmp" 2>/dev/null | head -n 3)
	ok $([ -z "$rep" ]; echo $?) "no sanitizer report in the logs${rep:+: $rep}"
	for f in $rep; do grep -A12 -e 'Sanitizer' -e 'runtime error:' "$f" | head -n 30 | sed 's/^/# /'; done
}
finish() {
	sanitizer_check
	[ $failed -eq 0 ] || for f in "$tmp"/*.log; do echo "# --- $f"; tail -n 30 "$f" | sed 's/^/# /'; done
	echo "1..$n"; [ $failed -eq 0 ]; exit $?; }
