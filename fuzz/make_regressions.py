#!/usr/bin/env python3
"""Writes the hand-made hostile inputs of tests/fuzz-regressions/ (issue 25: each reproduced a crash,
an abort or a runaway allocation before its fix; the ctest fuzz-regressions/NAME replays them and
tests/test_hostile_input.cpp checks each one's error line). Standard library only:
python3 fuzz/make_regressions.py"""
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vdb_bytes  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def put(harness, name, data):
    folder = os.path.join(ROOT, "tests", "fuzz-regressions", harness)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def patch(data, old, new):
    assert data.count(old) >= 1, old
    return data.replace(old, new, 1)


# --- OpenVDB ---
ramp = vdb_bytes.ramp()
one = [0.0] * 512
one[0] = 1.0
# two active voxels 816 apart: a 817³ box (2.2 GB as floats) for two voxels
put("vdb", "sparse-two-voxels.vdb", vdb_bytes.vdb([vdb_bytes.grid(
    leaves={(0, 0, 0): (one, [0]), (816, 816, 816): (one, [0])})]))
good = vdb_bytes.vdb([vdb_bytes.grid(ramp, compression=1)])
big = struct.pack("<I", 512 << 20)
# the grid name's length made 512 MiB (OpenVDB allocated it before reading)
put("vdb", "name-512mib.vdb", patch(good, vdb_bytes.string("density") + b"\x10\0\0\0Tree_float",
                                    big + b"density\x10\0\0\0Tree_float"))
# a metadata string's size made 512 MiB
put("vdb", "metadata-512mib.vdb", patch(good, b"\x0a\x00\x00\x00fog volume", big + b"fog volume"))
# a leaf's uncompressed chunk declaring 4096 bytes where the leaf holds 2048: OpenVDB copied them
# into the leaf's buffer before comparing the sizes (heap overflow, glibc abort)
raw = struct.pack("<512f", *ramp) * 2
put("vdb", "leaf-chunk-overflow.vdb", vdb_bytes.vdb([vdb_bytes.grid(
    ramp, compression=1, chunk_override=b"\x06" + struct.pack("<q", -len(raw)) + raw)]))
# a root child at an origin that is not a multiple of 4096, and a bool grid
put("vdb", "unaligned-root-child.vdb", patch(good, struct.pack("<II3i", 0, 1, 0, 0, 0), struct.pack("<II3i", 0, 1, 8, 0, 0)))
put("vdb", "bool-grid.vdb", vdb_bytes.vdb([vdb_bytes.grid(ramp, grid_type="Tree_bool_5_4_3")]))

# --- DICOM ---
import dicom_bytes  # noqa: E402
# an element (Modality) whose length says 2 GiB
good_dcm = dicom_bytes.image(syntax=dicom_bytes.IMPLICIT)
put("dicom", "length-2gib.dcm", patch(good_dcm, struct.pack("<HHI", 8, 0x60, 2) + b"OT",
                                       struct.pack("<HHI", 8, 0x60, 0x80000000) + b"OT"))
# garbage as JPEG baseline and JPEG 2000 pixel data (encapsulated: an offset table item, one fragment)
garbage = bytes((i * 37 + 11) % 256 for i in range(64))
fragments = (struct.pack("<HHI", 0xFFFE, 0xE000, 0) + struct.pack("<HHI", 0xFFFE, 0xE000, len(garbage)) + garbage +
             struct.pack("<HHI", 0xFFFE, 0xE0DD, 0))
for name, syntax in (("jpeg-garbage.dcm", "1.2.840.10008.1.2.4.50"), ("jpeg2000-garbage.dcm", "1.2.840.10008.1.2.4.90")):
    put("dicom", name, dicom_bytes.image(syntax=syntax, pixels=fragments, pixel_length=0xFFFFFFFF))
# pixel data of 4 bytes for a 3 x 4 16-bit image (24 bytes)
put("dicom", "short-pixels.dcm", dicom_bytes.image(pixels=b"\1\0\2\0"))
# 8-bit pixels with 1 bit stored, MONOCHROME1 (GDCM's general decoder asserts that 8-bit pixels store
# all 8 bits; the fuzzer found it with an empty PhotometricInterpretation: bits-stored-1-of-8.dcm)
eight_bit = patch(dicom_bytes.image(photometric=b"MONOCHROME1 ", bits_stored=1), struct.pack("<HH", 0x28, 0x100) + b"US" +
                  struct.pack("<HH", 2, 16), struct.pack("<HH", 0x28, 0x100) + b"US" + struct.pack("<HH", 2, 8))
eight_bit = patch(eight_bit, struct.pack("<HH", 0x28, 0x102) + b"US" + struct.pack("<HH", 2, 15),
                  struct.pack("<HH", 0x28, 0x102) + b"US" + struct.pack("<HH", 2, 0))
put("dicom", "monochrome1-bits-stored-1-of-8.dcm", eight_bit)

# --- deep EXR: sombra's own 8 x 8 map (fuzz/corpus/deep_exr) cut inside its sample data ---
seed = os.path.join(ROOT, "fuzz", "corpus", "deep_exr", "dsm_8x8.exr")
if os.path.exists(seed):
    with open(seed, "rb") as f:
        whole = f.read()
    put("deep_exr", "cut-in-samples.exr", whole[: len(whole) * 2 // 3])

# --- CLI arguments (fuzz/fuzz_cli.cpp): values out of range or not numbers, outputs naming inputs ---
def argv(*args):
    return b"\0".join(a.encode() for a in args)


put("cli", "huge-and-nan-values.args", argv("render", "scene.json", "-o", "o.png", "--width", "1e400", "--eps", "nan",
                                             "--dsm-res", "-1", "--filter", "inf", "--seed", "99999999999999999999"))
put("cli", "output-is-input.args", argv("render", "scene.json", "-o", "scene.json"))
put("cli", "points-device.args", argv("visibility", "scene.json", "--light", "99999999999", "--points", "/dev/zero"))
put("cli", "empty-arguments.args", argv("", "", "render", "", "-o"))
put("cli", "unknown-technique.args", argv("dsm", "scene.json", "--light", "0", "-o", "d.png", "--shadows", "dsmx", "--precompression=7"))
