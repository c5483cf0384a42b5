#!/usr/bin/env bash
# The layout's rules (docs/layout.md), checked rather than kept by habit:
#  - only src/rt includes Embree (rt.c: the CPU's rays; tri_bvh.c: the GPU backend's BVH builder);
#  - the programs (apps/) include only the public headers and headers of apps/ (photongi-mpi
#    shares apps/photongi's), never the library's internal ones (src/...);
#  - the public headers include only each other and the C library.
# Prints each breach as FILE:LINE: what, and exits 1; 0 when every rule holds.
#   tests/check_layers.sh      (run from anywhere)
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root" || exit 2
bad=0
breach() { echo "$1: $2"; bad=1; }

while IFS= read -r hit; do
    breach "${hit%%:#*}" "Embree included outside src/rt (ray tracing goes through src/rt/rt.h or tri_bvh.h)"
done < <(grep -rn --include='*.c' --include='*.h' '#include *<embree' src apps bench tests python include |
    grep -v '^src/rt/')

while IFS= read -r hit; do
    file=${hit%%:*}
    inc=$(sed -n 's/.*#include *"\([^"]*\)".*/\1/p' <<<"${hit#*:*:}")
    case $inc in
    photongi/*) ;;
    */*) breach "${hit%%:#*}" "a program includes the library's internal header \"$inc\"" ;;
    *) [ -f "$(dirname "$file")/$inc" ] || compgen -G "apps/*/$inc" >/dev/null ||
        breach "${hit%%:#*}" "\"$inc\" is neither a public header nor one of apps/" ;;
    esac
done < <(grep -rn --include='*.c' --include='*.h' '#include *"' apps)

while IFS= read -r hit; do
    inc=$(sed -n 's/.*#include *"\([^"]*\)".*/\1/p' <<<"${hit#*:*:}")
    case $inc in photongi/*) ;; *) breach "${hit%%:#*}" "a public header includes \"$inc\"" ;; esac
done < <(grep -rn '#include *"' include)

[ $bad -eq 0 ] && echo "check_layers: every rule holds"
exit $bad
