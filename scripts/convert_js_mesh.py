#!/usr/bin/env python3
"""Converts a CommonJS mesh (npm `teapot`, `bunny`: exports.positions=[[x,y,z],…],
exports.cells=[[i,j,k],…], 0-based) into a Wavefront OBJ file (1-based faces).

Usage: scripts/convert_js_mesh.py IN.js OUT.obj "comment line (provenance)"
Run once per mesh; the OBJ files in data/meshes/ are the result (see data/README.md)."""
import json
import re
import sys


def read_array(text, name, path):
    match = re.search(r"exports\." + name + r"\s*=\s*(\[.*?\]\])", text, re.S)
    if not match:
        sys.exit(f"{path}: exports.{name}: not found")
    return json.loads(match.group(1))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    src, dst, comment = sys.argv[1:]
    text = open(src, encoding="utf-8").read()
    positions = read_array(text, "positions", src)
    cells = read_array(text, "cells", src)
    for i, p in enumerate(positions):
        if len(p) != 3:
            sys.exit(f"{src}: positions[{i}]: must have 3 coordinates")
    for i, c in enumerate(cells):
        if len(c) != 3 or not all(0 <= k < len(positions) for k in c):
            sys.exit(f"{src}: cells[{i}]: must be 3 indices below {len(positions)}")
    with open(dst, "w", encoding="ascii", newline="\n") as out:
        out.write(f"# {comment}\n# {len(positions)} vertices, {len(cells)} triangles\n")
        for p in positions:
            out.write("v {} {} {}\n".format(*(repr(float(x)) for x in p)))
        for c in cells:
            out.write("f {} {} {}\n".format(*(k + 1 for k in c)))
    print(f"{dst}: {len(positions)} vertices, {len(cells)} triangles")


if __name__ == "__main__":
    main()
