#!/usr/bin/env bash
# Every kernel program variant compiles for NVIDIA sm_90 (issue 33, item 2). Collects the programs
# the renderer really builds (SOMBRA_DUMP_PROGRAMS: expanded source and -D options of each program
# it asks for, also those it loads from the program cache, which stays on)
# from tiny renders on PoCL that cover the variant families (the list below): every --shadows
# technique, lanes 1/4/8/16, every DSM storage and lookup and DSM option, the shadow cache on and
# off, image volumes, Sobel, scattering, meshes, bounds, clusters, point/spot/directional lights,
# box/gauss low-pass kernels, the dsm, visibility and clusters commands, two shipped mesh scenes,
# and (third argument: the test binary) the tests' sample and layout probes. Then each distinct
# program:
#   clang-15 -x cl -target nvptx64-nvidia-nvcl -march=sm_86 -O3 <the program's own options>
#            -Wall -Werror + libclc's NVPTX built-ins (-mlink-builtin-bitcode)    ->  PTX 7.5
#   ptxas -arch=sm_90 -v                                                       ->  registers, spills, stack
# LLVM 15's NVPTX back end stops at sm_86 / PTX 7.5; ptxas assembles that PTX for sm_90, as the
# driver does for a newer GPU. ptxas assembles whole programs, so a helper that is called but
# never defined (a plain C99 `inline` left out of line) fails here with "Unresolved extern
# function", as it did on NVIDIA's compiler. This is a second, strict compiler and NVIDIA's real
# assembler, not NVIDIA's OpenCL front end: the register counts are indicative of the driver's.
# Images: see "image stand-in" below (a gap of libclc 15, reported per program in the report).
# Writes WORK_DIR/report.md (per program and kernel: registers, spill stores/loads, stack frame)
# and fails (exit 1) naming the program (source, options) and the first error lines of any
# compile or ptxas error, or any render that fails. Usage: ptx_check.sh SOMBRA_CLI WORK_DIR
# [SOMBRA_TESTS]. Exit 77 (skipped) without clang-15, libclc-15 (scripts/install-deps.sh installs
# both) or ptxas ($PTXAS, PATH, /usr/local/cuda/bin, else PyPI's nvidia-cuda-nvcc in .python-deps
# if it was put there: this script installs nothing). PTX_CHECK_JOBS: parallel jobs (default 2).
set -euo pipefail
cli=$1 work=$2 tests=${3:-}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
jobs=${PTX_CHECK_JOBS:-2}

skip() { echo "ptx_check.sh: $1: skipped"; exit 77; }
clang=$(command -v clang-15 || true)
[ -n "$clang" ] || skip "clang-15 is not installed"
libclc=/usr/lib/clc/nvptx64--nvidiacl.bc
[ -f "$libclc" ] || skip "libclc's NVPTX built-ins are not installed ($libclc: Debian package libclc-15)"
ptxas=${PTXAS:-}
if [ -z "$ptxas" ]; then
    for candidate in "$(command -v ptxas || true)" /usr/local/cuda/bin/ptxas \
                     "$root"/.python-deps/lib/python3*/site-packages/nvidia/*/bin/ptxas; do
        if [ -n "$candidate" ] && [ -x "$candidate" ]; then ptxas=$candidate; break; fi
    done
fi
[ -n "$ptxas" ] && [ -x "$ptxas" ] || skip "ptxas not found (CUDA toolkit: /usr/local/cuda/bin/ptxas)"

rm -rf "$work" && mkdir -p "$work/dump" "$work/renders" "$work/out"
work=$(cd "$work" && pwd)
started=$(date +%s)
echo "ptx_check.sh: $("$clang" --version | head -1); ptxas $("$ptxas" --version | sed -n 's/.*release \([0-9.]*\).*/\1/p'); $libclc"

# ---- scenes: spheres of 8³ voxels; lights: one directional, or directional + point + spot, or none;
# meshes: a closed cube (cube.obj) as translucent geometry and as a volume's bounds ----
volume='{"generator": {"type": "sphere", "size": 8}, "transform": {"scale": 0.1},
         "transfer_function": {"rgb_points": [0, 1, 1, 1, 1, 1, 0.5, 0.2], "opacity_points": [0, 0, 1, 0.5]}}'
