#!/bin/sh
# ./quickstart on copies of the checkout with apt-get, dpkg-query and make stubbed (nothing is installed or
# rebuilt): the demo installs only the build's packages, progress is printed, and `stop` stops exactly the
# daemon of its own checkout, never another granulard.
set -u
. "$(dirname "$0")/daemon_lib.sh"
A= B= C= F=
# The daemons here run from relative paths: daemon_lib's cleanup would not find them.
trap 'for p in $A $B $C $F; do kill -9 "$p" 2>/dev/null; done; cleanup' EXIT

# A checkout: the quickstart under test, a copy of the daemon (its /proc/PID/exe names this checkout), the demo
# scene; configure and make are stubs, and playwright-core "is installed" so npm is never run.
checkout() {
	d=$tmp/$1
	mkdir -p "$d/daemon" "$d/examples" "$d/.npm-test/node_modules/playwright-core"
	cp "$SRCDIR/quickstart" "$d/"
	cp "$GRANULARD" "$d/daemon/granulard"
	cp "$SRCDIR/examples/cooling-2d.json" "$d/examples/"
	printf '#!/bin/sh\necho configured\n' >"$d/configure"
	chmod +x "$d/configure"
}
# Stubs first on PATH: every package is missing, apt-get records what it is asked for and reports progress on
# APT::Status-Fd=1 as apt does, make records its arguments.
mkdir -p "$tmp/bin"
cat >"$tmp/bin/dpkg-query" <<'EOF'
#!/bin/sh
exit 1
EOF
cat >"$tmp/bin/apt-get" <<'EOF'
#!/bin/sh
echo "apt-get $*" >>"$STUB_LOG"
case " $* " in *" install "*)
	echo "Reading package lists..."
	for p in 0 25 50 75 100; do echo "dlstatus:1:$p:Retrieving file"; done
	for p in 0 25 50 75 100; do echo "pmstatus:pkg:$p:Installing pkg"; done ;;
esac
EOF
cat >"$tmp/bin/make" <<'EOF'
#!/bin/sh
echo "make $*" >>"$STUB_LOG"
EOF
printf '#!/bin/sh\nexec "$@"\n' >"$tmp/bin/sudo"
chmod +x "$tmp/bin/"*
export STUB_LOG="$tmp/stub.log" PATH="$tmp/bin:$PATH"

# 1. ./quickstart (the demo): the build's packages only, progress lines, a daemon started and a job submitted.
checkout co1
: >"$STUB_LOG"
GRANULARD_LISTEN=127.0.0.1:0 "$tmp/co1/quickstart" >"$tmp/run.out" 2>&1
rc=$?
installed=$(sed -n 's/^apt-get install .*-o APT::Status-Fd=1 //p' "$STUB_LOG")
ok $([ $rc = 0 ] && [ -n "$installed" ]; echo $?) "./quickstart runs the demo (exit $rc)$( [ $rc = 0 ] || tail -n 3 "$tmp/run.out" | tr '\n' ' ')"
extra=
for p in chromium python3-mdanalysis python3-h5py python3-jsonschema python3-yaml python3-matplotlib hdf5-tools check man-db; do
	case " $installed " in *" $p "*) extra="$extra $p" ;; esac
done
ok $([ -z "$extra" ] && echo " $installed " | grep -q ' libmicrohttpd-dev ' && echo " $installed " | grep -q ' libhdf5-openmpi-dev '; echo $?) \
	"the demo installs the build's packages, not the test suite's${extra:+ (also:$extra)}"
ok $(grep -q '^quickstart: installing [0-9]* Debian package' "$tmp/run.out" && grep -q '^quickstart:   updating the package lists' "$tmp/run.out" &&
     grep -q '^quickstart:   downloading 100%' "$tmp/run.out" && grep -q '^quickstart:   installing 100%' "$tmp/run.out" &&
     grep -q '^quickstart:   packages installed in' "$tmp/run.out"; echo $?) "progress while installing: $(grep -c '^quickstart:   ' "$tmp/run.out") short lines"
ok $(grep -q '^quickstart: configuring' "$tmp/run.out" && grep -q '^quickstart: building with make' "$tmp/run.out" &&
     grep -q '^quickstart:   built in' "$tmp/run.out" && grep -q '^make -j' "$STUB_LOG" && ! grep -q '^Reading package lists' "$tmp/run.out"; echo $?) \
	"progress while building; apt's and make's own output kept in the logs"
