#!/usr/bin/env python3
"""Writes a coffee cup as a closed, consistently wound (outwards) Wavefront OBJ: a lathed wall with
thickness and a rounded rim, a bottom, and a handle (a torus segment with capped ends sunk into
the wall). The cup stands on z = 0 around the z axis, 9 units tall, its handle towards +x.

Usage: scripts/make_cup_mesh.py [OUT.obj]   (default data/meshes/cup.obj)
Standard library only. The mesh has two closed components (cup, handle); every directed edge
occurs once and its reverse once, and each component's signed volume is positive (checked before
writing). Generated, public domain (CC0)."""
import math
import sys

SEGMENTS = 48          # around the cup
HEIGHT, R_BOTTOM, R_TOP = 9.0, 3.1, 4.0
WALL, BOTTOM = 0.35, 0.5  # wall and bottom thickness
FOOT = 0.25            # rounding of the outer bottom edge
HANDLE_MAJOR, HANDLE_MINOR = 2.3, 0.42
HANDLE_ALONG, HANDLE_AROUND = 24, 12


def wall_radius(z):
    """Outer radius of the (slightly conical) wall at height z."""
    return R_BOTTOM + (R_TOP - R_BOTTOM) * z / HEIGHT


def profile():
    """The cup's cross-section (r, z) from the bottom's centre outside, over the rim, down the inside
    to the inner bottom's centre; both ends lie on the axis."""
    pts = [(0.0, 0.0)]
    for k in range(4):  # the bottom's ring, then the rounded foot
        a = 0.5 * math.pi * k / 3
        pts.append((wall_radius(0.0) - FOOT + FOOT * math.sin(a), FOOT - FOOT * math.cos(a)))
    steps = 4
    for k in range(1, steps + 1):  # the outer wall up to the rim
        z = FOOT + (HEIGHT - FOOT) * k / steps
        pts.append((wall_radius(z), z))
    for k in range(1, 6):  # the rim: a half circle over the wall
        a = math.pi * k / 6
        c = wall_radius(HEIGHT) - 0.5 * WALL
        pts.append((c + 0.5 * WALL * math.cos(a), HEIGHT + 0.5 * WALL * math.sin(a)))
    for k in range(steps + 1):  # the inner wall down to the inner bottom
        z = HEIGHT - (HEIGHT - BOTTOM) * k / steps
        pts.append((wall_radius(z) - WALL, z))
    for k in (0.66, 0.33):
        pts.append((k * (wall_radius(BOTTOM) - WALL), BOTTOM))
    pts.append((0.0, BOTTOM))
    return pts


class Mesh:
    def __init__(self):
        self.v, self.f = [], []

    def add(self, p):
        self.v.append(p)
        return len(self.v) - 1

    def tri(self, a, b, c):
        self.f.append((a, b, c))

    def quad(self, a, b, c, d):  # a b c d counter-clockwise seen from outside
        self.tri(a, b, c)
        self.tri(a, c, d)


def lathe(mesh, pts):
    """Surface of revolution of the profile; the axis points become poles with triangle fans."""
    first = len(mesh.f)
    rings = []
    for r, z in pts[1:-1]:
        rings.append([mesh.add((r * math.cos(2 * math.pi * j / SEGMENTS), r * math.sin(2 * math.pi * j / SEGMENTS), z))
                      for j in range(SEGMENTS)])
    bottom, top = mesh.add((0.0, 0.0, pts[0][1])), mesh.add((0.0, 0.0, pts[-1][1]))
    for j in range(SEGMENTS):
        k = (j + 1) % SEGMENTS
        mesh.tri(bottom, rings[0][k], rings[0][j])
        for i in range(len(rings) - 1):
            mesh.quad(rings[i][j], rings[i][k], rings[i + 1][k], rings[i + 1][j])
        mesh.tri(top, rings[-1][j], rings[-1][k])
    return first


