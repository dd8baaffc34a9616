#!/usr/bin/env bash
# Intel's OpenCL CPU runtime, a second real OpenCL implementation beside PoCL (issue 33), from
# PyPI without root: the wheels below, pinned by version and sha256 (pip download --require-hashes),
# unpacked into .intel-opencl/ of the source tree (git-ignored; 276 MB downloaded in ≈ 30 s, 409 MB
# unpacked, identical copies made links). Quick (≈ 0.1 s) when already there. Then writes ICD folders
# for OCL_ICD_VENDORS: .intel-opencl/vendors/intel (Intel only) and .intel-opencl/vendors/intel+pocl.
#
#   scripts/intel-opencl.sh          install if missing; print the Intel-only ICD folder
#   scripts/intel-opencl.sh --env    install if missing; print export lines to eval:
#                                    eval "$(scripts/intel-opencl.sh --env)"
#   scripts/intel-opencl.sh --env --pocl   the same with PoCL visible too (Intel and PoCL)
#   --no-install: exit 77 instead of downloading when it is not there (the ctest's way)
#
# The environment: OCL_ICD_VENDORS (only the folder's platforms are seen), LD_LIBRARY_PATH (the
# wheels' libraries) and LD_PRELOAD of the wheel's libtbb.so.12 — Intel's runtime needs oneTBB
# 2023, but sombra links OpenVDB, which loads Debian's TBB 2021.8 under the same soname first, and
# Intel's device then silently disappears. Not written: libOpenCL.so* (the system's ICD loader
# stays), icx-lto.so (a compiler plug-in, 94 MB), the wheels' ICD files and conda scripts.
# Exit 77 when it cannot install (no network, no pip), with one line saying why (messages go to
# stderr, the folder or the export lines to stdout).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dest=$root/.intel-opencl
env=0 pocl=0 install=1
for arg in "$@"; do
  case $arg in
    --env) env=1 ;;
    --pocl) pocl=1 ;;
    --no-install) install=0 ;;
    *) echo "intel-opencl.sh: unknown argument $arg (--env, --pocl, --no-install)" >&2; exit 2 ;;
  esac
done
# intel-opencl-rt needs tbb 2023.* (which needs tcmlib 1.*), intel-cmplr-lic-rt 2026.* (its
# licence) and, not declared, intel-cmplr-lib-rt (libimf, libsvml, libirng, libintlc)
pins='intel-opencl-rt==2026.2.0 --hash=sha256:6b6215a420598b4999ee01caca6d5cbe106aa4155c46c52377619c5aafce9f67
intel-cmplr-lib-rt==2026.2.0 --hash=sha256:9f713083073a820d2496a6da8e8d4f3482aba6640f74521d25ea48dcebe72748
intel-cmplr-lic-rt==2026.2.0 --hash=sha256:402d9bc7fd418ab2df7a75b0545cf447bb52e02bedf4e3af0e7d5809b66d749d
tbb==2023.2.0 --hash=sha256:7d80615b6e970f11671fa05b6eaa9483ac864fbfe525ac280271a78b37870b7c
tcmlib==1.6.0 --hash=sha256:46c2491988bfd18c4733eeb08aca6a386706a497b92cc51d155f37ddea003c14'

if ! { [ -f "$dest/installed" ] && [ "$(cat "$dest/installed")" = "$pins" ] && [ -f "$dest/lib/libintelocl.so" ]; }; then
  [ $install = 1 ] || { echo "intel-opencl.sh: Intel's runtime is not in $dest (scripts/intel-opencl.sh installs it): skipped" >&2; exit 77; }
  python=/usr/bin/python3
  "$python" -m pip --version >/dev/null 2>&1 || python=$root/.python-deps/bin/python
  "$python" -m pip --version >/dev/null 2>&1 || { echo "intel-opencl.sh: no pip (python3-pip) to install Intel's runtime: skipped" >&2; exit 77; }
  rm -rf "$dest" "$dest.part"
  mkdir -p "$dest.part/wheels"
  echo "$pins" >"$dest.part/requirements.txt"
  echo "intel-opencl.sh: downloading Intel's OpenCL CPU runtime (276 MB) into $dest" >&2
  if ! "$python" -m pip download -q --disable-pip-version-check --no-deps --require-hashes --only-binary :all: \
      -r "$dest.part/requirements.txt" -d "$dest.part/wheels" >"$dest.part/pip.log" 2>&1; then
    echo "intel-opencl.sh: cannot download the wheels from PyPI ($(grep -m1 -iE 'error|could not' "$dest.part/pip.log" || echo 'pip failed')): skipped" >&2
    rm -rf "$dest.part"
    exit 77
  fi
  # each wheel's data files (<name>.data/data/...) into the folder; identical copies (a wheel has
  # no symbolic links: libX.so, libX.so.N, libX.so.N.M) become links to the longest name
  "$python" - "$dest.part" <<'PY'
import hashlib, os, sys, zipfile
dest = sys.argv[1]
for wheel in sorted(os.listdir(f"{dest}/wheels")):
    with zipfile.ZipFile(f"{dest}/wheels/{wheel}") as z:
        for info in z.infolist():
            parts = info.filename.split("/", 2)
            if len(parts) < 3 or not parts[0].endswith(".data") or parts[1] != "data" or info.is_dir():
                continue
            name = os.path.basename(parts[2])
            if parts[2].startswith(("bin/", "etc/")) or name.startswith("libOpenCL.so") or name == "icx-lto.so":
                continue
            target = os.path.join(dest, parts[2])
            os.makedirs(os.path.dirname(target), exist_ok=True)
            with z.open(info) as src, open(target, "wb") as out:
                out.write(src.read())
            os.chmod(target, 0o755 if ".so" in name else 0o644)
    os.remove(f"{dest}/wheels/{wheel}")
same = {}
for name in sorted(os.listdir(f"{dest}/lib")):
    with open(f"{dest}/lib/{name}", "rb") as f:
        same.setdefault(hashlib.sha256(f.read()).hexdigest(), []).append(name)
for names in same.values():
    keep = max(names, key=len)
    for name in names:
        if name != keep:
            os.remove(f"{dest}/lib/{name}")
            os.symlink(keep, f"{dest}/lib/{name}")
PY
  rm -rf "$dest.part/wheels" "$dest.part/pip.log"
  mv "$dest.part" "$dest"
  mv "$dest/requirements.txt" "$dest/installed"
  echo "intel-opencl.sh: installed ($(du -sh "$dest" | cut -f1))" >&2
fi

# the ICD folders (rewritten every time: the source tree may have moved)
mkdir -p "$dest/vendors/intel" "$dest/vendors/intel+pocl"
echo "$dest/lib/libintelocl.so" >"$dest/vendors/intel/intel.icd"
echo "$dest/lib/libintelocl.so" >"$dest/vendors/intel+pocl/intel.icd"
if [ -f /etc/OpenCL/vendors/pocl.icd ]; then cp /etc/OpenCL/vendors/pocl.icd "$dest/vendors/intel+pocl/pocl.icd"; fi
vendors=$dest/vendors/$([ $pocl = 1 ] && echo intel+pocl || echo intel)
if [ $env = 1 ]; then
  echo "export OCL_ICD_VENDORS='$vendors'"
  echo "export LD_LIBRARY_PATH='$dest/lib'\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
  echo "export LD_PRELOAD='$dest/lib/libtbb.so.12'\${LD_PRELOAD:+:\$LD_PRELOAD}"
else
  echo "$vendors"
fi
