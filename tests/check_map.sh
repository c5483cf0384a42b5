#!/usr/bin/env bash
# Checks docs/map.md (paper section -> file -> functions): every table row's file must exist
# and every function it lists must be DEFINED in that file: a line at column 0 holding
# `name(` whose declaration reaches `{` before `;` (a prototype does not count), or a
# `#define name(` macro. For each problem it prints
#   docs/map.md:LINE: what is wrong -> what to write instead (where it can tell)
# and exits 1; 0 when every row checks out; 2 on usage errors.
#   tests/check_map.sh [MAP]      (run from anywhere; paths are relative to the repository root)
set -uo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root" || exit 2
map=${1:-docs/map.md}
[ -f "$map" ] || { echo "check_map: $map not found" >&2; exit 2; }
SEARCH=(src include apps bench tests)

# defined FILE NAME -> prints the line numbers where NAME is defined in FILE
defined() {
  awk -v name="$2" '
    function scan_from(i, rest,   k, c) {
      # first "{" or ";" from the text `rest` on line i onwards (at most 40 lines)
      for (k = 0; k < 40 && i + k <= n; k++) {
        if (k > 0) rest = L[i + k]
        sub(/\/\/.*/, "", rest)
        for (c = 1; c <= length(rest); c++) {
          ch = substr(rest, c, 1)
          if (ch == "{") return 1
          if (ch == ";") return 0
        }
      }
      return 0
    }
    { L[NR] = $0 }
    END {
      n = NR
      pat = "(^|[^A-Za-z0-9_])" name "[ \t]*\\("
      for (i = 1; i <= n; i++) {
        line = L[i]
        if (line ~ ("^#[ \t]*define[ \t]+" name "\\(")) { print i; continue }
        if (line !~ /^[A-Za-z_]/) continue          # definitions start at column 0
        if (match(line, pat) == 0) continue
        if (scan_from(i, substr(line, RSTART + RLENGTH))) print i
      }
    }' "$1"
}

# where NAME -> "file:line" of its definitions anywhere in the tree
where() {
  local f ln
  while IFS= read -r f; do
    for ln in $(defined "$f" "$1"); do echo "$f:$ln"; done
  done < <(grep -rlE --include='*.c' --include='*.h' "(^|[^A-Za-z0-9_])$1[[:space:]]*\(" "${SEARCH[@]}" 2>/dev/null | sort)
}

trim() { local s=$1; s=${s#"${s%%[![:space:]]*}"}; s=${s%"${s##*[![:space:]]}"}; printf '%s' "$s"; }

errors=0 rows=0 fns=0 lineno=0
report() { echo "$map:$lineno: $*"; errors=$((errors + 1)); }

while IFS= read -r line || [ -n "$line" ]; do
  lineno=$((lineno + 1))
  [[ $line == \|* ]] || continue
  IFS='|' read -r -a cols <<< "$line"
  # cols[0] is empty (text before the first '|'); cols[1] item, cols[2] file, cols[3] functions
  file=$(trim "${cols[2]:-}"); file=${file//\`/}
  funcs=$(trim "${cols[3]:-}"); funcs=${funcs//\`/}
  case $file in
    file|---*|:--*|"") continue ;;   # header and separator rows
  esac
  rows=$((rows + 1))
  if [ -z "$funcs" ]; then report "$file: no functions listed"; continue; fi
  IFS=',' read -r -a names <<< "$funcs"
  if [ ! -f "$file" ]; then
    moved=$(find "${SEARCH[@]}" -name "$(basename "$file")" 2>/dev/null | sort | paste -sd' ' -)
    report "$file: no such file${moved:+ (a file of that name: $moved)}"
    for nm in "${names[@]}"; do
      nm=$(trim "$nm"); nm=${nm%()}
      [ -n "$nm" ] || continue
      fns=$((fns + 1))
      at=$(where "$nm" | paste -sd' ' -)
      if [ -n "$at" ]; then echo "    -> $nm: now defined at $at"
      else echo "    -> $nm: defined nowhere in ${SEARCH[*]}"; fi
    done
    continue
  fi
  for nm in "${names[@]}"; do
    nm=$(trim "$nm"); nm=${nm%()}
    [ -n "$nm" ] || continue
    fns=$((fns + 1))
    if ! [[ $nm =~ ^[A-Za-z_][A-Za-z0-9_]*$ ]]; then report "$file: '$nm' is not a C identifier"; continue; fi
    [ -n "$(defined "$file" "$nm")" ] && continue
    at=$(where "$nm" | paste -sd' ' -)
    if [ -n "$at" ]; then
      report "$file: $nm is not defined here; it is defined at $at -> update the row"
    elif grep -qE "(^|[^A-Za-z0-9_])$nm[[:space:]]*\(" "$file"; then
      report "$file: $nm is only declared or called here, defined nowhere in ${SEARCH[*]}"
    else
      report "$file: $nm not found anywhere in ${SEARCH[*]} (renamed or removed?)"
    fi
  done
done < "$map"

if [ "$rows" -eq 0 ]; then echo "check_map: no table rows found in $map" >&2; exit 1; fi
if [ "$errors" -gt 0 ]; then
  echo "check_map: $errors problem(s) in $rows rows ($fns function references) of $map"
  exit 1
fi
echo "check_map: $rows rows, $fns function references in $map: all defined where listed"
