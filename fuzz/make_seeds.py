#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz harnesses (fuzz/corpus/<harness>/): small valid files of
every format, made by hand here, plus the small files and cut headers of data/. Standard library
only. Run from anywhere: python3 fuzz/make_seeds.py"""
import gzip, io, os, shutil, struct, zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORPUS = os.path.join(ROOT, "fuzz", "corpus")
DATA = os.path.join(ROOT, "data")


def put(harness, name, data):
    folder = os.path.join(CORPUS, harness)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def head(path, n):
    with open(os.path.join(DATA, path), "rb") as f:
        return f.read(n)


voxels = [float(i % 7) for i in range(2 * 3 * 4)]  # 2 x 3 x 4, x fastest

def npy(descr="<f4", fmt="<24f", values=voxels):
    header = "{'descr': '%s', 'fortran_order': False, 'shape': (4, 3, 2), }" % descr
    header = header.ljust(117) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + struct.pack(fmt, *values)

def nifti(datatype=16, bitpix=32, fmt="<24f"):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, 2, 3, 4, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1, 2, 3, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)
    struct.pack_into("<f", h, 112, 1.0)
    h[344:348] = b"n+1\0"
    values = voxels if fmt.endswith("f") else [int(v) for v in voxels]
    return bytes(h) + b"\0\0\0\0" + struct.pack(fmt, *values)

def den():
    h = bytearray(62)
    struct.pack_into("<h", h, 0, 1)
    struct.pack_into("<3h", h, 50, 2, 3, 4)
    struct.pack_into("<i", h, 58, 24)
    return bytes(h) + bytes(int(v) for v in voxels)

def inr(kind="float", bits=32, cpu="decm", fmt="<24f"):
    text = "#INRIMAGE-4#{\nXDIM=2\nYDIM=3\nZDIM=4\nVDIM=1\nTYPE=%s\nPIXSIZE=%d bits\nCPU=%s\nVX=1\nVY=2\nVZ=3\n" % (kind, bits, cpu)
    text = text.ljust(252, "\n") + "##}\n"
    values = voxels if fmt.endswith("f") else [int(v) for v in voxels]
    return text.encode() + struct.pack(fmt, *values)

def vtk(mode="ASCII"):
    head_text = ("# vtk DataFile Version 3.0\nseed\n%s\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 3 4\n"
                 "SPACING 1 2 3\nORIGIN 0 0 0\nPOINT_DATA 24\nSCALARS v float 1\nLOOKUP_TABLE default\n" % mode)
    body = (" ".join("%g" % v for v in voxels) + "\n").encode() if mode == "ASCII" else struct.pack(">24f", *voxels)
    return head_text.encode() + body

put("npy", "f4.npy", npy())
put("npy", "u2_big.npy", npy(">u2", ">24H", [int(v) for v in voxels]))
for name, method in (("stored.npz", zipfile.ZIP_STORED), ("deflated.npz", zipfile.ZIP_DEFLATED)):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", method) as z:
        z.writestr("arr_0.npy", npy())
    put("npz", name, buf.getvalue())
put("nifti", "f32.nii", nifti())
put("nifti", "u8.nii", nifti(2, 8, "<24B"))
put("nifti_gz", "f32.nii.gz", gzip.compress(nifti(), mtime=0))
put("nifti_gz", "ch2_head.nii.gz", head("volumes/ch2.nii.gz", 2048))
put("den", "small.den", den())
put("den", "brainsmall_head.den", head("volumes/brainsmall.den", 1024))
put("inr", "f32.inr", inr())
put("inr", "u16_sun.inr", inr("unsigned fixed", 16, "sun", ">24H"))
put("inr", "skull_head.inr", head("volumes/skull_2.9.inr", 1024))
put("vtk", "ascii.vtk", vtk("ASCII"))
put("vtk", "binary.vtk", vtk("BINARY"))
put("vtk", "heart_head.vtk", head("volumes/heart.vtk", 2048))
# raw: the JSON header, a NUL, then the bytes of v.raw beside it (see fuzz/fuzz_raw.cpp)
put("raw", "int16.raw", b'{"raw": "v.raw", "dims": [2, 3, 4], "type": "int16", "endian": "big", "header_bytes": 2, '
                        b'"spacing": [1, 2, 0.5]}\0' + b"\0\0" + struct.pack(">24h", *[int(v) for v in voxels]))
put("raw", "cloud_header.raw", head("volumes/cloud_shape_128.json", 4096).replace(b"cloud_shape_128.bin", b"v.raw") +
    b"\0" + bytes(64))

vertex = "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
face = "element face 2\nproperty list uchar int vertex_indices\n"
put("mesh_ply", "ascii.ply", "ply\nformat ascii 1.0\ncomment seed\n" + vertex + face + "end_header\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 1 2 3\n")
put("mesh_ply", "normals.ply", "ply\nformat ascii 1.0\n" + vertex + "property float nx\nproperty float ny\nproperty float nz\n"
    + face + "end_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n3 0 2 3\n")
for order, fmt in (("little", "<"), ("big", ">")):
    body = struct.pack(fmt + "12f", 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0)
    body += struct.pack(fmt + "B3i", 3, 0, 1, 2) + struct.pack(fmt + "B4i", 4, 0, 1, 2, 3)
    put("mesh_ply", "binary_%s.ply" % order,
        ("ply\nformat binary_%s_endian 1.0\n" % order + vertex + face + "end_header\n").encode() + body)
put("mesh_obj", "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n")
shutil.copy(os.path.join(DATA, "meshes", "wall.obj"), os.path.join(CORPUS, "mesh_obj", "wall.obj"))
put("mesh_obj", "teapot_head.obj", head("meshes/teapot.obj", 4096))

os.makedirs(os.path.join(CORPUS, "scene"), exist_ok=True)
for name in sorted(os.listdir(os.path.join(DATA, "scenes"))):
    if os.path.getsize(os.path.join(DATA, "scenes", name)) <= 4096:
        shutil.copy(os.path.join(DATA, "scenes", name), os.path.join(CORPUS, "scene", name))
put("scene", "generators.json", """{
  "camera": {"position": [0, -3, 1], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 40},
  "image": {"width": 64, "height": 48}, "background": [0, 0, 0.1], "ambient_intensity": 0.5,
  "volumes": [
    {"name": "a", "generator": {"type": "blobs", "size": 16, "count": 3, "seed": 7}, "spacing": [0.1, 0.1, 0.1],
     "transform": {"translate": [0, 0, 0], "rotate_deg": [10, 0, 0], "scale": 1}, "step_voxels": 0.5, "opacity_unit": 0,
     "transfer_function": {"rgb_points": [0, 1, 1, 1, 1, 1, 0.5, 0.2], "opacity_points": [0, 0, 1, 0.5]},
     "material": {"ambient": 0.2, "diffuse": 0.7, "specular": 0.3, "shininess": 20}},
    {"generator": {"type": "slab", "size": 8, "axis": 1, "lo": 0.2, "hi": 0.6, "density": 2},
     "transform": {"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},
     "transfer_function": {"rgb_points": [0, 1, 0, 0], "opacity_points": [0, 0, 2, 1]}}
  ],
  "lights": [{"type": "directional", "direction": [0.4, 0.8, -0.45], "color": [1, 1, 1], "intensity": 1},
             {"type": "spot", "position": [0, -2, 2], "direction": [0, 1, -1], "cone_angle_deg": 25, "cone_softness": 0.1,
              "attenuation": [1, 0, 0]},
             {"type": "point", "position": [1, 1, 1], "attenuation": [1, 0.1, 0.01]}]
}
""")
put("points", "points.csv", "# x,y,z\n0,0,0\n0.1;0.05;0\n  0 0.1 0.02\n\n1e3,-2.5e-3,7\n")

# ITK's formats (issue 25): NRRD raw and gzip, MetaImage with attached data, a two-page TIFF stack
float_bytes = struct.pack("<24f", *voxels)
nrrd_head = ("NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 2 3 4\n"
             "space directions: (1,0,0) (0,1.5,0) (0,0,2)\nspace origin: (1,2,3)\nendian: little\n")
put("nrrd", "raw.nrrd", (nrrd_head + "encoding: raw\n\n").encode() + float_bytes)
put("nrrd", "gzip.nrrd", (nrrd_head + "encoding: gzip\n\n").encode() + gzip.compress(float_bytes, mtime=0))
put("metaimage", "attached.mha", b"ObjectType = Image\nNDims = 3\nDimSize = 2 3 4\nElementSpacing = 1 1.5 2\n"
    b"ElementType = MET_FLOAT\nElementDataFile = LOCAL\n" + float_bytes)


def tiff_stack(pages=2, width=3, height=2):
    """A little-endian TIFF of `pages` uint16 pages, one strip each, written by hand (TIFF 6.0)."""
    out = bytearray(b"II*\0" + struct.pack("<I", 8))
    for page in range(pages):
        ifd = len(out)
        entries = [(256, 3, width), (257, 3, height), (258, 3, 16), (259, 3, 1), (262, 3, 1), (273, 4, 0),
                   (277, 3, 1), (278, 3, height), (279, 4, 2 * width * height)]
        data_at = ifd + 2 + 12 * len(entries) + 4
        out += struct.pack("<H", len(entries))
        for tag, kind, value in entries:
            value = data_at if tag == 273 else value
            out += struct.pack("<HHI", tag, kind, 1) + (struct.pack("<HH", value, 0) if kind == 3 else struct.pack("<I", value))
        next_at = data_at + 2 * width * height if page + 1 < pages else 0
        out += struct.pack("<I", next_at)
        out += struct.pack("<%dH" % (width * height), *[page * 100 + i for i in range(width * height)])
    return bytes(out)


put("tiff", "stack.tif", tiff_stack())
put("tiff", "one_page.tif", tiff_stack(1))


# OpenVDB (issue 25): one-leaf grids written by hand (fuzz/vdb_bytes.py), raw and zlib, and sombra's
# smoke plume (Blosc, half floats, two grids)
import sys
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vdb_bytes
put("vdb", "leaf_raw.vdb", vdb_bytes.vdb([vdb_bytes.grid(vdb_bytes.ramp(), compression=2)]))
put("vdb", "leaf_zip.vdb", vdb_bytes.vdb([vdb_bytes.grid(vdb_bytes.ramp(), compression=1)]))
shutil.copy(os.path.join(DATA, "volumes", "smoke_plume.vdb"), os.path.join(CORPUS, "vdb", "smoke_plume.vdb"))

# DICOM (issue 25): one 16-bit image by hand (fuzz/dicom_bytes.py), explicit and implicit VR, one
# with a sequence
import dicom_bytes
put("dicom", "explicit.dcm", dicom_bytes.image())
put("dicom", "implicit.dcm", dicom_bytes.image(syntax=dicom_bytes.IMPLICIT))
put("dicom", "sequence.dcm", dicom_bytes.image(extra=dicom_bytes.sequence(
    [dicom_bytes.element(0x0008, 0x1150, "UI", b"1.2.3\0")])))
# deep EXR: an 8 x 8 deep shadow map written by sombra itself, when the build is there
sombra = os.path.join(ROOT, "build", "sombra")
if os.path.exists(sombra):
    import subprocess
    os.makedirs(os.path.join(CORPUS, "deep_exr"), exist_ok=True)
    subprocess.run([sombra, "dsm", os.path.join(DATA, "scenes", "default.json"), "--light", "0", "--dsm-res", "8", "-q",
                    "-o", os.path.join(CORPUS, "deep_exr", "dsm_8x8.exr")], check=True)

# CLI arguments (issue 25 item 5): argument lists after `sombra`, NUL-separated; the harness's
# folder holds scene.json, v.npy, m.obj and points.csv (fuzz/fuzz_cli.cpp)
def argv(*args):
    return b"\0".join(a.encode() for a in args)

put("cli", "render.args", argv("render", "scene.json", "-o", "o.png", "--dsm-res", "64", "--eps", "0.01", "--stats", "s.json"))
put("cli", "render-lowpass.args", argv("render", "scene.json", "-o", "o.exr", "--shadows", "lowpass", "--filter", "5",
                                        "--width", "32", "--height", "8"))
put("cli", "render-volume.args", argv("render", "v.npy", "-o", "v.png", "--preset", "ct", "--write-scene", "w.json"))
put("cli", "dsm.args", argv("dsm", "scene.json", "--light", "1", "-o", "d.exr", "--dsm-error", "absolute", "--clusters", "2"))
put("cli", "visibility.args", argv("visibility", "scene.json", "--light", "0", "--points", "points.csv", "--shadows", "dsm,rays"))
put("cli", "info.args", argv("info", "scene.json", "--json"))
put("cli", "clusters.args", argv("clusters", "scene.json", "--clusters", "3", "--light", "0"))
put("cli", "help.args", argv("render", "--help"))
