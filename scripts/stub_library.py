#!/usr/bin/env python3
"""Writes a stand-in for a shared library that a bundled program loads but never calls (issue 33's
GPU bundle: OpenImageIO links video, camera-raw, DICOM and OpenCV libraries that sombra never
reaches, 250 MB with what they load in turn, over what a lent machine takes).

    stub_library.py LIBRARY OUT_DIR

The stand-in has the library's file name and soname, defines every dynamic symbol it exports
(functions that return an empty C string: OpenImageIO asks its format libraries for their version
strings when it lists its plugins; data as zeroed storage of the symbol's size; the same version
nodes) and loads nothing. A program that calls into it is wrong: scripts/gpu-bundle.sh checks the
bundle by running the CLI and the tests that write and read images with it before it ships.
"""
import os
import re
import subprocess
import sys
import tempfile


def exported_symbols(path):
    """[(name, version or None, default version?, type, size)] of the defined dynamic symbols."""
    out = subprocess.run(["readelf", "--dyn-syms", "-W", path], capture_output=True, text=True, check=True).stdout
    symbols = []
    for line in out.splitlines():
        fields = line.split()
        if len(fields) < 8 or not fields[0][:-1].isdigit() or fields[6] in ("UND", "ABS") or fields[4] == "LOCAL":
            continue
        kind, size, raw = fields[3], int(fields[2], 16) if fields[2].startswith("0x") else int(fields[2]), fields[7]
        if kind not in ("FUNC", "IFUNC", "OBJECT", "TLS", "NOTYPE"):
            continue
        match = re.match(r"([^@]+)(@@?)(.+)?$", raw)
        name, version, default = (match.group(1), match.group(3), match.group(2) == "@@") if match else (raw, None, True)
        symbols.append((name, version, default, kind, size))
    return symbols


def main():
    library, out_dir = sys.argv[1], sys.argv[2]
    soname = re.search(r"SONAME.*\[(.*)\]", subprocess.run(["readelf", "-d", library], capture_output=True,
                                                           text=True).stdout)
    soname = soname.group(1) if soname else os.path.basename(library)
    symbols = exported_symbols(library)
    source, versions = [], {}
    for i, (name, version, default, kind, size) in enumerate(symbols):
        local = f"stub_{i}"
        if kind in ("FUNC", "IFUNC", "NOTYPE") and size == 0 or kind in ("FUNC", "IFUNC"):
            source.append(f'const char* {local}(void) {{ return ""; }}')
        elif kind == "TLS":
            source.append(f"__thread char {local}[{max(size, 1)}] __attribute__((aligned(16)));")
        else:
            source.append(f"char {local}[{max(size, 1)}] __attribute__((aligned(16)));")
        if version is None:
            source.append(f'__asm__(".globl {name}\\n.set {name}, {local}");')
            versions.setdefault(None, []).append(name)
        else:
            source.append(f'__asm__(".symver {local}, {name}{"@@" if default else "@"}{version}");')
            versions.setdefault(version, [])
    script = []
    for version in [v for v in versions if v is not None]:
        script.append(f"{version} {{ }};")
    with tempfile.TemporaryDirectory() as tmp:
        c_path, map_path = os.path.join(tmp, "stub.c"), os.path.join(tmp, "stub.map")
        with open(c_path, "w") as f:
            f.write("\n".join(source) + "\n")
        with open(map_path, "w") as f:
            f.write("\n".join(script) + "\n")
        args = ["gcc", "-shared", "-fPIC", "-O0", "-w", "-nostdlib", f"-Wl,-soname,{soname}", "-o",
                os.path.join(out_dir, os.path.basename(library)), c_path]
        if script:
            args.append(f"-Wl,--version-script={map_path}")
        subprocess.run(args, check=True)


if __name__ == "__main__":
    main()
