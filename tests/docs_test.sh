#!/bin/sh
# What users read first: `make install` puts both man pages where man finds them, --help shows each default once
# in plain digits, ranges are the ones really taken, docs/daemon.md's key table is the daemon's, no token on a command line.
set -u
: "${SRCDIR:=$(cd "$(dirname "$0")/.." && pwd)}"
: "${BUILDDIR:=$SRCDIR}"
: "${GRANULARD:=$BUILDDIR/daemon/granulard}"
: "${GRANULARCTL:=$BUILDDIR/client/granularctl}"
: "${ENGINE:=$BUILDDIR/engine/granular-engine}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/granulard_docs.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
n=0; failed=0
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
skip() { n=$((n + 1)); echo "ok $n # SKIP $1"; }

# 1. make install DESTDIR=...: both pages installed, and man finds them by name.
# (A make of its own: not the jobserver of the make running the tests.)
env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -C "$BUILDDIR" install DESTDIR="$tmp/root" >"$tmp/install.log" 2>&1
ok $? "make install DESTDIR=... $(tail -n 1 "$tmp/install.log" | grep -i error)"
ctl_page=$(find "$tmp/root" -path '*/man1/granularctl.1' | head -n 1)
gd_page=$(find "$tmp/root" -path '*/man8/granulard.8' | head -n 1)
ok $([ -n "$ctl_page" ] && [ -n "$gd_page" ]; echo $?) "granularctl.1 in man1 and granulard.8 in man8: ${ctl_page#"$tmp/root"} ${gd_page#"$tmp/root"}"
if command -v man >/dev/null && [ -n "$ctl_page" ] && [ -n "$gd_page" ]; then
	mp=$(dirname "$(dirname "$ctl_page")")
	for page in granularctl granulard; do
		MANPATH=$mp MANWIDTH=100 man "$page" >"$tmp/$page.txt" 2>"$tmp/$page.err" </dev/null
		rc=$?
		ok $([ $rc = 0 ] && grep -q "^NAME" "$tmp/$page.txt" && grep -q "^ *$page -" "$tmp/$page.txt"; echo $?) "man $page works after make install"
		MANPATH=$mp man --warnings -l "$(MANPATH=$mp man -w "$page")" >/dev/null 2>"$tmp/$page.warn" </dev/null
		ok $([ ! -s "$tmp/$page.warn" ]; echo $?) "man $page renders without groff warnings$( [ -s "$tmp/$page.warn" ] && echo ": $(head -n 1 "$tmp/$page.warn")")"
	done
	# SEE ALSO names the other page, which is installed (man -w finds it).
	sed -n '/^SEE ALSO/,$p' "$tmp/granularctl.txt" | grep -q 'granulard(8)' && MANPATH=$mp man -w 8 granulard >/dev/null 2>&1
	ok $? "granularctl(1) SEE ALSO names granulard(8), and man 8 granulard finds it"
	sed -n '/^SEE ALSO/,$p' "$tmp/granulard.txt" | grep -q 'granularctl(1)'
	ok $? "granulard(8) SEE ALSO names granularctl(1)"
	# The OPTIONS of the installed page are the program's own keys (generated from daemon/cfg.c).
	missing=
	for k in $("$GRANULARD" --list-keys markdown | sed -n 's/^| `\([a-z_]*\)` .*/\1/p'); do
		flag=$(echo "$k" | tr _ -)
		grep -q -- "--$flag .*($k)" "$tmp/granulard.txt" || missing="$missing $k"
	done
	ok $([ -z "$missing" ]; echo $?) "granulard(8) lists every configuration key${missing:+ (missing:$missing)}"
else
	skip "man (man-db) not installed"
fi

