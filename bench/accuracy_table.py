#!/usr/bin/env python3
"""Closed-form accuracy: every technique of `sombra visibility` against transmittances known
exactly (not against the brute-force reference), with the DSM build time from --stats.

Cases (the measurements of the issue "exact where the answer is known"):
  cube     point light inside a homogeneous 32³ cube (opacity 0.03 per voxel): T = exp(-σ r)
  slab     a 24 mm slab in a rotated volume of spacing (1.5, 1, 0.75), oblique directional light
  wall     a one-voxel wall, opacity linear in the value up to 0.999999 per voxel, light along its
           normal: T = exp(-2 ∫₀¹ -ln(1 - a d) dd) = 0.1353 behind it
Usage: bench/accuracy_table.py [--sombra build/sombra] [--dsm-res 512] [--eps 0.001]
"""
import argparse, csv, io, json, math, os, random, subprocess, tempfile

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser()
ap.add_argument('--sombra', default=os.path.join(root, 'build', 'sombra'))
ap.add_argument('--dsm-res', default='512')
ap.add_argument('--eps', default='0.001')
ap.add_argument('--dsm-storage', default='atlas')
a = ap.parse_args()
env = dict(os.environ, PATH='/usr/local/bin:/usr/bin:/bin:' + os.environ.get('PATH', ''))
rng = random.Random(1)

def rot(deg):  # T·Rz·Ry·Rx as the scene loader builds it (docs/scenes.md)
    x, y, z = (math.radians(d) for d in deg)
    rx = [[1, 0, 0], [0, math.cos(x), -math.sin(x)], [0, math.sin(x), math.cos(x)]]
    ry = [[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]]
    rz = [[math.cos(z), -math.sin(z), 0], [math.sin(z), math.cos(z), 0], [0, 0, 1]]
    mul = lambda p, q: [[sum(p[i][k] * q[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return mul(rz, mul(ry, rx))

def chord(p, u, lo, hi):  # length of p + t·u, t > 0, inside the box [lo, hi] (box frame)
    t0, t1 = 0.0, math.inf
    for k in range(3):
        if abs(u[k]) < 1e-15:
            if not lo[k] <= p[k] <= hi[k]: return 0.0
            continue
        ta, tb = (lo[k] - p[k]) / u[k], (hi[k] - p[k]) / u[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return max(0.0, t1 - t0)

def volume(name, n, lo, hi, opacity_points, spacing=(1, 1, 1), rotate=(0, 0, 0)):
    return {"name": name, "generator": {"type": "slab", "size": n, "axis": 0, "lo": lo, "hi": hi, "density": 1},
            "spacing": list(spacing), "transform": {"rotate_deg": list(rotate)}, "opacity_unit": 1,
            "transfer_function": {"rgb_points": [0, 1, 1, 1], "opacity_points": opacity_points}}

def scene(vol, light):
    return {"camera": {"position": [0, -100, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 30},
            "image": {"width": 64, "height": 64}, "volumes": [vol], "lights": [light]}

cases = []
# cube: every voxel 1, opacity 0.03 per voxel (1 mm)
sigma = -math.log(1 - 0.03)
L = (1.5, -0.9, 0.6)
pts = [tuple(rng.uniform(-12, 12) for _ in range(3)) for _ in range(300)]
cases.append(("point light in a homogeneous cube", scene(volume("cube", 32, 0, 1, [0, 0.03]), {"type": "point", "position": list(L)}),
              pts, [math.exp(-sigma * math.dist(p, L)) for p in pts]))
# slab: 48 voxels along x of 1.5 mm, value 1 in voxels 16..31 (24 mm), TF step at 0.5, 0.05 per mm
R = rot((20, -30, 40))
sigma = -math.log(1 - 0.05)
d = (0.3, -0.5, -0.81)
n = math.sqrt(sum(c * c for c in d))
toward = [-c / n for c in d]
half = (36.0, 24.0, 18.0)  # box half extents: 48 · (1.5, 1, 0.75) / 2
pts, exact = [], []
for _ in range(300):
    b = [rng.uniform(-0.9 * h, 0.9 * h) for h in half]
    p = [sum(R[i][j] * b[j] for j in range(3)) for i in range(3)]
    u = [sum(R[j][i] * toward[j] for j in range(3)) for i in range(3)]  # Rᵀ: into the box frame
    pts.append(tuple(p))
    exact.append(math.exp(-sigma * chord(b, u, (-12, -half[1], -half[2]), (12, half[1], half[2]))))
cases.append(("24 mm slab, rotated, spacing (1.5, 1, 0.75), directional",
              scene(volume("slab", 48, 16 / 48, 32 / 48, [0.4999, 0, 0.5, 0.05], (1.5, 1, 0.75), (20, -30, 40)),
                    {"type": "directional", "direction": list(d)}), pts, exact))
# wall: 16 voxels, value 1 in voxel 8, opacity linear 0 → 0.999999
peak = 0.999999
flank = ((1 - peak) * math.log1p(-peak) - (1 - peak) + 1) / peak
pts = [(rng.uniform(2, 7), rng.uniform(-6, 6), rng.uniform(-6, 6)) for _ in range(200)]
cases.append(("one-voxel wall, opacity 0.999999 per voxel", scene(volume("wall", 16, 0.5, 0.5625, [0, 0, 1, peak]),
              {"type": "directional", "direction": [1, 0, 0]}), pts, [math.exp(-2 * flank)] * len(pts)))

cols = ['reference', 'dsm', 'shadow_ray', 'lowpass', 'shadow_map']
print(f"DSM {a.dsm_res}², ε {a.eps}, {a.storage}; low-pass W 1; mean / max |T − exact| over the points\n")
print("| case | " + " | ".join(cols) + " | DSM build ms | DSM MiB |")
print("|---|" + "---|" * (len(cols) + 2))
with tempfile.TemporaryDirectory() as tmp:
    for name, sc, pts, exact in cases:
        sp, pp, st = os.path.join(tmp, 's.json'), os.path.join(tmp, 'p.csv'), os.path.join(tmp, 'stats.json')
        json.dump(sc, open(sp, 'w'))
        with open(pp, 'w') as f:
            for p in pts: f.write('%.6f,%.6f,%.6f\n' % p)
        out = subprocess.run([a.sombra, 'visibility', sp, '--light', '0', '--points', pp, '--dsm-res', a.dsm_res, '--eps', a.eps,
                              '--dsm-storage', a.storage, '--filter', '1', '--stats', st], capture_output=True, text=True, env=env)
        if out.returncode != 0:
            print(f"| {name} | failed: {out.stderr.strip()} |")
            continue
        rows = list(csv.DictReader(io.StringIO(out.stdout)))
        cells = []
        for c in cols:
            e = [abs(float(r[c]) - x) for r, x in zip(rows, exact)]
            cells.append(f"{sum(e) / len(e):.2g} / {max(e):.2g}")
        stats = json.load(open(st))
        ms = stats.get('stage_ms', {}).get('dsm_build', float('nan'))
        mib = stats.get('dsm', {}).get('bytes_used', 0) / 2**20
        print(f"| {name} | " + " | ".join(cells) + f" | {ms:.0f} | {mib:.0f} |")
