#!/usr/bin/env bash
# Formats the C sources with the repository's .clang-format (clang-format 14, Debian's
# `clang-format` package; scripts/install-deps.sh installs it).
#   scripts/format.sh            rewrite src include apps bench tests examples (*.c, *.h) in place
#   scripts/format.sh --check    change nothing; list violations, exit 1 if there are any
# CLANG_FORMAT=/path/to/clang-format overrides the binary.
set -euo pipefail

cd "$(dirname "$0")/.."
CF=${CLANG_FORMAT:-clang-format}
DIRS=(src include apps bench tests examples python)

mode=fix
case "${1:-}" in
  "") ;;
  --check) mode=check ;;
  -h|--help) sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "format.sh: unknown option '$1' (use --check or nothing)" >&2; exit 2 ;;
esac

if ! command -v "$CF" >/dev/null 2>&1; then
  echo "format.sh: $CF not found (apt-get install clang-format, or scripts/install-deps.sh)" >&2
  exit 2
fi
ver=$("$CF" --version | sed -n 's/.*version \([0-9][0-9]*\).*/\1/p')
if [ "$ver" != "14" ]; then
  echo "format.sh: warning: .clang-format is tuned for clang-format 14, this is ${ver:-unknown}" >&2
fi

files=()
while IFS= read -r -d '' f; do files+=("$f"); done \
  < <(find "${DIRS[@]}" -type f \( -name '*.c' -o -name '*.h' \) -print0 | sort -z)
if [ ${#files[@]} -eq 0 ]; then
  echo "format.sh: no sources found" >&2; exit 2
fi

if [ "$mode" = fix ]; then
  "$CF" -i --style=file "${files[@]}"
  exit 0
fi

if "$CF" --dry-run -Werror --style=file "${files[@]}"; then
  echo "format.sh: ${#files[@]} files formatted"
else
  echo "format.sh: formatting differs (run scripts/format.sh to fix)" >&2
  exit 1
fi