camera='"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "image": {"width": 8, "height": 8}'
one='"lights": [{"type": "directional", "direction": [0, -1, -1]}]'
three='"lights": [{"type": "directional", "direction": [0, -1, -1]}, {"type": "point", "position": [1, 2, 2]},
                  {"type": "spot", "position": [-2, 2, 1], "direction": [2, -2, -1], "cone_angle_deg": 30}]'
cube='{"name": "cube", "file": "cube.obj", "transform": {"translate": [0.4, 0, 0], "scale": 0.3},
       "material": {"color": [0.9, 0.4, 0.2], "opacity": 0.6}}'
printf 'v %s\n' "-1 -1 -1" "1 -1 -1" "1 1 -1" "-1 1 -1" "-1 -1 1" "1 -1 1" "1 1 1" "-1 1 1" >"$work/cube.obj"
printf 'f %s\n' "1 3 2" "1 4 3" "5 6 7" "5 7 8" "1 2 6" "1 6 5" "2 3 7" "2 7 6" "3 4 8" "3 8 7" "4 1 5" "4 5 8" >>"$work/cube.obj"
echo "{$camera, \"volumes\": [$volume], $one}" >"$work/one.json"
echo "{$camera, \"volumes\": [$volume, $volume], $three}" >"$work/three.json"
echo "{$camera, \"volumes\": [$volume], \"lights\": []}" >"$work/dark.json"
echo "{$camera, \"volumes\": [$volume, $volume], \"meshes\": [$cube], $three}" >"$work/mesh.json"
echo "{$camera, \"volumes\": [${volume%\}}, \"bounds\": {\"mesh\": \"cube.obj\", \"transform\": {\"scale\": 0.3}}}], $one}" >"$work/bounded.json"
printf '0,0,0\n0.05,0.02,0\n' >"$work/points.csv"

# ---- the renders (one per line: a name, then the arguments after the CLI) ----
# Every technique at 1 lane (GPUs' default) with the shadow cache off and on; dsm at 4, 8 (with
# meshes) and 16 lanes (camera pass and DSM generation), rays and lowpass at 8 (a program at 8 or
# 16 lanes costs 5 to 10 times one at 1 lane to assemble); every DSM storage with packed
# and native lookups, each DSM option that adds a define; images; Sobel, scattering, no empty-space
# skipping, ray step, gauss kernel, no lights; meshes, bounds, clusters; the dsm, visibility and
# clusters commands; steaming_cups.json and cup_array.json once each (many volumes and meshes).
scenes=$root/data/scenes
list=$work/renders.txt
: >"$list"
add() { local name=$1; shift; printf '%s\t%s\n' "$name" "$*" >>"$list"; }
r() {  # r NAME SCENE ARGS...: a tiny render on PoCL (--dsm-res for the techniques with maps only)
    local name=$1 scene=$2 shadows=dsm previous="" res=""; shift 2
    for a in "$@"; do [ "$previous" = --shadows ] && shadows=$a; previous=$a; done
    case $shadows in dsm|shadowmap) res="--dsm-res 16";; esac
    add "$name" render "$scene" -o "$work/renders/$name.png" --width 8 --height 8 $res --device cpu -q "$@"
}
for shadows in none rays dsm shadowmap lowpass ao cone; do
    r "$shadows" "$work/three.json" --shadows $shadows --lanes 1 --shadow-cache off
    r "$shadows-cache" "$work/three.json" --shadows $shadows --lanes 1 --shadow-cache on
done
r dsm-l4 "$work/three.json" --lanes 4 --shadow-cache off
r dsm-l16 "$work/three.json" --lanes 16 --shadow-cache off
r rays-l8 "$work/three.json" --shadows rays --lanes 8 --shadow-cache off
r lowpass-l8 "$work/three.json" --shadows lowpass --lanes 8 --shadow-cache off
for storage in atlas chunked chunked-ondemand compact; do
    for lookup in packed native; do
        r "dsm-$storage-$lookup" "$work/one.json" --lanes 1 --dsm-storage $storage --dsm-lookup $lookup --shadow-cache off
    done
