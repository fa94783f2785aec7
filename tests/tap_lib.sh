# Shared by the shell tests that check the engine's output with python (sourced, not run): the TAP counter
# ok(), and report(), which turns a check's "ok - ..." / "not ok - ..." lines into TAP points and its other
# lines into diagnostics. The caller sets n=0 failed=0 and ends with: echo "1..$n"; [ "$failed" = 0 ].
ok() { n=$((n + 1)); if [ "$1" = 0 ]; then echo "ok $n - $2"; else echo "not ok $n - $2"; failed=$((failed + 1)); fi; }
report() {
	while IFS= read -r line; do
		case "$line" in
		"ok - "*) ok 0 "${line#ok - }" ;;
		"not ok - "*) ok 1 "${line#not ok - }" ;;
		*) echo "# $line" ;;
		esac
	done <"$1"
}
