#!/usr/bin/env bash
# The on-disk program cache (src/host/program_cache.h), first frame with and without it: each
# shipped scene rendered by a fresh process (a) with an empty program cache and PoCL's own cache
# off (a cold driver, as Intel's runtime always is), (b) again from the programs (a) stored. Wall
# time of the whole process and the programs compiled / loaded (--stats), medians of REPS runs
# each, (a) and (b) interleaved. Usage: bench/program_cache_bench.sh [SOMBRA_CLI] [WIDTH] [REPS]
set -euo pipefail
cli=${1:-build/sombra} width=${2:-128} reps=${3:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export POCL_KERNEL_CACHE=0
median() { sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }
printf '| scene | technique | cold: wall s | programs compiled | warm: wall s | programs loaded | cold / warm |\n|---|---|---|---|---|---|---|\n'
for scene in default smoke mri_head cup_array; do
    for technique in dsm lowpass; do
        cold=() warm=()
        for ((r = 0; r < reps; r++)); do
            rm -rf "$work/cache"
            for phase in cold warm; do
                start=$(date +%s%N)
                SOMBRA_KERNEL_CACHE="$work/cache" "$cli" render "data/scenes/$scene.json" -o "$work/out.png" -q \
                    --width "$width" --height "$width" --shadows "$technique" --stats "$work/$phase.json"
                seconds=$((($(date +%s%N) - start) / 1000000))  # ms
                if [ $phase = cold ]; then cold+=("$seconds"); else warm+=("$seconds"); fi
            done
        done
        compiled=$(python3 -c "import json; print(json.load(open('$work/cold.json'))['programs']['compiled'])")
        loaded=$(python3 -c "import json; print(json.load(open('$work/warm.json'))['programs']['loaded_from_cache'])")
        c=$(printf '%s\n' "${cold[@]}" | median) w=$(printf '%s\n' "${warm[@]}" | median)
        printf '| %s | %s | %d.%02d | %s | %d.%02d | %s | %d.%d× |\n' "$scene" "$technique" $((c / 1000)) $((c % 1000 / 10)) "$compiled" \
            $((w / 1000)) $((w % 1000 / 10)) "$loaded" $((c / w)) $((c * 10 / w % 10))
    done
done
