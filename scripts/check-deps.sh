#!/usr/bin/env bash
# Guard against a package installed by hand: every system header and shared library the last
# build in build/ used must belong to a package of scripts/install-deps.sh's list, to one of their
# dependencies (recursively), or to a package of Debian priority "required" (on every system).
# Run after a build; scripts/test.sh runs it. Exit 1 and a list when something is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
[ -d "$build" ] || { echo "check-deps: no build folder $build" >&2; exit 2; }

# headers from the compiler's dependency files, libraries the built programs load
used=$( {
  grep -rhoE '/usr/(include|lib|share)/[^ :\\]+' --include=compiler_depend.make --include='*.d' "$build" || true
  find "$build" -type f -perm -u+x -print0 | while IFS= read -r -d '' f; do
    [ "$(head -c4 "$f" | od -An -c | tr -d ' ')" = "177ELF" ] || continue
    ldd "$f" 2>/dev/null | grep -oE '=> /[^ ]+' | cut -c4- || true
  done
} | sort -u)

declare -A owner_of   # package -> one file it owns that the build used
reals=$(xargs -r realpath -m <<< "$used" | sort -u)
# dpkg knows merged-/usr files under either name; ask for both, in one call each
while IFS= read -r line; do
  case $line in *': '/*) ;; *) continue ;; esac
  pkgs=${line%%: *}; f=${line#*: }
  for p in ${pkgs//,/ }; do owner_of[${p%%:*}]=$f; done
done < <( { xargs -r dpkg -S <<< "$reals"; sed -n 's|^/usr/lib/|/lib/|p' <<< "$reals" | xargs -r dpkg -S; } 2>/dev/null || true)

mapfile -t declared < <(scripts/install-deps.sh --list)
closure=$(apt-cache depends --recurse --installed --no-recommends --no-suggests --no-conflicts \
            --no-breaks --no-replaces --no-enhances "${declared[@]}" |
          sed -nE 's/^([a-z0-9][a-z0-9+.-]+)(:[a-z0-9]+)?$/\1/p; s/^ *\|?(Pre)?Depends: <?([a-z0-9][a-z0-9+.-]+).*/\2/p' |
          sort -u)

missing=0
for p in "${!owner_of[@]}"; do
  grep -qxF "$p" <<< "$closure" && continue
  [ "$(dpkg-query -W -f='${Priority}' "$p" 2>/dev/null)" = required ] && continue
  [ $missing -eq 0 ] && echo "check-deps: the build used packages that scripts/install-deps.sh does not install:"
  echo "  $p (e.g. ${owner_of[$p]})"
  missing=1
done
[ $missing -eq 0 ] && echo "check-deps: ${#owner_of[@]} packages used by the build, all installed by scripts/install-deps.sh"
exit $missing