done
r dsm-absolute "$work/one.json" --lanes 1 --dsm-error absolute --shadow-cache off
r dsm-precompression "$work/one.json" --lanes 1 --precompression --shadow-cache off
for prefilter in box tent 5tap; do
    r "dsm-prefilter-$prefilter" "$work/one.json" --lanes 1 --prefilter $prefilter --shadow-cache off
done
r dsm-compact-prefilter "$work/one.json" --lanes 1 --prefilter box --dsm-storage compact --shadow-cache off
r dsm-image "$work/one.json" --lanes 1 --volume-storage image --shadow-cache off
r lowpass-image "$work/one.json" --shadows lowpass --lanes 1 --volume-storage image --shadow-cache off
r scattering "$work/three.json" --lanes 1 --shading scattering --phase-g 0.3 --shadow-cache off
r sobel "$work/one.json" --lanes 1 --gradient sobel --shadow-cache off
r no-skipping "$work/one.json" --lanes 1 --no-empty-space-skipping --shadow-cache off
r rays-step "$work/one.json" --shadows rays --lanes 1 --ray-step 0.5 --shadow-cache off
r lowpass-gauss "$work/three.json" --shadows lowpass --lanes 1 --filter-kernel gauss --shadow-cache off
# the float lookups of devices without cl_khr_fp64 (cl/lowpass.h)
r lowpass-gauss-float "$work/three.json" --shadows lowpass --lanes 1 --filter-kernel gauss --sat-precision float --shadow-cache off
r cone-float "$work/three.json" --shadows cone --lanes 1 --sat-precision float --shadow-cache on
r dark "$work/dark.json" --lanes 1
for shadows in dsm rays lowpass; do
    r "mesh-$shadows" "$work/mesh.json" --shadows $shadows --lanes 1 --shadow-cache off
done
r mesh-cache "$work/mesh.json" --lanes 1 --shadow-cache on
r mesh-l8 "$work/mesh.json" --lanes 8 --shadow-cache off
r mesh-clusters "$work/mesh.json" --lanes 1 --clusters 3 --shadow-cache off
r bounded-rays "$work/bounded.json" --shadows rays --lanes 1 --shadow-cache off
r steaming_cups "$scenes/steaming_cups.json" --lanes 1 --shadow-cache on
r cup_array "$scenes/cup_array.json" --shadows rays --lanes 1 --shadow-cache off
add dsm-command dsm "$work/three.json" -o "$work/renders/point.exr" --light 1 --dsm-res 16 --device cpu -q
add visibility visibility "$work/three.json" --points "$work/points.csv" --light 2 --dsm-res 16 --device cpu -q
add clusters clusters "$work/mesh.json" --image "$work/renders/clusters.png" --width 8 --height 8 --device cpu

# Runs "$@" at most $jobs at a time (the caller waits).
throttle() { while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done; }
export SOMBRA_DUMP_PROGRAMS=$work/dump
renders=0
while IFS=$'\t' read -r name args; do
    throttle
    # shellcheck disable=SC2086  # the arguments are words without spaces
    ( begin=$SECONDS
      if timeout 300 "$cli" $args >"$work/renders/$name.log" 2>&1; then echo "ok $((SECONDS - begin)) s" >"$work/renders/$name.status"
      else echo "exit $?" >"$work/renders/$name.status"; fi ) &
    renders=$((renders + 1))
