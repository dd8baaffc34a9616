"""OpenVDB files written byte by byte (format 224, one Tree_float_5_4_3 grid), for fuzz seeds
(fuzz/make_seeds.py) and hostile variants: every length, count and chunk is a parameter."""
import struct
import zlib

UUID = b"00000000-0000-4000-8000-000000000000"


def string(s):
    s = s.encode() if isinstance(s, str) else s
    return struct.pack("<I", len(s)) + s


def metadata(items):
    """items: (name, type, value bytes); each value goes with its size."""
    out = struct.pack("<I", len(items))
    for name, kind, value in items:
        out += string(name) + string(kind) + struct.pack("<I", len(value)) + value
    return out


def chunk(raw, zip_it):
    """io::readData's chunk of a compressed grid: a signed size, then zlib data or (size < 0) raw bytes."""
    if not zip_it:
        return struct.pack("<q", -len(raw)) + raw
    z = zlib.compress(raw)
    return struct.pack("<q", len(z)) + z


def values(raw, compression, inactive_node=False):
    """io::readCompressedValues: every value stored (metadata byte 6), or for a node without active
    values under active-mask compression (flag 2) none (metadata byte 0: all background)."""
    if inactive_node and compression & 2:
        raw, how = b"", b"\x00"
    else:
        how = b"\x06"
    return how + (chunk(raw, compression & 1) if compression & 5 else raw)


def leaf_index(x, y, z, shift, span):
    """The index of (x, y, z)'s child in a node of `span` voxels whose children span 2**shift."""
    side = span >> shift
    return (((x % span) >> shift) * side + ((y % span) >> shift)) * side + ((z % span) >> shift)


def topology_and_buffers(leaves, compression, chunk_override=None):
    """The root's one child at the origin holding `leaves`: {leaf origin: (512 floats, active voxel
    indices)}, leaf origins multiples of 8 in [0, 4096). Returns (topology, buffers)."""
    lower = {}  # InternalNode<4> index in the upper node -> {leaf index: leaf origin}
    for o in leaves:
        lower.setdefault(leaf_index(*o, 7, 4096), {})[leaf_index(*o, 3, 128)] = o
    topo = struct.pack("<i", 1) + struct.pack("<f", 0) + struct.pack("<II", 0, 1) + struct.pack("<3i", 0, 0, 0)
    topo += bitmask(32768, lower) + bitmask(32768, ()) + values(bytes(4 * 32768), compression, True)
    buffers = b""
    for i in sorted(lower):
        topo += bitmask(4096, lower[i]) + bitmask(4096, ()) + values(bytes(4 * 4096), compression, True)
        for j in sorted(lower[i]):
            voxels, active = leaves[lower[i][j]]
            m = bitmask(512, active)
            topo += m
            raw = struct.pack("<512f", *voxels)
            buffers += m + (chunk_override if chunk_override is not None else values(raw, compression))
    return topo, buffers


def bitmask(bits, on):
    m = bytearray(bits // 8)
    for i in on:
        m[i // 8] |= 1 << (i % 8)
    return bytes(m)


def grid(voxels=None, compression=1, name="density", grid_type="Tree_float_5_4_3", meta_extra=(),
         chunk_override=None, leaves=None):
    """One float grid: by default a single leaf at the origin holding `voxels` (512 floats, x
    slowest as OpenVDB stores them), all active; or `leaves` as topology_and_buffers takes them."""
    if leaves is None:
        leaves = {(0, 0, 0): (voxels, range(512))}
    desc = string(name) + string(grid_type) + string("") + struct.pack("<3q", 0, 0, 0)
    meta = metadata([("name", "string", name.encode()), ("class", "string", b"fog volume")] + list(meta_extra))
    scale = struct.pack("<15d", 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0.5, 0.5, 0.5)
    topo, buffers = topology_and_buffers(leaves, compression, chunk_override)
    return desc + struct.pack("<I", compression) + meta + string("UniformScaleMap") + scale + topo + buffers


def vdb(grids, version=224, file_meta=()):
    head = struct.pack("<qI", 0x56444220, version) + struct.pack("<II", 10, 0) + b"\x00" + UUID
    return head + metadata(list(file_meta)) + struct.pack("<i", len(grids)) + b"".join(grids)


def ramp():
    return [float(i % 8) / 8 for i in range(512)]
