"""DICOM Part 10 files written byte by byte (one 16-bit grey image), for fuzz seeds
(fuzz/make_seeds.py) and hostile variants (fuzz/make_regressions.py)."""
import struct

IMPLICIT, EXPLICIT = "1.2.840.10008.1.2", "1.2.840.10008.1.2.1"
LONG_VRS = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"}


def even(value):
    return value + (b"\0" if len(value) % 2 else b"")


def element(group, elem, vr, value, explicit=True, length=None):
    """One data element; `length` overrides the value's own (a hostile length)."""
    n = len(value) if length is None else length
    head = struct.pack("<HH", group, elem)
    if not explicit:
        return head + struct.pack("<I", n) + value
    if vr in LONG_VRS:
        return head + vr.encode() + b"\0\0" + struct.pack("<I", n) + value
    return head + vr.encode() + struct.pack("<H", n) + value


def meta(syntax):
    body = element(2, 0x0001, "OB", b"\0\1")
    body += element(2, 0x0002, "UI", even(b"1.2.840.10008.5.1.4.1.1.7"))
    body += element(2, 0x0003, "UI", even(b"1.2.3.4.5"))
    body += element(2, 0x0010, "UI", even(syntax.encode()))
    return b"\0" * 128 + b"DICM" + element(2, 0x0000, "UL", struct.pack("<I", len(body))) + body


def image(rows=3, columns=4, syntax=EXPLICIT, pixels=None, pixel_length=None, extra=b"", photometric=b"MONOCHROME2 ",
          bits_stored=16):
    """A 16-bit grey image, rows x columns; `pixels` replaces the pixel bytes, `pixel_length` their length;
    `photometric` and `bits_stored` the values of (0028,0004) and (0028,0101)."""
    x = syntax != IMPLICIT
    data = pixels if pixels is not None else struct.pack("<%dh" % (rows * columns), *range(rows * columns))
    body = element(0x0008, 0x0060, "CS", b"OT", x)
    body += extra  # elements of group 0008 after (0008,0060), in tag order
    body += element(0x0020, 0x0032, "DS", b"0\\0\\0 ", x) + element(0x0020, 0x0037, "DS", b"1\\0\\0\\0\\1\\0 ", x)
    body += element(0x0028, 0x0002, "US", struct.pack("<H", 1), x)
    body += element(0x0028, 0x0004, "CS", photometric, x)
    body += element(0x0028, 0x0010, "US", struct.pack("<H", rows), x)
    body += element(0x0028, 0x0011, "US", struct.pack("<H", columns), x)
    body += element(0x0028, 0x0030, "DS", b"1\\1 ", x)
    body += element(0x0028, 0x0100, "US", struct.pack("<H", 16), x) + element(0x0028, 0x0101, "US", struct.pack("<H", bits_stored), x)
    body += element(0x0028, 0x0102, "US", struct.pack("<H", 15), x) + element(0x0028, 0x0103, "US", struct.pack("<H", 1), x)
    body += element(0x7FE0, 0x0010, "OW", data, x, pixel_length)
    return meta(syntax) + body


def sequence(items, explicit=True):
    """(0008,1140) ReferencedImageSequence of undefined length with undefined-length items."""
    body = b"".join(struct.pack("<HHI", 0xFFFE, 0xE000, 0xFFFFFFFF) + i + struct.pack("<HHI", 0xFFFE, 0xE00D, 0) for i in items)
    head = struct.pack("<HH", 0x0008, 0x1140) + ((b"SQ\0\0") if explicit else b"")
    return head + struct.pack("<I", 0xFFFFFFFF) + body + struct.pack("<HHI", 0xFFFE, 0xE0DD, 0)