def handle(mesh):
    """A torus segment in the xz plane beside the wall; its ends end inside the wall, capped."""
    first = len(mesh.f)
    cz = 0.52 * HEIGHT
    cx = wall_radius(cz) + 0.55 * HANDLE_MAJOR
    # the sweep ends where the tube's centre line is half a wall thickness inside the outer wall
    ends = []
    for sign in (-1, 1):
        lo, hi = 0.0, math.pi
        for _ in range(60):  # bisection on the angle from +x
            mid = 0.5 * (lo + hi)
            x, z = cx + HANDLE_MAJOR * math.cos(mid), cz + sign * HANDLE_MAJOR * math.sin(mid)
            if x > wall_radius(z) - 0.5 * WALL:
                lo = mid
            else:
                hi = mid
        ends.append(lo)
    phis = [-ends[0] + (ends[0] + ends[1]) * i / HANDLE_ALONG for i in range(HANDLE_ALONG + 1)]
    rings = []
    for phi in phis:
        radial = (math.cos(phi), 0.0, math.sin(phi))
        centre = (cx + HANDLE_MAJOR * radial[0], 0.0, cz + HANDLE_MAJOR * radial[2])
        ring = []
        for j in range(HANDLE_AROUND):
            psi = 2 * math.pi * j / HANDLE_AROUND
            c, s = HANDLE_MINOR * math.cos(psi), HANDLE_MINOR * math.sin(psi)
            ring.append(mesh.add((centre[0] + c * radial[0], s, centre[2] + c * radial[2])))
        rings.append((centre, ring))
    for i in range(HANDLE_ALONG):
        a, b = rings[i][1], rings[i + 1][1]
        for j in range(HANDLE_AROUND):
            k = (j + 1) % HANDLE_AROUND
            mesh.quad(a[j], a[k], b[k], b[j])
    (c0, r0), (c1, r1) = rings[0], rings[-1]
    m0, m1 = mesh.add(c0), mesh.add(c1)
    for j in range(HANDLE_AROUND):
        k = (j + 1) % HANDLE_AROUND
        mesh.tri(m0, r0[k], r0[j])
        mesh.tri(m1, r1[j], r1[k])
    return first


def signed_volume(mesh, faces):
    vol = 0.0
    for a, b, c in faces:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = mesh.v[a], mesh.v[b], mesh.v[c]
        vol += (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6.0
    return vol


def check_closed(mesh, faces, name):
    directed = {}
    for a, b, c in faces:
        for e in ((a, b), (b, c), (c, a)):
            directed[e] = directed.get(e, 0) + 1
    for (a, b), n in directed.items():
        if n != 1 or directed.get((b, a)) != 1:
            sys.exit(f"make_cup_mesh.py: {name}: edge {a}-{b} is not shared by exactly two opposite triangles")
    if signed_volume(mesh, faces) <= 0:
        sys.exit(f"make_cup_mesh.py: {name}: wound inwards")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "data/meshes/cup.obj"
    mesh = Mesh()
    cup_first = lathe(mesh, profile())
    handle_first = handle(mesh)
    check_closed(mesh, mesh.f[cup_first:handle_first], "cup")
    check_closed(mesh, mesh.f[handle_first:], "handle")
    with open(out, "w", encoding="ascii", newline="\n") as f:
        f.write("# Coffee cup generated by scripts/make_cup_mesh.py (public domain, CC0): lathed wall with a rim, "
                "bottom, torus-segment handle\n")
        f.write(f"# {len(mesh.v)} vertices, {len(mesh.f)} triangles; stands on z = 0, {HEIGHT} tall, handle towards +x\n")
        for p in mesh.v:
            f.write("v {:.6g} {:.6g} {:.6g}\n".format(*p))
        for t in mesh.f:
            f.write("f {} {} {}\n".format(*(k + 1 for k in t)))
    print(f"{out}: {len(mesh.v)} vertices, {len(mesh.f)} triangles")


if __name__ == "__main__":
    main()
