#!/usr/bin/env python3
"""Mesh cost against the triangle count (issue 25 item 5): the camera's raster and fragment stages
(`--stats` stage_ms camera_raster, camera_fragments) and the whole command, for OBJ files of N
coincident copies of one triangle (every fragment on the same pixels: the worst case of the
per-pixel sort) and of N small random triangles (a usual mesh), medians of 3 runs after a warm-up.

Usage: bench/mesh_scaling.py [--sombra build/sombra] [--size 64] [--counts 10000,100000,1000000]
"""
import argparse, json, os, random, statistics, subprocess, tempfile, time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument('--sombra', default=os.path.join(root, 'build', 'sombra'))
ap.add_argument('--size', type=int, default=64, help='image side in pixels')
ap.add_argument('--counts', default='10000,100000,1000000')
ap.add_argument('--coincident-counts', default='1000,2000,4000,8000,16000')
ap.add_argument('--runs', type=int, default=3)
a = ap.parse_args()
env = dict(os.environ, PATH='/usr/local/bin:/usr/bin:/bin:' + os.environ.get('PATH', ''))


def write_obj(path, n, coincident):
    rng = random.Random(7)
    with open(path, 'w') as f:
        if coincident:
            f.write('v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0 0.5 0\n')
            f.write('f 1 2 3\n' * n)
            return
        for _ in range(n):  # small triangles scattered over [-0.5, 0.5]³
            cx, cy, cz = (rng.uniform(-0.5, 0.5) for _ in range(3))
            for _ in range(3):
                f.write('v %.5f %.5f %.5f\n' % (cx + rng.uniform(-0.01, 0.01), cy + rng.uniform(-0.01, 0.01), cz))
        for i in range(n):
            f.write('f %d %d %d\n' % (3 * i + 1, 3 * i + 2, 3 * i + 3))


def measure(tmp, n, coincident):
    obj = os.path.join(tmp, 'm.obj')
    write_obj(obj, n, coincident)
    scene = {"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "image": {"width": a.size, "height": a.size},
             "meshes": [{"file": "m.obj", "material": {"color": [1, 1, 1], "opacity": 0.01}}],
             "lights": [{"type": "directional", "direction": [0, 0, -1]}]}
    path = os.path.join(tmp, 's.json')
    json.dump(scene, open(path, 'w'))
    rows = []
    for run in range(a.runs + 1):  # the first is the warm-up (kernel build)
        start = time.perf_counter()
        subprocess.run([a.sombra, 'render', path, '-o', os.path.join(tmp, 'o.png'), '--stats', os.path.join(tmp, 'st.json'), '-q'],
                       check=True, env=env)
        wall = time.perf_counter() - start
        st = json.load(open(os.path.join(tmp, 'st.json')))['stage_ms']
        if run:
            rows.append((st.get('camera_raster', 0), st.get('camera_fragments', 0), wall * 1000))
    return [statistics.median(c) for c in zip(*rows)]


print(f"| triangles | layout | camera_raster ms | camera_fragments ms | command ms | fragments ms per 1,000 triangles |")
print("|---|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as tmp:
    for coincident, counts in ((True, a.coincident_counts), (False, a.counts)):
        for n in map(int, counts.split(',')):
            raster, fragments, wall = measure(tmp, n, coincident)
            print(f"| {n:,} | {'coincident' if coincident else 'random small'} | {raster:.0f} | {fragments:.0f} | {wall:.0f} | "
                  f"{1000 * fragments / n:.2f} |", flush=True)
