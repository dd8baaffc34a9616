# sombra's Python module against the library: a numpy scene renders exactly like the same scene read
# from files, transmittance against the brute-force reference, deep shadow maps, argument errors,
# and the example of docs/python.md.
import json
import re

import numpy as np
import pytest

import sombra
from conftest import SOURCE_DIR


def lopsided_volume(seed=3):
    """A smooth random volume with three different sizes, so a swapped axis cannot go unnoticed."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(np.linspace(-1, 1, 20), np.linspace(-1, 1, 16), np.linspace(-1, 1, 12), indexing="ij")
    v = np.zeros_like(x)
    for cx, cy, cz in rng.uniform(-0.6, 0.6, size=(4, 3)):
        v += np.exp(-8 * ((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2))
    v[:, :, :3] += 0.3  # one thick wall on the low-x side
    return v.astype(np.float32)


SPACING = (0.05, 0.06, 0.04)
TRANSFORM = [[0.8, -0.6, 0, 0.1], [0.6, 0.8, 0, -0.05], [0, 0, 1, 0.02], [0, 0, 0, 1]]
OPACITY = [(0.0, 0.0), (0.4, 0.1), (1.2, 0.6)]
COLOR = [(0.0, 0.9, 0.5, 0.2), (1.2, 0.3, 0.6, 1.0)]
LIGHT = dict(position=(0.4, 1.3, 0.5), direction=(-0.4, -1.3, -0.5), cone_angle_deg=35)
CAMERA = dict(position=(0.3, -0.4, 2.5), look_at=(0, 0, 0), up=(0, 1, 0), fov_y_deg=35)


def numpy_scene(voxels):
    scene = sombra.Scene(width=40, height=40)
    scene.add_volume(voxels, spacing=SPACING, transform=np.array(TRANSFORM), opacity=OPACITY, color=COLOR)
    scene.add_light("spot", **LIGHT)
    scene.set_camera(**CAMERA)
    scene.background = (0.1, 0.1, 0.2)
    return scene


def file_scene(voxels, folder):
    np.save(folder / "v.npy", voxels)  # sombra's .npy reader: C order, shape (z, y, x)
    description = {
        "camera": CAMERA,
        "image": {"width": 40, "height": 40},
        "background": [0.1, 0.1, 0.2],
        "volumes": [{"file": "v.npy", "spacing": list(SPACING), "transform": {"matrix": sum(TRANSFORM, [])},
                     "transfer_function": {"opacity_points": sum(map(list, OPACITY), []),
                                           "rgb_points": sum(map(list, COLOR), [])}}],
        "lights": [dict(type="spot", **LIGHT)],
    }
    (folder / "scene.json").write_text(json.dumps(description))
    return sombra.load_scene(str(folder / "scene.json"))


def test_numpy_scene_renders_like_the_same_scene_from_files(context, tmp_path):
    voxels = lopsided_volume()
    from_numpy, from_files = numpy_scene(voxels), file_scene(voxels, tmp_path)
    for shadows, options in (("dsm", dict(dsm_resolution=48)), ("rays", {})):
        a, stats = sombra.render(context, from_numpy, shadows=shadows, **options)
        b, _ = sombra.render(context, from_files, shadows=shadows, **options)
        assert a.shape == (40, 40, 4) and a.dtype == np.float32
        assert np.isfinite(a).all()
        assert a[..., 3].max() > 0.3  # the volume is in view
        assert np.array_equal(a, b), f"{shadows}: max |Δ| {np.abs(a - b).max()}"
        assert stats["width"] == 40 and stats["samples"] > 0
    # a swapped axis would render differently: the transposed volume does
    swapped, _ = sombra.render(context, numpy_scene(np.ascontiguousarray(voxels.transpose(2, 1, 0))), shadows="dsm")
    assert np.abs(swapped - a).max() > 0.05


def test_transmittance_against_the_reference(context):
    scene = numpy_scene(lopsided_volume())
    points = np.random.default_rng(5).uniform(-0.35, 0.35, size=(300, 3))
    reference = sombra.reference_transmittance(scene, 0, points)
    assert reference.shape == (300,) and reference.dtype == np.float64
    assert reference.min() < 0.7  # the points do lie in shadow
    rays, _ = sombra.shadow_transmittance(context, scene, 0, points, shadows="rays")
    dsm, stats = sombra.shadow_transmittance(context, scene, 0, points.astype(np.float32), shadows="dsm",
                                             dsm_resolution=128, dsm_epsilon=0.01)
    # measured: rays mean 0.00034 / max 0.0027, dsm mean 0.0039 / max 0.017
    assert np.abs(rays - reference).mean() < 0.002
    assert np.abs(dsm - reference).mean() < 0.01
    assert np.abs(dsm - reference).max() < 0.05
    assert stats["dsm"]["views"] == 1
    lit = sombra.shadow_transmittance(context, scene, 0, [(0, 5, 5)], shadows="rays")[0]  # a plain list works too
    assert lit[0] == pytest.approx(1.0)
    # no technique named: deep shadow maps (issue 26: the default used to be 'none', an error)
    default, stats = sombra.shadow_transmittance(context, scene, 0, points[:20])
    assert stats["dsm"]["views"] == 1 and np.abs(default - reference[:20]).mean() < 0.01


def test_deep_shadow_maps(context, tmp_path):
    scene = numpy_scene(lopsided_volume())
    scene.add_light("point", position=(0.2, 1.0, 0.3))
    maps, stats = sombra.build_deep_shadow_maps(context, scene, 1, dsm_resolution=24)
    assert [m.light_name for m in maps] == [f"lights[1].{f}" for f in ("+x", "-x", "+y", "-y", "+z", "-z")]
    # the stats count every light's views (1 spot view + 6 cube faces); only light 1's were generated
    assert stats["dsm"]["views"] == 7 and stats["dsm"]["views_generated"] == 6
    assert 0 < sum(len(m.depth) for m in maps) == stats["dsm"]["nodes"]
    view = max(maps, key=lambda m: len(m.depth))
    assert view.first.shape == (24 * 24 + 1,) and view.first[-1] == len(view.depth) == len(view.opacity)
    assert ((view.opacity >= 0) & (view.opacity <= 1 + 0.02 + 1e-6)).all()  # compression may overshoot by ε
    # the light is the origin of camera space
    light = np.array([0.2, 1.0, 0.3, 1.0])
    assert np.allclose(view.world_to_camera @ light, [0, 0, 0, 1], atol=1e-5)
    view.write_exr(str(tmp_path / "face.exr"))
    back = sombra.read_deep_exr(str(tmp_path / "face.exr"))
    assert np.array_equal(back.first, view.first) and np.array_equal(back.depth, view.depth)
    assert np.abs(back.opacity - np.clip(view.opacity, 0, 1)).max() < 1e-6  # the file clamps to [0, 1]
    assert np.array_equal(back.world_to_ndc, view.world_to_ndc)


def test_volume_info_is_sombra_info_json():
    info = sombra.volume_info(str(SOURCE_DIR / "data/volumes/stent.npz"))
    assert info["dims"] == [128, 128, 256] and info["voxel_type"] == "int16" and info["preset"] == "ct"
    assert (info["min"], info["max"]) == (0.0, 2000.0)
    assert info["world_bounds"] == {"min": [-64.0, -64.0, -128.0], "max": [64.0, 64.0, 128.0]}
    assert sum(info["histogram"]["counts"]) == info["voxels"] == 128 * 128 * 256
    with pytest.raises(Exception, match="no_such.nii"):
        sombra.volume_info("no_such.nii")


def test_scene_bounds_and_value_ranges_match_sombra_info():
    scene = sombra.load_scene(str(SOURCE_DIR / "data/scenes/default.json"))
    info = sombra.volume_info(str(SOURCE_DIR / "data/volumes/stent.npz"))
    lo, hi = scene.bounds()
    assert [lo, hi] == [tuple(info["world_bounds"]["min"]), tuple(info["world_bounds"]["max"])]
    assert scene.volume_bounds(0) == (lo, hi)
    assert scene.value_range(0) == (info["min"], info["max"])
    with pytest.raises(IndexError, match="volume_bounds"):
        scene.volume_bounds(1)
    with pytest.raises(ValueError, match="no volume or mesh"):
        sombra.Scene(8, 8).bounds()


def test_load_mesh_gives_what_add_mesh_takes(context, tmp_path):
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    vertices, triangles = sombra.load_mesh(str(obj))
    assert vertices.dtype == np.float32 and vertices.shape == (4, 3) and vertices.strides == (12, 4)
    assert triangles.dtype == np.uint32 and triangles.shape == (2, 3)  # the quad as a fan
    assert vertices[2].tolist() == [1.0, 1.0, 0.0] and sorted(set(triangles.ravel().tolist())) == [0, 1, 2, 3]
    scene = sombra.Scene(8, 8)
    assert scene.add_mesh(vertices, triangles) == 0
    with pytest.raises(Exception, match="no_such.obj"):
        sombra.load_mesh(str(tmp_path / "no_such.obj"))


def test_render_returns_a_named_tuple_a_notebook_shows(context, tmp_path):
    scene = sombra.load_scene(str(SOURCE_DIR / "data/scenes/default.json"))
    result = sombra.render(context, scene, width=20, height=12)
    image, stats = result  # unpacks as before
    assert isinstance(result, tuple) and result.image is image and result.stats is stats and result[0] is image
    png = result._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR"
    assert int.from_bytes(png[16:20], "big") == 20 and int.from_bytes(png[20:24], "big") == 12
    sombra.write_image(str(tmp_path / "same.png"), image)
    assert (tmp_path / "same.png").read_bytes() == png  # the CLI's PNG, bit for bit


def test_render_shadows_by_default(context):
    scene = sombra.load_scene(str(SOURCE_DIR / "data/scenes/default.json"))
    assert sombra.RenderOptions().shadows == "dsm"
    context.release_prepared_scenes()  # maps another test kept would be reused, not generated
    image, stats = sombra.render(context, scene, width=24, height=24)
    assert "dsm" in stats and stats["dsm"]["views_generated"] > 0


def test_load_scene_and_options(context):
    scene = sombra.load_scene(str(SOURCE_DIR / "data/scenes/default.json"))
    assert scene.light_count == 2 and scene.volume_count == 1
    options = sombra.RenderOptions()
    options.width = options.height = 24
    options.shadows = "lowpass"
    image, stats = sombra.render(context, scene, options, lowpass_filter_width=5.0)
    assert image.shape == (24, 24, 4) and np.isfinite(image).all()
    assert options.shadows == "lowpass" and options.lowpass_filter_width == 3.0  # keywords change a copy
    assert stats["sat"]["tables"] > 0
    options.shadow_cache = "on"  # the shadow cache by name, for any technique
    image, stats = sombra.render(context, scene, options, shadows="dsm", dsm_resolution=64)
    assert options.shadow_cache == "on" and stats["shadow_cache"]["used"]
    # DSM lookups from the packed copy (default) or in the atlas's own layout: the same image
    packed, _ = sombra.render(context, scene, options, shadows="dsm", dsm_resolution=64, shadow_cache="off")
    native, _ = sombra.render(context, scene, options, shadows="dsm", dsm_resolution=64, shadow_cache="off", dsm_lookup="native")
    assert options.dsm_lookup == "packed" and np.array_equal(packed, native)


def test_bad_arguments_name_the_argument(context, tmp_path):
    scene = numpy_scene(lopsided_volume())
    volume = lopsided_volume()

    def error(kind, call):
        with pytest.raises(kind) as raised:
            call()
        return str(raised.value)

    assert error(ValueError, lambda: scene.add_volume(np.full((2, 2, 2), "a"))) == (
        "Scene.add_volume: voxels: expected a real array of shape (z, y, x), got dtype <U1")
    assert "voxels: expected a real array of shape (z, y, x), got shape (16, 12)" in error(
        ValueError, lambda: scene.add_volume(volume[0]))
    bad = volume.copy()
    bad[1, 2, 3] = np.nan
    assert "voxels: expected a real array of shape (z, y, x), got a non-finite value" in error(
        ValueError, lambda: scene.add_volume(bad))
    assert "transform: expected a 4×4 matrix, got shape (3, 3)" in error(
        ValueError, lambda: scene.add_volume(volume, transform=np.eye(3)))
    assert "opacity: x must increase" in error(ValueError, lambda: scene.add_volume(volume, opacity=[(1, 0), (0, 1)]))
    assert error(ValueError, lambda: scene.add_light("sun")) == (
        "Scene.add_light: type: unknown light type 'sun' (directional, spot, point)")
    assert error(ValueError, lambda: sombra.render(context, scene, shadows="dsmm")) == (
        "render: shadows: unknown value 'dsmm' (none, rays, dsm, shadowmap, lowpass, ao, cone) (did you mean 'dsm'?)")
    assert error(ValueError, lambda: sombra.render(context, scene, bogus=1)) == (
        "render: unknown option 'bogus' (see sombra.RenderOptions)")
    assert error(ValueError, lambda: sombra.render(context, scene, dsm_resolution="x")) == (
        "render: dsm_resolution: expected int, got str")
    # every option is checked at the call by its declaration, named as the caller wrote it
    assert error(ValueError, lambda: sombra.render(context, scene, width=-5)) == (
        "render: width: must lie in [0, 16384], got -5")
    assert error(ValueError, lambda: sombra.render(context, scene, shadows="rays", shadow_ray_step=1e-30)) == (
        "render: shadow_ray_step: must lie in [0.01, 16], got 1e-30")
    assert error(ValueError, lambda: sombra.render(context, scene, shadows="lowpass", lowpass_max_entries=0)).startswith(
        "render: lowpass_max_entries: must lie in [4096, ")
    assert error(ValueError, lambda: sombra.render(context, scene, shadows="rays", dsm_epsilon=0.1)) == (
        "render: dsm_epsilon: applies to shadows=dsm, shadowmap, not rays")
    assert error(ValueError, lambda: sombra.RenderOptions(phase_g=float("nan"))) == (
        "RenderOptions: phase_g: must lie in (-1, 1), got nan")
    options = sombra.RenderOptions()
    assert error(ValueError, lambda: setattr(options, "dsm_clusters", 65)) == "dsm_clusters: must lie in [0, 64], got 65"
    assert error(ValueError, lambda: setattr(options, "dsm_precompression", 1)) == "dsm_precompression: expected bool, got int"
    assert error(ValueError, lambda: sombra.shadow_transmittance(context, scene, 0, np.zeros((4, 2)), shadows="dsm")) == (
        "shadow_transmittance: points: expected an (N, 3) array of world points, got shape (4, 2)")
    assert error(ValueError, lambda: sombra.reference_transmittance(scene, 0, ["a", "b", "c"])).startswith(
        "reference_transmittance: points: expected an (N, 3) array of world points, got")
    # the library's own errors: sombra.Error with its one line
    missing = str(tmp_path / "missing.json")
    assert error(sombra.Error, lambda: sombra.load_scene(missing)).startswith(missing + ": ")
    assert "light index" in error(sombra.Error, lambda: sombra.reference_transmittance(scene, 7, np.zeros((1, 3))))


def test_options_are_generated_from_their_declarations(context, tmp_path):
    options = sombra.RenderOptions(shadows="dsm", dsm_resolution=64, dsm_epsilon=np.float32(0.05), lanes=np.int64(4))
    assert (options.shadows, options.dsm_resolution, options.dsm_epsilon, options.lanes) == ("dsm", 64, 0.05, 4)
    text = repr(options)
    assert text.startswith("sombra.RenderOptions(width=0, height=0, shadows='dsm'") and "dsm_resolution=64" in text
    assert sombra.RenderOptions.dsm_resolution.__doc__.startswith("deep shadow map texels per side [1, 8192] texels")
    # the scene file's "render" block is what render() starts from when no options are given
    volume = {"generator": {"type": "sphere", "size": 16}, "transform": {"scale": 0.06},
              "transfer_function": {"rgb_points": [0, 1, 1, 1, 1, 1, 0.5, 0.2], "opacity_points": [0, 0, 1, 0.5]}}
    scene_file = tmp_path / "block.json"
    scene_file.write_text(json.dumps({
        "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "image": {"width": 16, "height": 12},
        "render": {"shadows": "dsm", "dsm_resolution": 32, "dsm_epsilon": 0.04},
        "volumes": [volume], "lights": [{"type": "directional", "direction": [0, -1, -1]}]}))
    scene = sombra.load_scene(str(scene_file))
    block = scene.render_options()
    assert (block.shadows, block.dsm_resolution, block.dsm_epsilon) == ("dsm", 32, 0.04)
    _, stats = sombra.render(context, scene)
    assert stats["dsm"]["views"] == 1  # the block's technique
    maps, _ = sombra.build_deep_shadow_maps(context, scene, 0)
    assert maps[0].width == 32
    maps, _ = sombra.build_deep_shadow_maps(context, scene, 0, dsm_resolution=24)  # keywords override the block
    assert maps[0].width == 24
    scene_file.write_text(json.dumps({"render": {"dsm_resolutio": 32}, "volumes": [volume]}))
    with pytest.raises(sombra.Error) as raised:
        sombra.load_scene(str(scene_file)).render_options()
    assert str(raised.value) == f"{scene_file}: render: unknown key 'dsm_resolutio' (did you mean 'dsm_resolution'?)"


def test_voxels_of_every_real_dtype_and_order_render_as_their_float32_values(context):
    ramp = (np.arange(20 * 16 * 12).reshape(20, 16, 12) % 8).astype(np.float32) / 8  # eighths: exact in every dtype
    reference, _ = sombra.render(context, numpy_scene(ramp), shadows="rays")
    assert reference[..., 3].max() > 0.2  # the volume is in view
    variants = {"float64": ramp.astype(np.float64), "Fortran order": np.asfortranarray(ramp),
                "strided view": np.repeat(ramp, 2, axis=2)[:, :, ::2], "float16": ramp.astype(np.float16)}
    for name, voxels in variants.items():
        image, _ = sombra.render(context, numpy_scene(voxels), shadows="rays")
        assert np.array_equal(image, reference), name
    counts = (ramp * 8).astype(np.uint8)  # CT-like integers: the values as they are, as the CLI reads .npy
    from_uint8, _ = sombra.render(context, numpy_scene(counts), shadows="rays")
    from_int16, _ = sombra.render(context, numpy_scene(counts.astype(np.int16)), shadows="rays")
    from_float, _ = sombra.render(context, numpy_scene(counts.astype(np.float32)), shadows="rays")
    assert np.array_equal(from_uint8, from_float) and np.array_equal(from_int16, from_float)
    # converted straight into the volume (no float32 temporary), with the same non-finite rule
    for bad in (np.full((2, 2, 2), np.nan), np.full((2, 2, 2), 1e300), np.asfortranarray(np.full((2, 2, 3), np.inf))):
        with pytest.raises(ValueError, match="add_volume: voxels: .*non-finite value at flat index 0"):
            sombra.Scene(8, 8).add_volume(bad)


def test_meshes_from_numpy_cast_shadows_and_images_are_written(context, tmp_path):
    scene = numpy_scene(lopsided_volume())
    plain, _ = sombra.render(context, scene, shadows="rays")
    # an opaque square between the spot light and the volume
    square = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float64) * 0.4
    transform = np.eye(4)
    transform[:3, 3] = (0.28, 0.9, 0.35)  # on the light's way, above the volume
    index = scene.add_mesh(square, np.array([[0, 1, 2], [0, 2, 3]]), color=(0.2, 0.2, 0.2), opacity=1.0, transform=transform)
    assert index == 0
    shadowed, _ = sombra.render(context, scene, shadows="rays")
    assert shadowed[..., :3].sum() < plain[..., :3].sum()  # the volume lies in the square's shadow
    with pytest.raises(ValueError) as raised:
        scene.add_mesh(square, [[0, 1, 4]])
    assert str(raised.value) == "Scene.add_mesh: triangles: index 4 in row 0 is not a vertex (0 … 3)"
    with pytest.raises(ValueError) as raised:
        scene.add_mesh(square, np.array([[0, 1, 2.5]]))
    assert str(raised.value) == "Scene.add_mesh: triangles: expected integer vertex indices, got dtype float64"
    # images as `sombra render -o` writes them
    png, exr = tmp_path / "out.png", tmp_path / "out.exr"
    sombra.write_image(str(png), shadowed)
    sombra.write_image(str(exr), shadowed, background=scene.background)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and exr.read_bytes()[:4] == b"\x76\x2f\x31\x01"
    with pytest.raises(sombra.Error):
        sombra.write_image(str(tmp_path / "out.bmp"), shadowed)
    assert not (tmp_path / "out.bmp").exists()
    assert re.fullmatch(r"\d+\.\d+\.\d+", sombra.__version__)


def test_docs_example_runs():
    text = (SOURCE_DIR / "docs/python.md").read_text()
    example = re.search(r"## Example.*?```python\n(.*?)```", text, re.S).group(1)
    namespace = {}
    exec(compile(example, "docs/python.md", "exec"), namespace)
    assert namespace["image"].shape == (96, 96, 4)
    assert np.abs(namespace["dsm"] - namespace["reference"]).mean() < 0.02  # measured 0.011
    assert len(namespace["maps"]) == 1 and len(namespace["view"].depth) > 0


def test_clustered_deep_shadow_maps(context):
    scene = sombra.load_scene(str(SOURCE_DIR / "data/scenes/cup_array.json"))
    options = sombra.RenderOptions()
    options.width, options.height = 48, 32
    options.shadows = "dsm"
    options.dsm_clusters = 4
    image, stats = sombra.render(context, scene, options, dsm_resolution=64)
    assert np.isfinite(image).all()
    lights = stats["dsm"]["lights"]
    assert len(lights) == 2 and all(1 <= len(light["clusters"]) <= 4 for light in lights)
    members = [name for light in lights[:1] for c in light["clusters"] for name in c["members"]]
    assert len(members) == len(set(members)) and "table" in members  # each object in one cluster of a light
    maps, _ = sombra.build_deep_shadow_maps(context, scene, 0, dsm_resolution=32, dsm_clusters=4)
    assert maps[0].light_name == "lights[0].cluster0.0"


def test_returned_arrays_hold_one_value_per_point_with_their_own_strides(context):
    """Under numpy 2 a module built with pybind11 < 2.12 returned stride-0 arrays (every point the
    first point's value) and zeroed offsets (issue 26): each returned array is checked for its
    dtype, shape, strides and values that differ from point to point."""
    import os

    expected_major = os.environ.get("SOMBRA_EXPECT_NUMPY_MAJOR")
    if expected_major:  # the ctest run under numpy 2 does run under numpy 2
        assert np.__version__.split(".")[0] == expected_major
    scene = numpy_scene(lopsided_volume())
    n = 60
    t = np.linspace(0, 1, n)
    points = np.stack([-0.35 + 0.7 * t, 0.05 + 0.1 * t, 0.3 - 0.6 * t], axis=1)
    reference = sombra.reference_transmittance(scene, 0, points)
    rays, _ = sombra.shadow_transmittance(context, scene, 0, points, shadows="rays")
    dsm, _ = sombra.shadow_transmittance(context, scene, 0, points, shadows="dsm", dsm_resolution=64)
    for name, values in (("reference", reference), ("rays", rays), ("dsm", dsm)):
        assert values.dtype == np.float64 and values.shape == (n,) and values.strides == (8,), name
        assert len(np.unique(values)) > n // 2, f"{name}: {values[:5]}"  # a value per point, not one for all
    for i in (0, 23, n - 1):  # each point's value is its own, as a query of that point alone gives it
        assert reference[i] == sombra.reference_transmittance(scene, 0, points[i:i + 1])[0]
    assert np.abs(rays - reference).max() < 0.02
    image, _ = sombra.render(context, scene, shadows="dsm", dsm_resolution=32)
    assert image.strides == (40 * 16, 16, 4) and image.flags.c_contiguous
    assert len(np.unique(image[..., 3])) > 100
    maps, _ = sombra.build_deep_shadow_maps(context, scene, 0, dsm_resolution=24)
    view = maps[0]
    assert view.first.dtype == np.uint32 and view.first.strides == (4,) and view.first.shape == (24 * 24 + 1,)
    assert view.first[0] == 0 and (np.diff(view.first.astype(np.int64)) >= 0).all() and view.first[-1] > 0
    for values in (view.depth, view.opacity):
        assert values.dtype == np.float32 and values.strides == (4,) and values.shape == (view.first[-1],)
        assert len(np.unique(values)) > 10
    assert view.world_to_camera.strides == (16, 4) and len(np.unique(view.world_to_camera)) > 3


def test_one_context_shared_by_threads(context):
    """A Context may be shared between threads: calls take turns on its lock (issue 25; two threads
    used to crash in preparation or abort in PoCL). Each thread's results equal a lone call's."""
    import threading

    scene = numpy_scene(lopsided_volume())
    points = np.random.default_rng(9).uniform(-0.3, 0.3, size=(40, 3))
    alone_image, _ = sombra.render(context, scene, shadows="dsm", dsm_resolution=32)
    alone_t, _ = sombra.shadow_transmittance(context, scene, 0, points, shadows="rays")
    results, errors = {}, []

    def work(k):
        try:
            if k % 2:
                results[k] = sombra.render(context, scene, shadows="dsm", dsm_resolution=32)[0]
            else:
                results[k] = sombra.shadow_transmittance(context, scene, 0, points, shadows="rays")[0]
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(repr(e))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    assert not errors and len(results) == 6
    for k, value in results.items():
        assert np.array_equal(value, alone_image if k % 2 else alone_t), k


def test_scene_values_are_checked_at_the_call_with_the_scene_files_rules(context):
    """Python scenes obey the rules scene files do, at the call that received the value (issue 25:
    step_voxels=0 hung the renderer; NaN intensities and a 180° cone were accepted; issue 26: a bad
    set_camera was reported only at render); a value set
    later is caught at render by the same checks."""
    volume = lopsided_volume()
    scene = sombra.Scene(width=16, height=16)

    def message(call):
        with pytest.raises(ValueError) as raised:
            call()
        return str(raised.value)

    assert message(lambda: scene.add_volume(volume, step_voxels=0)) == "Scene.add_volume: step_voxels: must lie in [0.01, 16]"
    assert message(lambda: scene.add_volume(volume, step_voxels=float("nan"))).startswith("Scene.add_volume: step_voxels")
    assert message(lambda: scene.add_volume(volume, spacing=(1, 0, 1))) == "Scene.add_volume: spacing: must be ≥ 1e-12 (positive)"
    assert message(lambda: scene.add_volume(volume, opacity_unit=-1)).startswith("Scene.add_volume: opacity_unit")
    assert message(lambda: scene.add_light("spot", cone_angle_deg=90)) == "Scene.add_light: cone_angle_deg: must lie in (0, 90)"
    assert message(lambda: scene.add_light("point", intensity=float("nan"))) == "Scene.add_light: intensity: must be ≥ 0"
    assert message(lambda: scene.add_light("directional", direction=(0, 0, 0))) == (
        "Scene.add_light: direction: must be a non-zero vector")
    assert message(lambda: scene.add_light("point", color=(1, -1, 1))) == "Scene.add_light: color: must be ≥ 0"
    assert message(lambda: scene.set_camera((0, 0, 5), (0, 0, 5))) == (
        "Scene.set_camera: look_at: must differ from camera.position")
    assert message(lambda: scene.set_camera((0, 0, 5), (0, 0, 0), up=(0, 0, 2))) == (
        "Scene.set_camera: up: must be a non-zero vector not parallel to the view direction")
    assert message(lambda: scene.set_camera((0, 0, 5), (0, 0, 0), up=(0, 0, 0))).startswith("Scene.set_camera: up:")
    assert message(lambda: scene.set_camera((0, 0, 5), (0, 0, 0), fov_y_deg=180)) == (
        "Scene.set_camera: fov_y_deg: must lie in (0, 180)")
    assert message(lambda: scene.set_camera((0, 0, 1e30), (0, 0, 0))) == "Scene.set_camera: position: must lie within ±1e18"
    assert scene.volume_count == 0 and scene.light_count == 0  # nothing half-added
    scene.add_volume(volume, spacing=SPACING, opacity=OPACITY, color=COLOR)
    scene.add_light("spot", **LIGHT)
    scene.set_camera(**CAMERA)
    scene.ambient_intensity = -1.0  # an attribute set after the fact: render checks it
    with pytest.raises(sombra.Error) as raised:
        sombra.render(context, scene)
    assert "ambient_intensity: must be ≥ 0" in str(raised.value)


def test_huge_zero_stride_views_are_refused_before_any_copy():
    """A broadcast view of 2³³ voxels costs nothing until copied: its size is checked first (issue 25:
    it used to be converted whole, gigabytes, before the size check)."""
    import tracemalloc

    scene = sombra.Scene()
    huge = np.broadcast_to(np.float32(0.5), (2048, 2048, 2048))
    assert huge.strides == (0, 0, 0)
    tracemalloc.start()
    with pytest.raises(ValueError) as raised:
        scene.add_volume(huge)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert "8589934592 elements (2048, 2048, 2048), more than the limit of 1073741824" in str(raised.value)
    assert peak < 1 << 20
    points = np.broadcast_to(np.zeros(3), (1 << 25, 3))
    with pytest.raises(ValueError, match="more than the limit"):
        sombra.reference_transmittance(numpy_scene(lopsided_volume()), 0, points)


def test_the_type_stub_names_everything_the_module_has():
    import ast

    stub = ast.parse((SOURCE_DIR / "python" / "sombra.pyi").read_text())

    def names(body):
        out = set()
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                out.add(node.name)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                out.add(node.target.id)
        return out

    classes = {node.name: names(node.body) for node in stub.body if isinstance(node, ast.ClassDef)}
    public = {n for n in dir(sombra) if not n.startswith("_")} | {"__version__"}
    assert public <= names(stub.body), public - names(stub.body)
    for name, members in classes.items():
        if not hasattr(sombra, name) or name == "Error":
            continue  # stub-only types (RenderOptionKeywords); Error's members are Exception's
        inherited = set(dir(tuple)) if issubclass(getattr(sombra, name), tuple) else set()  # a NamedTuple's count, index
        runtime = {m for m in dir(getattr(sombra, name)) if not m.startswith("_")} - inherited
        assert runtime <= members, (name, runtime - members)