ok $([ "$(wc -l <"$tmp/run.out")" -le 30 ]; echo $?) "the demo's output stays short ($(wc -l <"$tmp/run.out") lines)"
A=$(head -n 1 "$tmp/co1/var/granulard.lock" 2>/dev/null)
ok $([ -n "$A" ] && alive "$A" && [ "$(readlink "/proc/$A/exe")" = "$(cd "$tmp/co1" && pwd -P)/daemon/granulard" ] &&
     grep -q '^quickstart: submitted job 1 (queued)' "$tmp/run.out"; echo $?) "the daemon writes its pid ($A) into the lock file it holds; the demo job was submitted"
ok $(! grep -q "$(cat "$tmp/co1/var/token")" "$tmp/run.out"; echo $?) "the token is not printed"

# 2. ./quickstart check installs both lists.
: >"$STUB_LOG"
(cd "$tmp/co1" && ./quickstart check >"$tmp/check.out" 2>&1)
installed=$(sed -n 's/^apt-get install .*-o APT::Status-Fd=1 //p' "$STUB_LOG")
missing=
for p in $("$tmp/co1/quickstart" packages check); do case " $installed " in *" $p "*) ;; *) missing="$missing $p" ;; esac; done
ok $([ -z "$missing" ] && echo " $installed " | grep -q ' chromium ' && grep -q '^make -j[0-9]* check' "$STUB_LOG"; echo $?) \
	"./quickstart check installs the build's and the test suite's packages and runs make check${missing:+ (missing:$missing)}"

# 3. Two more granulards that the old `pkill -f "daemon/granulard --listen .* --state-dir var"` also matched:
# another checkout's, and this checkout's binary on another state directory.
checkout co2
(cd "$tmp/co2" && mkdir -p var && exec daemon/granulard --listen 127.0.0.1:0 --state-dir var >>"$tmp/co2.log" 2>&1) &
B=$!
mkdir -p "$tmp/other"
(cd "$tmp/other" && exec "$tmp/co1/daemon/granulard" --listen 127.0.0.1:0 --state-dir var >>"$tmp/other.log" 2>&1) &
C=$!
i=0
while { [ ! -s "$tmp/co2/var/granulard.addr" ] || [ ! -s "$tmp/other/var/granulard.addr" ]; } && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
ok $(alive "$A" && alive "$B" && alive "$C"; echo $?) "three daemons up: A=$A (co1), B=$B (co2), C=$C (co1's binary, other state dir)"
"$tmp/co1/quickstart" stop >"$tmp/stop.out" 2>&1
rc=$?
i=0
while alive "$A" && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
ok $([ $rc = 0 ] && ! alive "$A" && grep -q "stopping granulard (pid $A)" "$tmp/stop.out" && grep -q 'granulard stopped' "$tmp/stop.out"; echo $?) \
	"co1's stop stopped its own daemon A and said so: $(tr '\n' ' ' <"$tmp/stop.out")"
ok $(alive "$B" && alive "$C"; echo $?) "and neither B (another checkout) nor C (another state dir)"
ok $([ ! -s "$tmp/co1/var/granulard.lock" ]; echo $?) "a stopped daemon leaves no pid in its lock file"
"$tmp/co1/quickstart" stop >"$tmp/stop.out" 2>&1
ok $([ $? = 0 ] && grep -q 'not running' "$tmp/stop.out"; echo $?) "stop again: not running, exit 0"

# 4. A pid in an unlocked file, or a lock held by something else, is never signalled.
echo "$B" >"$tmp/co1/var/granulard.lock"
"$tmp/co1/quickstart" stop >"$tmp/stop.out" 2>&1
ok $([ $? = 0 ] && grep -q 'not running' "$tmp/stop.out" && alive "$B"; echo $?) "a stale pid in an unlocked lock file: not running, B untouched"
(exec 9<"$tmp/co1/var/granulard.lock" && flock 9 && exec sleep 60) &
F=$!
i=0
while flock -n "$tmp/co1/var/granulard.lock" true && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
"$tmp/co1/quickstart" stop >"$tmp/stop.out" 2>&1
ok $([ $? = 1 ] && alive "$B" && grep -q "names pid $B, which is .*/co2/daemon/granulard, not" "$tmp/stop.out"; echo $?) \
	"lock held elsewhere, pid of another checkout's granulard: refused, B untouched: $(cat "$tmp/stop.out")"
echo "$C" >"$tmp/co1/var/granulard.lock"
"$tmp/co1/quickstart" stop >"$tmp/stop.out" 2>&1
ok $([ $? = 1 ] && alive "$C" && grep -q "pid $C .* does not hold" "$tmp/stop.out"; echo $?) \
	"lock held elsewhere, pid of this checkout's binary on another state dir: refused, C untouched"
kill "$F" 2>/dev/null
kill -TERM "$B" "$C"
wait "$B" "$C" 2>/dev/null
finish
