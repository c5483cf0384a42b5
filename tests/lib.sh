# Shared by the shell tests: `. "$(dirname "$0")/lib.sh" NAME` makes $TMP (removed on exit), the
# counters and ok / bad; `summary` at the end prints them and fails the test on any failure.
TMP=$(mktemp -d "${TMPDIR:-/tmp}/pgi-$1-XXXXXX")
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() {
    fail=$((fail + 1))
    echo "FAIL: $*"
}
summary() {
    echo "$1: $pass passed, $fail failed"
    [ "$fail" -eq 0 ]
}
