#!/bin/bash
# Two builds of `sombra` side by side (bench/README.md "DSM lookup and generation"): per scene and
# storage, renders alternating  A none, A dsm, B none, B dsm  (one warm-up round, then RUNS rounds) and
# prints the medians of the camera pass (stage_ms.camera_pass) and of the generation stages
# (every dsm_* stage) from --stats. Ratios of one run are what to compare on a shared machine.
#   bench/compare_dsm_speed.sh A_BIN B_BIN [RUNS] [SCENES] [STORAGES]
# e.g. bench/compare_dsm_speed.sh /tmp/sombra_before build/sombra 5 "smoke default" "atlas compact"
set -euo pipefail
A=$1; B=$2; RUNS=${3:-5}; SCENES=${4:-"smoke default"}; STORAGES=${5:-"atlas compact chunked chunked-ondemand"}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
no_cache() {  # BIN -> its flag for per-sample lookups (--shadow-cache off; builds before it: --no-shadow-cache)
    local help; help=$("$1" render --help 2>&1 || true)  # not `| grep -q`: its early exit fails the pipe (pipefail)
    if grep -q -- '--shadow-cache' <<<"$help"; then echo "--shadow-cache off"; else echo "--no-shadow-cache"; fi
}
render() {  # BIN SCENE STORAGE SHADOWS -> "camera_pass_ms dsm_stages_sum_ms dsm_build_ms dsm_count_ms"
    # DSM flags only for dsm (sombra refuses options that do not apply); --storage: the spelling every build knows
    local dsm=()
    [ "$4" = dsm ] && dsm=(--dsm-res 512 --eps 0.01 --storage "$3")
    # shellcheck disable=SC2046
    "$1" render "$ROOT/data/scenes/$2.json" -o "$TMP/o.png" --width 256 --height 256 --shadows "$4" "${dsm[@]}" \
        $(no_cache "$1") --stats "$TMP/s.json" -q >/dev/null 2>&1
    python3 -c "import json,sys; s=json.load(open(sys.argv[1]))['stage_ms']
print(s['camera_pass'], sum(v for k, v in s.items() if k.startswith('dsm_')), s.get('dsm_build', 0), s.get('dsm_count', 0))" "$TMP/s.json"
}
echo "| scene | storage | A none ms | A dsm ms | A dsm ÷ none | B none ms | B dsm ms | B dsm ÷ none | A gen ms (build + count) | B gen ms |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for scene in $SCENES; do
    for storage in $STORAGES; do
        : > "$TMP/none"; : > "$TMP/a"; : > "$TMP/bnone"; : > "$TMP/b"
        for i in $(seq 0 "$RUNS"); do  # round 0: warm-up
            n=$(render "$A" "$scene" "$storage" none); a=$(render "$A" "$scene" "$storage" dsm)
            m=$(render "$B" "$scene" "$storage" none); b=$(render "$B" "$scene" "$storage" dsm)
            if [ "$i" -gt 0 ]; then
                echo "$n" >> "$TMP/none"; echo "$a" >> "$TMP/a"; echo "$m" >> "$TMP/bnone"; echo "$b" >> "$TMP/b"
            fi
        done
        python3 - "$scene" "$storage" "$TMP" <<'PY'
import statistics as st, sys
scene, storage, tmp = sys.argv[1:4]
col = lambda f, i: st.median(float(l.split()[i]) for l in open(f"{tmp}/{f}"))
none, a, bnone, b = col("none", 0), col("a", 0), col("bnone", 0), col("b", 0)
gen = lambda f: f"{col(f, 1):.0f} ({col(f, 2):.0f} + {col(f, 3):.0f})"
print(f"| {scene} | {storage} | {none:.1f} | {a:.1f} | {a / none:.2f} | {bnone:.1f} | {b:.1f} | {b / bnone:.2f} | {gen('a')} | {gen('b')} |")
PY
    done
done