done <"$list"
if [ -n "$tests" ]; then  # the test-only programs: the sample probe (buffer, image, Sobel) and the layout probe
    for tag in '[sampling]' '[layout]'; do
        throttle
        name=tests-${tag//[^a-z]/}
        printf '%s\t%s\n' "$name" "$tests $tag" >>"$list"
        # a crash after "All tests passed" (exit ≠ 0) is the test binary's own, which its ctest
        # entries report: noted here, and the programs it dumped are checked
        ( begin=$SECONDS
          if timeout 300 "$tests" "$tag" >"$work/renders/$name.log" 2>&1; then echo "ok $((SECONDS - begin)) s" >"$work/renders/$name.status"
          else code=$?
               if grep -q "^All tests passed" "$work/renders/$name.log"; then echo "ok $((SECONDS - begin)) s, exit $code after all tests passed" >"$work/renders/$name.status"
               else echo "exit $code" >"$work/renders/$name.status"; fi
          fi ) &
        renders=$((renders + 1))
    done
fi
wait
unset SOMBRA_DUMP_PROGRAMS
collected=$(date +%s)
status=0
for s in "$work"/renders/*.status; do
    if [ "$(cut -c1-2 "$s")" != ok ]; then
        name=$(basename "$s" .status)
        echo "FAIL collecting $name ($(cat "$s")): $(grep -P "^$name\t" "$list" | cut -f2)"
        head -20 "$work/renders/$name.log"
        status=1
    fi
done

# ---- compile every distinct program ----
standin=$work/image_standin
# libclc 15 has no image built-ins for NVPTX: clang lowers a program-scope sampler to a call of
# __translate_sampler_initializer and leaves read_imagef to the library, and both stay unresolved
# externs. Stand-ins (LLVM IR, linked into programs that read images only) so that the rest of such
# a program is assembled: the "sample" depends on the coordinates, so their computation is kept.
# Both read_imagef overloads: float coordinates, and the integer ones of the 8-voxel trilinear.
cat >"$standin.ll" <<'LL'
target datalayout = "e-i64:64-i128:128-v16:16-v32:32-n16:32:64"
target triple = "nvptx64-nvidia-nvcl"
define ptr addrspace(4) @__translate_sampler_initializer(i32 %bits) {
  ret ptr addrspace(4) null
}
define <4 x float> @_Z11read_imagef14ocl_image3d_ro11ocl_samplerDv4_f(ptr addrspace(1) %image, ptr addrspace(4) %sampler, <4 x float> %p) {
  %x = extractelement <4 x float> %p, i32 0
  %y = extractelement <4 x float> %p, i32 1
  %z = extractelement <4 x float> %p, i32 2
  %xy = fadd float %x, %y
  %xyz = fadd float %xy, %z
  %v = insertelement <4 x float> <float 0.0, float 0.0, float 0.0, float 1.0>, float %xyz, i32 0
  ret <4 x float> %v
}
define <4 x float> @_Z11read_imagef14ocl_image3d_ro11ocl_samplerDv4_i(ptr addrspace(1) %image, ptr addrspace(4) %sampler, <4 x i32> %p) {
  %pf = sitofp <4 x i32> %p to <4 x float>
  %v = call <4 x float> @_Z11read_imagef14ocl_image3d_ro11ocl_samplerDv4_f(ptr addrspace(1) %image, ptr addrspace(4) %sampler, <4 x float> %pf)
  ret <4 x float> %v
}
LL
"$clang" -x ir -target nvptx64-nvidia-nvcl -c -emit-llvm "$standin.ll" -o "$standin.bc"
# -Wall -Werror, except: unused functions (headers define helpers a variant may not call), linker
# warnings (libclc's triple is spelt nvptx64--nvidiacl), and bitwise & of comparisons with calls
# (lane masks are combined with & on purpose: no short circuit, the same text for 1 and 16 lanes).
warnings=(-Wall -Werror -Wno-unused-function -Wno-error=linker-warnings -Wno-bitwise-instead-of-logical)
compile() {  # one program: DIGEST -> out/DIGEST.{ptx,clang.log,ptxas.log,result,seconds}
    local digest=$1 source=$work/dump/$1.cl out=$work/out/$1 options extra=() note="" t0 t1 t2
    read -r -a options <"$work/dump/$digest.options"
    t0=$(date +%s.%N)
    "$clang" -x cl -E "${options[@]}" -target nvptx64-nvidia-nvcl "$source" -o "$out.i" 2>/dev/null || true
    if grep -q '\bread_image' "$out.i"; then
        extra=(-Xclang -mlink-builtin-bitcode -Xclang "$standin.bc")
        note="image stand-in"
    fi
    rm -f "$out.i"
    if ! "$clang" -x cl "${options[@]}" -target nvptx64-nvidia-nvcl -march=sm_86 -O3 "${warnings[@]}" \
            -Xclang -mlink-builtin-bitcode -Xclang "$libclc" "${extra[@]}" -S "$source" -o "$out.ptx" >"$out.clang.log" 2>&1; then
        echo "clang" >"$out.result"
        return
    fi
    t1=$(date +%s.%N)
    if ! "$ptxas" -arch=sm_90 -v "$out.ptx" -o "$out.cubin" >"$out.ptxas.log" 2>&1; then
        echo "ptxas" >"$out.result"
    else
        echo "ok${note:+ ($note)}" >"$out.result"
    fi
    t2=$(date +%s.%N)
    echo "$t0 $t1 $t2" | awk '{printf "%.2f %.2f\n", $2 - $1, $3 - $2}' >"$out.seconds"
    rm -f "$out.cubin"
}
for options in "$work"/dump/*.options; do
    throttle
    compile "$(basename "$options" .options)" &
done
wait
finished=$(date +%s)

# ---- no integer min/max/clamp of a vector against a scalar ----
# Legal OpenCL C, but Oclgrind 21.10 reads the scalar as a vector (tests/portability/oclgrind_min_scalar.cl):
# lane code splats the bound (lmin, lclamp in cl/lanes.h). Found in the unlinked IR by the mangled
# name, e.g. _Z3minDv4_ii = min(int4, int).
mixed=$work/vector_scalar.txt
: >"$mixed"
for options in "$work"/dump/*.options; do
    digest=$(basename "$options" .options)
    read -r -a opts <"$options"
    "$clang" -x cl "${opts[@]}" -Xclang -finclude-default-header -O0 -S -emit-llvm "$work/dump/$digest.cl" \
        -o "$work/out/$digest.ll" 2>/dev/null || continue  # a compile failure is reported below
    grep -ohE '@_Z[0-9]+(min|max|clamp)Dv[0-9]+_([ijlm])\2+\b' "$work/out/$digest.ll" | sort -u |
        sed "s/^/$digest: /" >>"$mixed" || true
    rm -f "$work/out/$digest.ll"
done
if [ -s "$mixed" ]; then
    echo "FAIL: integer min/max/clamp of a vector against a scalar (use lmin/lclamp of cl/lanes.h):"
    cat "$mixed"
    status=1
fi

# ---- the report ----
versions="$("$clang" --version | head -1), ptxas $("$ptxas" --version | sed -n 's/.*release \([0-9.]*\).*/\1/p'), $libclc"
python3 - "$work" "$((collected - started))" "$((finished - collected))" "$versions" <<'PY' || status=1
import glob, os, re, sys
work, collect_s, compile_s, versions = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
noise = re.compile(r"Linking two modules of different target triples|^\s*\[-Wlinker-warnings\]|^\d+ warnings? generated")
def read(path):
    return open(path, errors='replace').read() if os.path.exists(path) else ''

runs = [line.split('\t') for line in read(os.path.join(work, 'renders.txt')).splitlines()]
run_notes = []
for name, args in runs:
    status = read(os.path.join(work, 'renders', name + '.status')).strip()
    if 'after all tests passed' in status:
        run_notes.append(f'{name} ({args}): {status}')

programs, failures = [], []
for options_path in sorted(glob.glob(os.path.join(work, 'dump', '*.options'))):
    digest = os.path.basename(options_path)[:-len('.options')]
    options = read(options_path).strip()
    source = re.match(r'#line 1 "([^"]+)"', read(os.path.join(work, 'dump', digest + '.cl')))
    out = os.path.join(work, 'out', digest)
    p = dict(digest=digest, source=source.group(1) if source else '?', options=options,
             defines=' '.join(o[2:].replace('SOMBRA_', '') for o in options.split() if o.startswith('-D')) or '(none)',
             result=read(out + '.result').strip() or 'not compiled', kernels=[], functions=[],
             seconds=[float(x) for x in read(out + '.seconds').split()] or [0.0, 0.0])
    clang_log, ptxas_log = read(out + '.clang.log'), read(out + '.ptxas.log')
    p['warnings'] = [l for l in clang_log.splitlines() if 'warning:' in l and not noise.search(l)]
    current = None
    for line in ptxas_log.splitlines():
        m = re.search(r"Compiling entry function '(\w+)'", line)
        if m:
            current = {'name': m.group(1)}; p['kernels'].append(current); continue
        m = re.search(r"Function properties for (\w+)", line)
        if m:
            known = [k for k in p['kernels'] if k['name'] == m.group(1)]
            current = known[0] if known else {'name': m.group(1)}
            if not known: p['functions'].append(current)
            continue
        m = re.search(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads", line)
        if m and current is not None:
            current['stack'], current['spill_st'], current['spill_ld'] = map(int, m.groups())
        m = re.search(r"Used (\d+) registers", line)
        if m and current is not None:
            current['regs'] = int(m.group(1))
    programs.append(p)
    if not p['result'].startswith('ok'):
        log = ptxas_log if p['result'] == 'ptxas' else clang_log
        failures.append((p, [l for l in log.splitlines() if l.strip() and not noise.search(l)][:12]))

ok = [p for p in programs if p['result'].startswith('ok')]
standin = [p for p in programs if 'stand-in' in p['result']]
kernels = [(p, k) for p in ok for k in p['kernels']]
names = sorted({k['name'] for _, k in kernels})
spills = lambda k: k.get('spill_st', 0) + k.get('spill_ld', 0)
spilling = [(p, k) for p, k in kernels if spills(k)]
by_source = {}
for p in programs: by_source[p['source']] = by_source.get(p['source'], 0) + 1
lanes = lambda p: (re.search(r'LANES=(\d+)', p['options']) or [None, '-'])[1]
clang_s, ptxas_s = sum(p['seconds'][0] for p in programs), sum(p['seconds'][1] for p in programs)
md = ['# NVPTX / ptxas check (sm_90)', '',
      f'Toolchain: {versions}. Written by tests/portability/ptx_check.sh.', '',
      f'{len(runs)} renders and commands on PoCL ({collect_s} s) gave {len(programs)} distinct programs '
      f'({", ".join(f"{n} {s}" for s, n in sorted(by_source.items()))}); compiled in {compile_s} s '
      f'(per program, summed: clang {clang_s:.0f} s, ptxas {ptxas_s:.0f} s). {len(ok)} assembled, {len(programs) - len(ok)} failed; '
      f'{len(standin)} of them with the image stand-in (below). {len(kernels)} kernels assembled, {len(names)} distinct.', '']
for note in run_notes:
    md.append(f'Note: {note}.')
if run_notes: md.append('')
if kernels:
    md.append('Registers per kernel, by lanes (max over programs): ' + '; '.join(
        f'{n} lane{"s" if n != "1" else ""}: {max(k.get("regs", 0) for p, k in kernels if lanes(p) == n)}'
        for n in sorted({lanes(p) for p, _ in kernels if lanes(p) != '-'}, key=int)) + '.')
    spill1 = [(p, k) for p, k in spilling if lanes(p) in ('1', '-')]
    md.append(f'Kernels that spill: {len(spilling)} of {len(kernels)} ({len(spill1)} at 1 lane or without lanes).')
    md += ['', '## Per kernel, the most registers over its programs', '',
           '| kernel | programs | max registers | in | max spill stores / loads (bytes) | max stack frame (bytes) |',
           '|---|---|---|---|---|---|']
    for name in sorted(names, key=lambda n: -max(k.get('regs', 0) for _, k in kernels if k['name'] == n)):
        mine = [(p, k) for p, k in kernels if k['name'] == name]
        p, k = max(mine, key=lambda pk: pk[1].get('regs', 0))
        md.append(f'| {name} | {len(mine)} | {k.get("regs")} | {p["source"]} {p["defines"]} | '
                  f'{max(x.get("spill_st", 0) for _, x in mine)} / {max(x.get("spill_ld", 0) for _, x in mine)} | '
                  f'{max(x.get("stack", 0) for _, x in mine)} |')
    md += ['', '## Per kernel at 1 lane (GPUs\' default) and in the programs without lanes', '',
           '| kernel | programs | max registers | in | max spill stores / loads (bytes) | max stack frame (bytes) |',
           '|---|---|---|---|---|---|']
    for name in sorted(names, key=lambda n: -max([k.get('regs', 0) for p, k in kernels if k['name'] == n and lanes(p) in ('1', '-')] or [0])):
        mine = [(p, k) for p, k in kernels if k['name'] == name and lanes(p) in ('1', '-')]
        if mine:
            p, k = max(mine, key=lambda pk: pk[1].get('regs', 0))
            md.append(f'| {name} | {len(mine)} | {k.get("regs")} | {p["source"]} {p["defines"]} | '
                      f'{max(x.get("spill_st", 0) for _, x in mine)} / {max(x.get("spill_ld", 0) for _, x in mine)} | '
                      f'{max(x.get("stack", 0) for _, x in mine)} |')
md += ['', '## Per program', '',
       'Kernels: registers, spill stores/loads (bytes), stack frame (bytes); then the functions ptxas kept '
       'out of line that spill. Seconds: clang, ptxas.', '',
       '| program | source | defines | result | kernels | out-of-line functions that spill | seconds |', '|---|---|---|---|---|---|---|']
for p in sorted(programs, key=lambda p: (p['source'], p['defines'])):
    ks = '; '.join(f'{k["name"]} {k.get("regs", "?")} r, {k.get("spill_st", 0)}/{k.get("spill_ld", 0)}, {k.get("stack", 0)}'
                   for k in p['kernels'])
    fs = '; '.join(sorted({f'{f["name"]} {f.get("spill_st", 0)}/{f.get("spill_ld", 0)}' for f in p['functions'] if spills(f)}))
    md.append(f'| {p["digest"][:8]} | {p["source"]} | {p["defines"]} | {p["result"]} | {ks} | {fs} | '
              f'{p["seconds"][0]:.1f}, {p["seconds"][1]:.1f} |')
md += ['', '## Not checked', '',
       'libclc 15 has no image built-ins for NVPTX: clang lowers the program-scope `sampler_t` to a call of '
       '`__translate_sampler_initializer` and leaves `read_imagef` to the library, so both stay unresolved externs '
       '(a gap of this toolchain; NVIDIA\'s driver has both). The programs that read images (SOMBRA_USE_IMAGES) are '
       'linked with stand-ins for these functions (the sampler initializer and both read_imagef overloads): everything else in them is compiled and assembled, their '
       'texture fetch is not, and their register counts leave out the fetch.', '']
md += [f'- {p["source"]} {p["defines"]}' for p in standin] or ['- (none this run)']
warned = [p for p in programs if p['warnings']]
if warned:
    md += ['', '## clang warnings', '']
    md += [f'- {p["source"]} {p["defines"]}: ' + ' / '.join(p['warnings'][:3]) for p in warned]
if failures:
    md += ['', '## Failures', '']
    for p, lines in failures:
        md += [f'- {p["source"]} `{p["options"]}`: {p["result"]}', '', '```', *lines, '```', '']
open(os.path.join(work, 'report.md'), 'w').write('\n'.join(md) + '\n')
print('\n'.join(l for l in md[4:md.index('## Per kernel, the most registers over its programs') if kernels else 8] if l))
for p, lines in failures:
    print(f'FAIL {p["source"]} ({p["result"]}): options {p["options"]}')
    print('\n'.join('    ' + l for l in lines))
print(f'ptx_check.sh: report in {os.path.join(work, "report.md")}')
sys.exit(1 if failures or not programs else 0)
PY
exit $status
