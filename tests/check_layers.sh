#!/usr/bin/env bash
# The layout's rules (docs/layout.md), checked rather than kept by habit:
#  - only src/rt includes Embree (rt.c: the CPU's rays; tri_bvh.c: the GPU backend's BVH builder);
#  - the programs (apps/) include only the public headers and headers of apps/ (photongi-mpi
#    shares apps/photongi's), never the library's internal ones (src/...);
#  - the public headers include only each other and the C library;
#  - a folder of src/ includes only folders below it (the ranks below);
#  - internal macros and enum constants are PGI__ (the public prefix PGI_ is include/'s alone);
#  - the ray tracer (rt.c) does not include the ray capture (ray_log.h sets rt.c's capture hook);
#  - the view pass (src/view) and the path tracer (src/reference) do not use the photon tracer
#    (src/photon): what they share with it (the triangle cache, the lights) is in src/scene.
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

# Internal names: a macro or enum constant defined outside include/ takes PGI__ (two underscores),
# so that PGI_ (one) is the public API's alone (shaders use PGIS_: GLSL reserves double underscores).
while IFS= read -r hit; do
    breach "${hit%%:*}:$(cut -d: -f2 <<<"$hit")" "an internal name with the public prefix: $(grep -oE 'PGI_[A-Z0-9][A-Z0-9_]*' <<<"${hit#*:*:}" | head -1) (internal names are PGI__...)"
done < <(grep -rnE --include='*.c' --include='*.h' --include='*.glsl' --include='*.comp' \
    '^\s*#\s*(define|ifndef)\s+PGI_[A-Z0-9]|^\s+PGI_[A-Z0-9][A-Z0-9_]*\s*=[^=]|enum[^;]*\{[^}]*\bPGI_[A-Z0-9]' \
    src apps tests bench examples python 2>/dev/null | grep -v 'PGI_VERSION_STRING')

# The library's folders, lowest first: a folder includes only folders of a lower rank (docs/architecture.md).
declare -A rank=([core]=0 [io]=1 [metrics]=2 [filter]=2 [scene]=2 [rt]=3 [estimators]=3 [photon]=4 [view]=5
    [gpu]=6 [pipeline]=7 [reference]=8)
for dir in src/*/; do
    d=$(basename "$dir")
    [ -n "${rank[$d]+x}" ] || { breach "$dir" "a folder with no rank in tests/check_layers.sh"; continue; }
    while IFS= read -r hit; do
        to=$(sed -n 's/.*#include *"\([a-z]*\)\/.*/\1/p' <<<"${hit#*:*:}")
        [ -n "$to" ] && [ "$to" != "$d" ] && [ -n "${rank[$to]+x}" ] || continue
        [ "${rank[$to]}" -lt "${rank[$d]}" ] ||
            breach "${hit%%:#*}" "src/$d includes src/$to, which is not below it"
    done < <(grep -rn --include='*.c' --include='*.h' --include='*.glsl' '#include *"[a-z]*/' "$dir")
done

while IFS= read -r hit; do
    breach "${hit%%:#*}" "the ray tracer includes the ray capture (rt.h's pgi__rt_capture hook is the way in)"
done < <(grep -Hn '#include *"\(rt/\)\?ray_log.h"' src/rt/rt.c src/rt/rt.h)

while IFS= read -r hit; do
    breach "${hit%%:#*}" "the view pass or the path tracer includes the photon tracer (shared code belongs in src/scene)"
done < <(grep -rn --include='*.c' --include='*.h' '#include *"photon/' src/view src/reference)

[ $bad -eq 0 ] && echo "check_layers: every rule holds"
exit $bad
