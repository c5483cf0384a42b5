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

# write_closed_room DIR: DIR/room.obj (+ room.mtl), a closed box of grey walls, 2 units wide around
# the origin, lit only by a lamp under its ceiling, with no camera: an automatic camera sees its
# outside.
write_closed_room() {
    printf 'newmtl wall\nKd 0.7 0.7 0.7\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n' >"$1/room.mtl"
    {
        printf 'mtllib room.mtl\n'
        printf 'v %s\n' "-1 -1 -1" "1 -1 -1" "1 1 -1" "-1 1 -1" "-1 -1 1" "1 -1 1" "1 1 1" "-1 1 1"
        printf 'v %s\n' "-0.3 0.95 -0.3" "0.3 0.95 -0.3" "0.3 0.95 0.3" "-0.3 0.95 0.3"
        printf 'usemtl wall\nf 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 4 3 7 8\nf 1 4 8 5\nf 2 6 7 3\nusemtl lamp\nf 9 10 11 12\n'
    } >"$1/room.obj"
}
