#!/usr/bin/env python3
"""Converged single-scattering reference for sombra's shadow techniques (issue 27, last item).

Computes, independently of sombra's code, the exact single-scattering image of
bench/scenes/cloud_reference.json at a seeded set of pixels, converged by refining the steps of
the camera ray and of the light rays together until the image changes by < 1e-4 relative, then
renders the scene with every shadow technique through the Python module and reports the relative
RMSE against it (bench/results/converged_reference.md).

    PYTHONPATH=build/python .python-deps/bin/python bench/converged_reference.py reference
    PYTHONPATH=build/python .python-deps/bin/python bench/converged_reference.py validate
    PYTHONPATH=build/python .python-deps/bin/python bench/converged_reference.py measure
    .python-deps/bin/python bench/converged_reference.py scene     # rewrites the scene (deterministic)

`reference` needs only numpy; it writes bench/results/converged_reference_pixels.npz (the pixels,
the reference RGB, the unshadowed reference RGB, the refinement sequence).

The integral (what sombra's model says the image is, written out without sombra's code):

    I(pixel) = ∫₀^∞ T_c(t) σ(t) c(t) S(p(t)) dt + T_c(∞) · background,
    T_c(t)   = exp(−∫₀^t σ),
    S(p)     = k_a i_a + Σ_m 4π p_HG(g, cos θ_m) f_m(p) i_m T_m(p),
    T_m(p)   = exp(−∫ σ along the segment from p towards light m).

Each convention, and the file it is read from:

- Pixel rays (src/geometry/scene_upload.cpp `pack_camera`, cl/render.cl `render_camera`): forward
  = normalize(look_at − position), right = normalize(forward × up), up' = right × forward, both
  scaled by tan(fov_y/2) (right also by width/height); the ray through pixel (x, y), row 0 at the
  top, is normalize(forward + s_y·up' + s_x·right) with s_x = 2(x + 0.5)/width − 1,
  s_y = 1 − 2(y + 0.5)/height.
- Voxels (docs/scenes.md, src/geometry/scene_upload.cpp `pack_scene`): a .npy is (z, y, x) in C
  order; voxel (i, j, k) sits at ((i − (nx−1)/2)·sx, (j − (ny−1)/2)·sy, (k − (nz−1)/2)·sz) (no
  transform here). The volume's box is [−0.5, n − 0.5] in voxel units (cl/traversal.h
  `make_volume_ray`).
- Density (cl/volume_sample.h `sample_density`): trilinear between voxel centres, positions
  clamped to [0, n − 1] (clamp to edge). The scene's voxels are 0 in the outer 3 layers, so the
  box and the clamping do not matter.
- Extinction (docs/scenes.md "Opacity convention", src/scene/transfer_function.cpp `table`):
  α(d) piecewise linear in the opacity points (clamped beyond both ends), clamped to [0, 1];
  σ(d) = −ln(1 − α(d)) / opacity_unit, at most −ln(10⁻⁶)/opacity_unit; opacity_unit 0 means one
  voxel (the smallest spacing; src/geometry/scene_upload.cpp). sombra tabulates σ at 1024 entries
  and interpolates linearly; here σ is evaluated exactly (they differ by ~10⁻⁸ relative here).
- Colour (src/scene/transfer_function.cpp `color`): the rgb points interpolated linearly, clamped
  beyond both ends. It is the single-scattering albedo (cl/shading.h `scatter_shade`). The scene
  uses one constant albedo.
- In-scattering (cl/shading.h `scatter_shade`, cl/shared/phase.h): S = c·[k_a i_a + Σ_m 4π
  p_HG(g, cos θ_m) f_m i_m T_m], p_HG(g, μ) = (1 − g²)/(4π (1 + g² − 2gμ)^{3/2}), cos θ_m =
  to_light_m · ray direction (the light travels along −to_light, the viewer is at −ray
  direction); k_a = the volume's material.ambient, i_a = the scene's ambient_intensity, g =
  render.phase_g; i_m = colour × intensity (src/geometry/scene_upload.cpp `pack_lights`).
- Light incidence f_m (cl/shading.h `light_incidence`): directional 1, to_light = −direction;
  point and spot 1/(c + l·d + q·d²) with d the distance to the light, and for a spot times
  smoothstep(cos_outer, cos_inner, −to_light·direction), cos_outer = cos(cone_angle), cos_inner =
  cos(cone_angle·(1 − cone_softness)) (src/geometry/scene_upload.cpp `pack_lights`; smoothstep as
  OpenCL's: 3u² − 2u³, u clamped).
- Shadow T_m (docs/shadows.md): the transmittance from p to the light's position (spot, point) or
  to infinity against the light's direction (directional), through the volume's σ — the exact
  quantity that `shadows=rays` estimates.
- Background (cl/render.cl `render_camera`): pixel = radiance + T_c(∞) · background; no early ray
  termination here (sombra stops at T_c < termination_transmittance, 10⁻³ by default).

Quadrature (converged, not sombra's): the camera ray's part of the box is cut into n equal steps
h (n = ⌈length/h⌉) and each step contributes T_c·(1 − e^(−σ h))·c·S at its midpoint, T_c *= e^(−σh);
each light segment from p to the box's exit (or to the light) is cut into ⌈length/h⌉ equal steps
and its optical depth summed at their midpoints. Both are second order in h; h goes 1, 1/2, … voxel
until the image changes by < 1e-4 relative (RMSE of the change over the reference's RMS).
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "scenes", "cloud_reference.json")
PIXELS = os.path.join(HERE, "results", "converged_reference_pixels.npz")
RESULTS = os.path.join(HERE, "results", "converged_reference.md")


# ---------------------------------------------------------------- the scene (deterministic)

def make_cloud(n=64, seed=27):
    """A cloud of 24 Gaussian puffs modulated by low-frequency noise, in [0, 1], 0 in the
    outer 3 layers. float32, (z, y, x)."""
    rng = np.random.default_rng(seed)
    g = (np.arange(n) - (n - 1) / 2) / (n / 2)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    d = np.zeros((n, n, n))
    for _ in range(24):
        c = rng.uniform(-0.5, 0.5, 3) * np.array([1.0, 0.8, 0.6])
        r = rng.uniform(0.07, 0.2)
        d += rng.uniform(0.5, 1.0) * np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / (2 * r * r))
    noise = np.zeros_like(d)
    for _ in range(6):
        k = rng.normal(0, 7.0, 3)
        noise += np.sin(k[0] * x + k[1] * y + k[2] * z + rng.uniform(0, 2 * np.pi))
    d = np.clip(d * (1 + 0.15 * noise) - 0.15, 0, None)
    d /= d.max()
    window = np.zeros(n)
    window[3:n - 3] = 1
    d *= window[:, None, None] * window[None, :, None] * window[None, None, :]
    return d.astype(np.float32)


def scene_dict(n):
    s = 1.0 / n
    return {
        "camera": {"position": [0.35, -2.5, 0.55], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 22},
        "image": {"width": 64, "height": 64},
        "background": [0.05, 0.06, 0.08],
        "ambient_intensity": 1.0,
        "volumes": [{
            "name": "cloud",
            "file": "cloud_reference.npy",
            "spacing": [s, s, s],
            "step_voxels": 0.5,
            "opacity_unit": 0,
            "transfer_function": {"rgb_points": [0, 0.9, 0.88, 0.85, 1, 0.9, 0.88, 0.85], "opacity_points": [0, 0, 1, 0.35]},
            "material": {"ambient": 0.1, "diffuse": 0.7, "specular": 0.2, "shininess": 20},
        }],
        "lights": [
            {"type": "directional", "direction": [-0.8, 0.2, -0.55], "color": [1.0, 0.92, 0.8], "intensity": 1.0},
            {"type": "spot", "position": [-1.3, -1.0, 1.0], "direction": [1.4, 1.1, -1.1], "cone_angle_deg": 16,
             "cone_softness": 0.3, "attenuation": [0.6, 0.0, 0.4], "color": [0.7, 0.8, 1.0], "intensity": 1.6},
        ],
        "render": {"shading": "scattering", "phase_g": 0.3},
    }


def write_scene():
    cloud = make_cloud()
    np.save(os.path.join(HERE, "scenes", "cloud_reference.npy"), cloud)
    with open(SCENE, "w") as f:
        json.dump(scene_dict(cloud.shape[0]), f, indent=2)
        f.write("\n")
    print("wrote", SCENE, "and cloud_reference.npy", cloud.shape, "mean", float(cloud.mean()))


# ---------------------------------------------------------------- the independent integrator

def normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class Reference:
    def __init__(self, scene_path=SCENE):
        with open(scene_path) as f:
            sc = json.load(f)
        self.sc = sc
        (v,) = sc["volumes"]
        assert "transform" not in v, "the reference knows no volume transform"
        vol = np.load(os.path.join(os.path.dirname(scene_path), v["file"])).astype(np.float64)
        self.nz, self.ny, self.nx = vol.shape
        self.flat = vol.ravel()
        self.spacing = np.array(v["spacing"], dtype=np.float64)  # x, y, z
        self.voxel = float(self.spacing.min())
        self.dims = np.array([self.nx, self.ny, self.nz], dtype=np.float64)
        self.unit = v["opacity_unit"] if v["opacity_unit"] > 0 else self.voxel
        tf = v["transfer_function"]
        op = np.array(tf["opacity_points"], dtype=np.float64).reshape(-1, 2)
        rgb = np.array(tf["rgb_points"], dtype=np.float64).reshape(-1, 4)
        self.op, self.rgb = op, rgb
        self.max_sigma = -math.log(1e-6) / self.unit
        self.ambient = v.get("material", {}).get("ambient", 0.3) * sc.get("ambient_intensity", 1.0)
        self.background = np.array(sc.get("background", [0, 0, 0]), dtype=np.float64)
        self.g = sc.get("render", {}).get("phase_g", 0.0)
        self.lights = []
        for L in sc["lights"]:
            d = dict(type=L["type"], rgb=np.array(L.get("color", [1, 1, 1])) * L.get("intensity", 1.0))
            if L["type"] == "directional":
                d["direction"] = normalize(L["direction"])
            else:
                d["position"] = np.array(L["position"], dtype=np.float64)
                d["att"] = L.get("attenuation", [1, 0, 0])
                if L["type"] == "spot":
                    d["direction"] = normalize(L["direction"])
                    half = math.radians(L.get("cone_angle_deg", 30))
                    d["cos_outer"] = math.cos(half)
                    d["cos_inner"] = math.cos(half * (1 - L.get("cone_softness", 0.1)))
            self.lights.append(d)
        cam = sc["camera"]
        self.width, self.height = sc["image"]["width"], sc["image"]["height"]
        self.eye = np.array(cam["position"], dtype=np.float64)
        fwd = normalize(np.array(cam["look_at"]) - self.eye)
        right = normalize(np.cross(fwd, cam["up"]))
        up = np.cross(right, fwd)
        tan_half = math.tan(math.radians(cam["fov_y_deg"]) / 2)
        self.fwd, self.right, self.up = fwd, right * tan_half * self.width / self.height, up * tan_half
        self.box_lo = -0.5 * self.dims * self.spacing  # world box of [−0.5, n − 0.5] voxel units
        self.box_hi = 0.5 * self.dims * self.spacing

    # -- fields
    def to_voxel(self, p):
        return p / self.spacing + (self.dims - 1) / 2

    def density(self, p):
        """Trilinear density at world points p (..., 3), clamped to the edge."""
        v = self.to_voxel(p)
        out_shape = v.shape[:-1]
        v = v.reshape(-1, 3)
        idx, frac = [], []
        for a, n in enumerate((self.nx, self.ny, self.nz)):
            q = np.clip(v[:, a], 0, n - 1)
            i0 = np.minimum(np.floor(q).astype(np.int64), n - 2)
            idx.append(i0)
            frac.append(q - i0)
        sx, sy = 1, self.nx
        sz = self.nx * self.ny
        base = idx[2] * sz + idx[1] * sy + idx[0]
        fx, fy, fz = frac
        f = self.flat
        c00 = f[base] * (1 - fx) + f[base + sx] * fx
        c10 = f[base + sy] * (1 - fx) + f[base + sy + sx] * fx
        c01 = f[base + sz] * (1 - fx) + f[base + sz + sx] * fx
        c11 = f[base + sz + sy] * (1 - fx) + f[base + sz + sy + sx] * fx
        d = (c00 * (1 - fy) + c10 * fy) * (1 - fz) + (c01 * (1 - fy) + c11 * fy) * fz
        return d.reshape(out_shape)

    def sigma_of(self, d):
        alpha = np.clip(np.interp(d, self.op[:, 0], self.op[:, 1]), 0, 1)
        with np.errstate(divide="ignore"):
            s = np.where(alpha >= 1, self.max_sigma, np.minimum(self.max_sigma, -np.log1p(-np.minimum(alpha, 0.999999999)) / self.unit))
        return s

    def color_of(self, d):
        return np.stack([np.interp(d, self.rgb[:, 0], self.rgb[:, c]) for c in (1, 2, 3)], axis=-1)

    def box_exit(self, o, d):
        """Distance along unit d from o (inside or outside) to the box's far side; −inf if missed."""
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            t0 = (self.box_lo - o) * inv
            t1 = (self.box_hi - o) * inv
        tn = np.nanmax(np.minimum(t0, t1), axis=-1)
        tf = np.nanmin(np.maximum(t0, t1), axis=-1)
        return tn, tf

    # -- light
    def incidence(self, light, p):
        """(to_light (N, 3), f (N,), segment length to integrate (N,))."""
        if light["type"] == "directional":
            u = np.broadcast_to(-light["direction"], p.shape)
            _, tf = self.box_exit(p, u)
            return u, np.ones(len(p)), np.maximum(tf, 0)
        dvec = light["position"] - p
        dist = np.linalg.norm(dvec, axis=-1)
        u = dvec / dist[:, None]
        c, l, q = light["att"]
        f = 1.0 / (c + dist * (l + dist * q))
        if light["type"] == "spot":
            cos_angle = -(u @ light["direction"])
            x = np.clip((cos_angle - light["cos_outer"]) / (light["cos_inner"] - light["cos_outer"]), 0, 1)
            f = f * x * x * (3 - 2 * x)
        _, tf = self.box_exit(p, u)
        return u, f, np.clip(tf, 0, dist)

    def optical_depth(self, p, u, length, h, chunk=3_000_000):
        """∫₀^length σ(p + s u) ds by the composite midpoint rule, ⌈length/h⌉ equal steps."""
        n = np.maximum(np.ceil(length / h).astype(np.int64), 1)
        hs = length / n
        out = np.zeros(len(p))
        order = np.argsort(n)  # blocks of points with similar step counts
        k = max(1, chunk // int(n.max()))
        for start in range(0, len(p), k):
            sel = order[start:start + k]
            M = int(n[sel].max())
            j = np.arange(M) + 0.5
            s = j[None, :] * hs[sel, None]  # (k, M)
            pts = p[sel, None, :] + s[..., None] * u[sel, None, :]
            sig = self.sigma_of(self.density(pts))
            sig[j[None, :] > n[sel, None]] = 0
            out[sel] = (sig * hs[sel, None]).sum(axis=1)
        return out

    # -- camera
    def ray_dirs(self, px, py):
        sx = (px + 0.5) / self.width * 2 - 1
        sy = 1 - (py + 0.5) / self.height * 2
        return normalize(self.fwd[None] + sy[:, None] * self.up[None] + sx[:, None] * self.right[None])

    def render(self, px, py, h_voxels, shadows=True):
        """(RGB (N, 3) with shadows, RGB (N, 3) without, camera optical depth (N,))."""
        h = h_voxels * self.voxel
        dirs = self.ray_dirs(px, py)
        N = len(px)
        o = np.broadcast_to(self.eye, (N, 3))
        t0, t1 = self.box_exit(o, dirs)
        t0 = np.maximum(t0, 0)
        length = np.maximum(t1 - t0, 0)
        n = np.maximum(np.ceil(length / h).astype(np.int64), 1)
        hs = length / n
        K = int(n.max())
        j = np.arange(K) + 0.5
        t = t0[:, None] + j[None, :] * hs[:, None]
        valid = j[None, :] < n[:, None]
        pts = self.eye[None, None, :] + t[..., None] * dirs[:, None, :]
        dens = self.density(pts)
        sig = np.where(valid, self.sigma_of(dens), 0.0)
        tau = sig * hs[:, None]
        trans_before = np.exp(-(np.cumsum(tau, axis=1) - tau))
        weight = trans_before * (1 - np.exp(-tau))  # (N, K)
        color = self.color_of(dens)  # (N, K, 3)
        active = sig > 0
        P = pts[active]
        D = np.broadcast_to(dirs[:, None, :], pts.shape)[active]
        lit = np.full((len(P), 3), self.ambient)
        unshadowed = np.full((len(P), 3), self.ambient)
        for light in self.lights:
            u, f, seg = self.incidence(light, P)
            mu = np.einsum("ij,ij->i", u, D)
            g = self.g
            phase4pi = (1 - g * g) / (1 + g * g - 2 * g * mu) ** 1.5  # 4π p_HG
            term = (f * phase4pi)[:, None] * light["rgb"][None, :]
            unshadowed += term
            if shadows:
                need = f > 0
                T = np.ones(len(P))
                T[need] = np.exp(-self.optical_depth(P[need], u[need], seg[need], h))
                lit += term * T[:, None]
        S = np.zeros(pts.shape)
        S0 = np.zeros(pts.shape)
        S[active] = lit
        S0[active] = unshadowed
        total_t = np.exp(-tau.sum(axis=1))
        bg = total_t[:, None] * self.background[None]
        rgb = (weight[..., None] * color * S).sum(axis=1) + bg
        rgb0 = (weight[..., None] * color * S0).sum(axis=1) + bg
        return rgb, rgb0, tau.sum(axis=1)


def rel_rmse(x, ref):
    return float(np.sqrt(np.mean((x - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)))


def choose_pixels(ref, count, seed=27):
    """`count` pixels drawn (seeded) from those whose camera ray sees optical depth > 0.05."""
    W, H = ref.width, ref.height
    yy, xx = np.mgrid[0:H, 0:W]
    px, py = xx.ravel().astype(np.float64), yy.ravel().astype(np.float64)
    _, _, tau = ref.render(px, py, 1.0, shadows=False)
    cloud = np.flatnonzero(tau > 0.05)
    rng = np.random.default_rng(seed)
    pick = np.sort(rng.choice(cloud, size=min(count, len(cloud)), replace=False))
    return xx.ravel()[pick], yy.ravel()[pick], len(cloud)


def cmd_reference(args):
    ref = Reference()
    px, py, cloud_pixels = choose_pixels(ref, args.pixels)
    print(f"{len(px)} pixels of {cloud_pixels} that see the cloud ({ref.width}x{ref.height})")
    steps, images, changes, times = [], [], [], []
    h = args.start
    prev = None
    while True:
        t = time.time()
        rgb, rgb0, _ = ref.render(px.astype(np.float64), py.astype(np.float64), h)
        dt = time.time() - t
        change = rel_rmse(rgb, prev) if prev is not None else float("nan")
        steps.append(h), images.append(rgb), changes.append(change), times.append(dt)
        print(f"h = {h:.5f} voxel: mean {rgb.mean():.6f}, change {change:.2e} relative, {dt:.1f} s", flush=True)
        if prev is not None and change < args.tolerance:
            break
        prev = rgb
        h /= 2
    # Richardson: the last two at second order give an estimate of the last one's own error
    rich = (4 * images[-1] - images[-2]) / 3
    last_err = rel_rmse(images[-1], rich)
    print(f"the last step's error estimated by Richardson extrapolation: {last_err:.2e}")
    # shadow ratio per pixel: how much of the in-scattered light the shadows take
    ratio = images[-1].mean(axis=1) / rgb0.mean(axis=1)
    np.savez(PIXELS, px=px, py=py, rgb=images[-1], rgb_richardson=rich, rgb_unshadowed=rgb0, steps=np.array(steps),
             changes=np.array(changes), times=np.array(times), images=np.array(images), cloud_pixels=cloud_pixels)
    print("wrote", PIXELS)
    print("shadowed / unshadowed luminance: min %.3f, quartiles %s, max %.3f" % (
        ratio.min(), np.round(np.percentile(ratio, [25, 50, 75]), 3), ratio.max()))


# ---------------------------------------------------------------- sombra

def scene_with_step(step_voxels, out_dir):
    with open(SCENE) as f:
        sc = json.load(f)
    for v in sc["volumes"]:
        v["step_voxels"] = step_voxels
        v["file"] = os.path.join(os.path.dirname(SCENE), v["file"])
    path = os.path.join(out_dir, f"cloud_step{step_voxels}.json")
    with open(path, "w") as f:
        json.dump(sc, f)
    return path


def sombra_pixels(image, px, py):
    return image[py, px, :3].astype(np.float64)


def render_technique(sombra, context, step, options, tmp):
    scene = sombra.load_scene(scene_with_step(step, tmp))
    t = time.time()
    image, stats = sombra.render(context, scene, **options)
    wall = time.time() - t
    return image, stats, wall


def cmd_validate(args):
    import sombra
    import tempfile
    data = np.load(PIXELS)
    px, py, ref = data["px"], data["py"], data["rgb"]
    ctx = sombra.Context(args.device)
    with tempfile.TemporaryDirectory() as tmp:
        for step, ray_step in [(float(s.split(":")[0]), float(s.split(":")[1])) for s in args.steps]:
            for shadows in (["none", "rays"] if not args.rays_only else ["rays"]):
                opts = dict(shadows=shadows, termination_transmittance=0.0, shadow_cache="off")
                if shadows == "rays":
                    opts["shadow_ray_step"] = ray_step
                image, stats, wall = render_technique(sombra, ctx, step, opts, tmp)
                x = sombra_pixels(image, px, py)
                r = data["rgb_unshadowed"] if shadows == "none" else ref
                err = rel_rmse(x, r)
                bias = float(np.mean(x - r) / np.mean(r))
                print(f"{shadows:5s} step {step} ray_step {ray_step}: rel RMSE {err:.2e}, mean signed {bias:+.2e}, "
                      f"max |rel| {np.max(np.abs(x - r) / np.abs(r)):.2e}, {wall:.1f} s", flush=True)


def parse_value(text):
    """An option's value from KEY=VALUE: int, float or string."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


TECHNIQUES = [
    ("none", {}),
    ("rays", {}),
    ("dsm", {}),
    ("shadowmap", {}),
    ("lowpass W1", {"shadows": "lowpass", "lowpass_filter_width": 1.0}),
    ("lowpass W3", {"shadows": "lowpass"}),
    ("ao", {}),
    ("cone", {}),
]


def cmd_measure(args):
    import sombra
    import tempfile
    data = np.load(PIXELS)
    px, py, ref, ref0 = data["px"], data["py"], data["rgb"], data["rgb_unshadowed"]
    ctx = sombra.Context(args.device)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # warm-up: kernels built once per technique's program, not timed in the rows
        for name, opts in TECHNIQUES:
            if args.only and name not in args.only:
                continue
            o = dict(opts)
            o.setdefault("shadows", name)
            o.update({k: parse_value(v) for k, v in (kv.split("=", 1) for kv in args.option or [])})
            for step in args.steps:
                render_technique(sombra, ctx, step, o, tmp)  # warm-up (program build, tables)
                walls, image, stats = [], None, None
                for _ in range(args.runs):
                    image, stats, wall = render_technique(sombra, ctx, step, o, tmp)
                    walls.append(wall)
                x = sombra_pixels(image, px, py)
                row = dict(technique=name, step=step, rmse=rel_rmse(x, ref), bias=float(np.mean(x - ref) / np.mean(ref)),
                           rmse_unshadowed=rel_rmse(x, ref0), wall=float(np.median(walls)),
                           camera_ms=float(stats["stage_ms"].get("camera_pass", float("nan"))),
                           stages=", ".join(f"{k} {v:.0f}" for k, v in stats["stage_ms"].items() if v >= 1),
                           cache=str(stats.get("shadow_cache", {}).get("used", "")))
                rows.append(row)
                print(f"{name:11s} step {step:<5} rel RMSE {row['rmse']:.5f}  mean signed {row['bias']:+.5f}  "
                      f"vs unshadowed {row['rmse_unshadowed']:.4f}  {row['wall']:.2f} s  cache {row['cache']}  "
                      f"[{row['stages']}]", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("scene")
    r = sub.add_parser("reference")
    r.add_argument("--pixels", type=int, default=240)
    r.add_argument("--start", type=float, default=1.0, help="first step, voxels")
    r.add_argument("--tolerance", type=float, default=1e-4)
    v = sub.add_parser("validate")
    v.add_argument("--device", default="auto")
    v.add_argument("--steps", nargs="+", default=["0.5:1", "0.1:0.1"], help="camera_step:shadow_ray_step, voxels")
    v.add_argument("--rays-only", action="store_true")
    m = sub.add_parser("measure")
    m.add_argument("--device", default="auto")
    m.add_argument("--steps", nargs="+", type=float, default=[0.5, 0.25], help="camera steps, voxels")
    m.add_argument("--runs", type=int, default=3, help="timed renders per row (median)")
    m.add_argument("--only", nargs="*", help="technique rows to run (names as printed)")
    m.add_argument("--option", nargs="*", help="extra render options KEY=VALUE (numbers or strings)")
    m.add_argument("--json", help="write the rows here")
    args = ap.parse_args()
    {"scene": lambda a: write_scene(), "reference": cmd_reference, "validate": cmd_validate,
     "measure": cmd_measure}[args.cmd](args)


if __name__ == "__main__":
    main()
