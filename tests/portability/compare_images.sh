#!/usr/bin/env bash
# The GPU check's image path on PoCL (issue 33): scripts/gpu-images.sh renders two scenes with
# three techniques twice into two folders; sombra_compare_images finds them equal, and fails when
# one folder lacks a file or holds a different image.
set -euo pipefail
cli=$1 compare=$2 work=$3
source=$(cd "$(dirname "$0")/../.." && pwd)
rm -rf "$work" && mkdir -p "$work"
for side in a b; do
  SOMBRA_CLI=$cli "$source/scripts/gpu-images.sh" cpu "$work/$side" --size 16 --scenes "default smoke" \
    --techniques "none dsm rays" --jobs 2 >/dev/null
done
[ "$(ls "$work/a"/*.exr | wc -l)" = 6 ] || { echo "expected 6 renders in $work/a"; ls "$work/a"; exit 1; }
"$compare" "$work/a" "$work/b" --max-abs 0 >"$work/same.txt" || { cat "$work/same.txt"; echo "FAIL: equal folders"; exit 1; }
grep -q "6 images compared: largest max |Δ| 0," "$work/same.txt" || { cat "$work/same.txt"; exit 1; }
rm "$work/b/smoke_rays.exr"
if "$compare" "$work/a" "$work/b" >"$work/missing.txt"; then cat "$work/missing.txt"; echo "FAIL: a missing file passed"; exit 1; fi
grep -q "smoke_rays.exr.*only in" "$work/missing.txt"
cp "$work/a/default_none.exr" "$work/b/smoke_rays.exr"   # another image under the name
if "$compare" "$work/a" "$work/b" --max-abs 1e-3 >"$work/changed.txt"; then cat "$work/changed.txt"; echo "FAIL: a changed image passed"; exit 1; fi
grep -q "FAIL largest max" "$work/changed.txt"
echo "ok: equal folders pass, a missing and a changed image fail"