# 2. --help of the daemon: every key once, each default once, numbers in digits (no 1.07374e+09).
"$GRANULARD" --help >"$tmp/help" 2>&1
ok $? "granulard --help exits 0"
nkeys=$("$GRANULARD" --list-keys markdown | grep -c '^| `')
nflags=$(grep -c '^  --' "$tmp/help")
ok $([ "$nkeys" -gt 20 ] && [ "$nflags" = "$nkeys" ]; echo $?) "--help lists each of the $nkeys keys once ($nflags flag lines)"
# One entry = its flag line and the indented continuation lines.
awk '/^  --/ { if (e != "") print e; e = $0; next } /^   / { e = e " " $0; next } END { if (e != "") print e }' "$tmp/help" >"$tmp/entries"
bad=$(awk '{ c = gsub(/[Dd]efault/, "&"); if (c != 1) print $1 }' "$tmp/entries" | tr '\n' ' ')
ok $([ -z "$bad" ]; echo $?) "every --help entry states its default exactly once${bad:+ (not: $bad)}"
ok $(! grep -Eq '[0-9]e[+-]?[0-9]' "$tmp/help"; echo $?) "--help has no number in exponent notation$(grep -Eo '[^ ]*[0-9]e[+-]?[0-9][^ ]*' "$tmp/help" | head -n 1 | sed 's/^/: /')"
ok $(grep -q -- '--max-body BYTES .*1073741824 (1 GiB); default 4194304 (4 MiB)' "$tmp/entries"; echo $?) "byte counts read as digits with their binary multiple: $(grep -o -- '--max-body.*' "$tmp/entries" | cut -c1-90)"
"$GRANULARD" --max-body 2e9 >/dev/null 2>"$tmp/err"
ok $([ $? = 2 ] && grep -q -- '--max-body: 2e9 is out of range 1024..1073741824' "$tmp/err"; echo $?) "a value out of range names the flag as typed and the range in digits: $(cat "$tmp/err")"

# 3. max_particles: the range --help states is the one the scene parser takes.
hi=$(grep -- '--max-particles' "$tmp/entries" | sed -n 's/.*; 2\.\.\([0-9][0-9]*\);.*/\1/p')
scene() { printf '{"method":"ed","dimensions":2,"particles":{"count":%s,"volume_fraction":0.2},"run":{"until":{"time":1}}}\n' "$1" >"$tmp/n.json"; }
if [ -n "$hi" ]; then
	scene "$hi"; "$ENGINE" validate "$tmp/n.json" >/dev/null 2>&1; r1=$?
	scene "$((hi + 1))"; "$ENGINE" validate "$tmp/n.json" >/dev/null 2>"$tmp/err"; r2=$?
	"$GRANULARD" --max-particles "$hi" --help >/dev/null 2>&1; r3=$?
	"$GRANULARD" --max-particles "$((hi + 1))" --help >/dev/null 2>&1; r4=$?
	ok $([ $r1 = 0 ] && [ $r2 = 2 ] && grep -q particles.count "$tmp/err" && [ $r3 = 0 ] && [ $r4 = 2 ]; echo $?) \
		"max_particles 2..$hi: the parser takes count $hi and refuses $((hi + 1)), and so does the daemon's key"
else
	ok 1 "max_particles states an integer range in --help: $(grep -- '--max-particles' "$tmp/entries")"
fi

# 4. The client's help: each option line states at most one default, no exponent notation.
: >"$tmp/ctlhelp"
for c in "" submit advise list show watch cancel delete progress clusters files download cluster presets; do
	# shellcheck disable=SC2086
	"$GRANULARCTL" $c --help >>"$tmp/ctlhelp" 2>&1
done
ok $(! grep -Eq '[Dd]efault.*[Dd]efault|[0-9]e[+-]?[0-9]' "$tmp/ctlhelp"; echo $?) "granularctl help: each default once, digits only$(grep -E '[Dd]efault.*[Dd]efault' "$tmp/ctlhelp" | head -n 1 | sed 's/^/ (not: /; s/$/)/')"

# 5. docs/daemon.md's key table is the daemon's own (regenerate: granulard --list-keys markdown).
# The mpirun default is the one configure found: the row's last cell is left out of the comparison.
mpirun_row='/^| `mpirun` |/s/| [^|]* |$/| (found by configure) |/'
"$GRANULARD" --list-keys markdown | sed "$mpirun_row" >"$tmp/keys.md"
sed -n '/^| key | flag |/,/^$/p' "$SRCDIR/docs/daemon.md" | sed '/^$/d' | sed "$mpirun_row" >"$tmp/doc-keys.md"
diff -u "$tmp/doc-keys.md" "$tmp/keys.md" >"$tmp/keys.diff"
ok $? "docs/daemon.md's key table equals 'granulard --list-keys markdown'$( [ -s "$tmp/keys.diff" ] && echo " ($(grep -c '^[-+]|' "$tmp/keys.diff") lines differ)")"

# 6. No token on a command line in the documentation: a token in argv shows in ps to every user.
hits=$(cd "$SRCDIR" && grep -nE 'Bearer \$|--token[ =]+["$]|TOKEN=\$\(|--token "?\$' README.md docs/*.md client/granularctl.1 daemon/granulard.8.in 2>/dev/null)
ok $([ -z "$hits" ]; echo $?) "no token on a command line in README.md, docs/*.md, the man pages${hits:+: $(echo "$hits" | head -n 1)}"

echo "1..$n"
[ $failed -eq 0 ]
