// sombra — the walk of a DICOM file's data elements before GDCM parses it (volume_io_itk_checks.h,
// check_dicom_file). GDCM (as Debian builds it) asserts, and so aborts the process, on lengths past
// the end of the file and on garbage in compressed pixel data; it accepts pixel data shorter than
// the image. DICOM PS3.5 §7 (data elements), §7.5 (sequences), §A (transfer syntaxes).
#include "scene/volume_io_itk_checks.h"

#include "scene/byte_cursor.h"
#include "scene/input_file.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

namespace sombra::volume_io {
namespace {

using Cursor = detail::ByteCursor;
constexpr std::uint32_t kUndefined = 0xFFFFFFFF;             // an element's undefined length
constexpr std::uint64_t kNoEnd = ~std::uint64_t(0);          // a sequence that ends at its delimiter
constexpr int kMaxDepth = 16;                       // sequences inside sequences
constexpr std::uint64_t kMaxFrames = 65536;
const std::string kImplicitLittle = "1.2.840.10008.1.2", kExplicitLittle = "1.2.840.10008.1.2.1";

struct Tag {
    std::uint16_t group = 0, element = 0;
    bool is(std::uint16_t g, std::uint16_t e) const { return group == g && element == e; }
};

struct Element {
    Tag tag;
    char vr[2] = {' ', ' '};
    std::uint32_t length = 0;
    bool vr_is(const char* v) const { return vr[0] == v[0] && vr[1] == v[1]; }
};

// What the top-level data set says about the image.
struct ImageFields {
    std::uint64_t rows = 0, columns = 0, bits = 0, samples = 1, frames = 1, pixel_bytes = 0;
    std::uint64_t bits_stored = 0, high_bit = 0;  // 0: absent (GDCM then assumes BitsAllocated)
    bool has_bits_stored = false, has_high_bit = false;
    std::string photometric;  // (0028,0004), trimmed; "" when absent
    bool pixels = false;
};

std::string tag_name(Tag t) {
    char s[16];
    std::snprintf(s, sizeof s, "(%04X,%04X)", t.group, t.element);
    return s;
}

bool long_vr(const char vr[2]) {  // VRs with 2 reserved bytes and a 32-bit length (PS3.5 §7.1.2)
    static const char* kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char* v : kLong)
        if (vr[0] == v[0] && vr[1] == v[1]) return true;
    return false;
}

bool known_vr(const char vr[2]) {  // PS3.5 §6.2
    static const char* kVrs[] = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL", "IS", "LO", "LT", "OB", "OD",
                                 "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ", "SS", "ST", "SV", "TM", "UC", "UI",
                                 "UL", "UN", "UR", "US", "UT", "UV"};
    for (const char* v : kVrs)
        if (vr[0] == v[0] && vr[1] == v[1]) return true;
    return false;
}

Element read_element(Cursor& c, bool explicit_vr) {
    Element e;
    e.tag.group = c.get<std::uint16_t>("tag");
    e.tag.element = c.get<std::uint16_t>("tag");
    if (!explicit_vr || e.tag.group == 0xFFFE) {  // items and delimiters carry no VR
        e.length = c.get<std::uint32_t>("length");
        return e;
    }
    c.read(e.vr, 2, "VR");
    if (!known_vr(e.vr))  // GDCM asserts on a VR it does not know
        c.fail(tag_name(e.tag), std::string("'") + e.vr[0] + e.vr[1] + "' is not a DICOM value representation");
    if (long_vr(e.vr)) {
        c.skip(2, "reserved");
        e.length = c.get<std::uint32_t>("length");
    } else {
        e.length = c.get<std::uint16_t>("length");
    }
    return e;
}

void walk_items(Cursor& c, bool explicit_vr, std::uint64_t end, int depth);

// Elements up to `end` (an offset), or up to an item delimiter when `delimited`.
void walk_elements(Cursor& c, bool explicit_vr, std::uint64_t end, int depth, bool delimited, ImageFields* image);

// A value of a defined length: inside its container, and a sequence's items walked.
bool looks_like_sequence(Cursor& c, const Element& e, bool explicit_vr) {
    if (explicit_vr) return e.vr_is("SQ");
    // implicit VR: GDCM reads a value that starts with an item tag as a sequence, so do we
    if (e.length < 8) return false;
    std::uint16_t head[2];
    c.read(head, 4, "value");
    c.rewind(4);
    return head[0] == 0xFFFE && head[1] == 0xE000;
}

std::uint64_t read_us(Cursor& c, const Element& e, const char* name) {
    if (e.length != 2) c.fail(tag_name(e.tag) + " " + name, "a length of " + std::to_string(e.length) + " (expected 2)");
    return c.get<std::uint16_t>(name);
}

// A short string value (CS, IS), its padding trimmed.
std::string read_code(Cursor& c, const Element& e, const char* name) {
    if (e.length > 64) c.fail(tag_name(e.tag) + " " + name, "longer than a code string");
    std::string s(e.length, '\0');
    c.read(s.data(), s.size(), name);
    const std::size_t a = s.find_first_not_of(" \0", 0, 2), b = s.find_last_not_of(" \0", std::string::npos, 2);
    return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::uint64_t read_frames(Cursor& c, const Element& e) {
    if (e.length > 16) c.fail(tag_name(e.tag) + " NumberOfFrames", "longer than an integer string");
    const std::string digits = read_code(c, e, "NumberOfFrames");
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9)
        c.fail("(0028,0008) NumberOfFrames", "'" + digits + "' is not a positive integer");
    return std::stoull(digits);
}

// Elements GDCM's image readers read through gdcm::Attribute, which asserts when the VR (explicit
// files) or a US value's length differs from its dictionary's. Not the whole dictionary (yet).
void check_image_vr(Cursor& c, const Element& e, bool explicit_vr) {
    static const struct { std::uint16_t group, element; const char* vr; } kRead[] = {
        {0x0008, 0x0016, "UI"}, {0x0008, 0x0060, "CS"}, {0x0018, 0x0050, "DS"}, {0x0018, 0x0088, "DS"},
        {0x0020, 0x000D, "UI"}, {0x0020, 0x000E, "UI"}, {0x0020, 0x0013, "IS"}, {0x0020, 0x0032, "DS"},
        {0x0020, 0x0037, "DS"}, {0x0028, 0x0002, "US"}, {0x0028, 0x0004, "CS"}, {0x0028, 0x0006, "US"},
        {0x0028, 0x0008, "IS"}, {0x0028, 0x0010, "US"}, {0x0028, 0x0011, "US"}, {0x0028, 0x0030, "DS"},
        {0x0028, 0x0100, "US"}, {0x0028, 0x0101, "US"}, {0x0028, 0x0102, "US"}, {0x0028, 0x0103, "US"},
        {0x0028, 0x1050, "DS"}, {0x0028, 0x1051, "DS"}, {0x0028, 0x1052, "DS"}, {0x0028, 0x1053, "DS"},
        {0x0028, 0x1054, "LO"},
        // read for the spacing and the frames (gdcm::ImageHelper::GetSpacingValue, the fuzzer's finding)
        {0x0028, 0x0009, "AT"}, {0x0028, 0x0034, "IS"}, {0x0018, 0x1164, "DS"}, {0x0018, 0x2010, "DS"},
        {0x3002, 0x0011, "DS"}, {0x0054, 0x0081, "US"}, {0x0018, 0x602C, "FD"}, {0x0018, 0x602E, "FD"},
        {0x0020, 0x0030, "DS"}, {0x0020, 0x0035, "DS"}};
    for (const auto& k : kRead) {
        if (!e.tag.is(k.group, k.element)) continue;
        if (explicit_vr && !e.vr_is(k.vr))
            c.fail(tag_name(e.tag), std::string("VR ") + e.vr[0] + e.vr[1] + " where DICOM defines " + k.vr);
        if (k.vr[0] == 'U' && k.vr[1] == 'S' && e.length != 2)
            c.fail(tag_name(e.tag), "a US value of " + std::to_string(e.length) + " bytes (expected 2)");
    }
}

// One element of the top-level data set: the image fields read, the rest skipped.
void read_top_level(Cursor& c, const Element& e, ImageFields* image) {
    if (e.tag.is(0x0028, 0x0010)) image->rows = read_us(c, e, "Rows");
    else if (e.tag.is(0x0028, 0x0011)) image->columns = read_us(c, e, "Columns");
    else if (e.tag.is(0x0028, 0x0100)) image->bits = read_us(c, e, "BitsAllocated");
    else if (e.tag.is(0x0028, 0x0002)) image->samples = read_us(c, e, "SamplesPerPixel");
    else if (e.tag.is(0x0028, 0x0008)) image->frames = read_frames(c, e);
    else if (e.tag.is(0x0028, 0x0004)) image->photometric = read_code(c, e, "PhotometricInterpretation");
    else if (e.tag.is(0x0028, 0x0101)) image->bits_stored = read_us(c, e, "BitsStored"), image->has_bits_stored = true;
    else if (e.tag.is(0x0028, 0x0102)) image->high_bit = read_us(c, e, "HighBit"), image->has_high_bit = true;
    else {
        if (e.tag.is(0x7FE0, 0x0010)) image->pixels = true, image->pixel_bytes = e.length;
        c.skip(e.length, "value");
    }
}

void walk_value(Cursor& c, const Element& e, bool explicit_vr, std::uint64_t end, int depth, ImageFields* image) {
    const std::string name = tag_name(e.tag);
    check_image_vr(c, e, explicit_vr);
    if (e.length == kUndefined) {
        if (e.tag.is(0x7FE0, 0x0010))
            c.fail(name + " PixelData", "encapsulated (compressed) pixel data in an uncompressed transfer syntax");
        if (explicit_vr && !e.vr_is("SQ") && !e.vr_is("UN"))
            c.fail(name, std::string("an undefined length for a value of VR ") + e.vr[0] + e.vr[1] + " (only sequences have one)");
        return walk_items(c, explicit_vr, kNoEnd, depth + 1);
    }
    if (e.length > end - c.at())
        c.fail(name, "a length of " + std::to_string(e.length) + " bytes, " + std::to_string(end - c.at()) +
                         " are left in the file or its enclosing item (truncated or corrupt)");
    if (looks_like_sequence(c, e, explicit_vr)) return walk_items(c, explicit_vr, c.at() + e.length, depth + 1);
    if (image) return read_top_level(c, e, image);
    c.skip(e.length, "value");
}

// A data set's elements, in increasing tag order, each once (PS3.5 §7.1): GDCM keeps the first of
// a repeated tag, a walk that read the last would check another value than GDCM uses.
void walk_elements(Cursor& c, bool explicit_vr, std::uint64_t end, int depth, bool delimited, ImageFields* image) {
    std::uint32_t previous = 0;
    for (bool first = true; delimited || c.at() < end; first = false) {
        const Element e = read_element(c, explicit_vr);
        if (e.tag.group == 0xFFFE) {
            if (delimited && e.tag.is(0xFFFE, 0xE00D) && e.length == 0) return;
            c.fail(tag_name(e.tag), "an item or delimiter where a data element belongs");
        }
        const std::uint32_t tag = std::uint32_t(e.tag.group) << 16 | e.tag.element;
        if (!first && tag <= previous)
            c.fail(tag_name(e.tag), "after " + tag_name(Tag{std::uint16_t(previous >> 16), std::uint16_t(previous & 0xFFFF)}) +
                                        ": elements must appear once each, in increasing tag order");
        if (depth == 0 && e.tag.group == 0x0002) c.fail(tag_name(e.tag), "a file meta element inside the data set");
        previous = tag;
        walk_value(c, e, explicit_vr, end, depth, image);
    }
    if (c.at() != end) c.fail("item", "its elements overrun its length");
}

// A sequence's items, up to `end` or (kNoEnd) a sequence delimiter.
void walk_items(Cursor& c, bool explicit_vr, std::uint64_t end, int depth) {
    if (depth > kMaxDepth) c.fail("sequence", "nested more than " + std::to_string(kMaxDepth) + " deep");
    const bool delimited = end == kNoEnd;
    const std::uint64_t limit = delimited ? c.at() + c.left() : end;
    while (delimited || c.at() < end) {
        const Element item = read_element(c, false);
        if (delimited && item.tag.is(0xFFFE, 0xE0DD) && item.length == 0) return;
        if (!item.tag.is(0xFFFE, 0xE000)) c.fail(tag_name(item.tag), "an item tag (FFFE,E000) expected in a sequence");
        if (item.length == kUndefined) {
            walk_elements(c, explicit_vr, limit, depth, true, nullptr);
            continue;
        }
        if (item.length > limit - c.at()) c.fail("sequence item", "a length of " + std::to_string(item.length) + " bytes past its sequence");
        walk_elements(c, explicit_vr, c.at() + item.length, depth, false, nullptr);
    }
    if (c.at() != end) c.fail("sequence", "its items overrun its length");
}

// The file meta information: (0002,0000) group length first, then its group; returns the transfer syntax.
std::string walk_meta(Cursor& c) {
    char magic[4];
    c.skip(128, "preamble");
    c.read(magic, 4, "preamble");
    if (std::memcmp(magic, "DICM", 4) != 0) c.fail("preamble", "not a DICOM Part 10 file (no 'DICM' at byte 128)");
    const Element first = read_element(c, true);
    if (!first.tag.is(0x0002, 0x0000) || !first.vr_is("UL") || first.length != 4)
        c.fail("meta", "the file meta information does not start with its group length (0002,0000)");
    const std::uint32_t length = c.get<std::uint32_t>("meta group length");
    c.need(length, "meta");
    const std::uint64_t end = c.at() + length;
    std::string syntax;
    while (c.at() < end) {
        const Element e = read_element(c, true);
        if (e.tag.group != 0x0002) c.fail(tag_name(e.tag), "a data element inside the file meta information's group length");
        if (e.length > end - c.at()) c.fail(tag_name(e.tag), "a length of " + std::to_string(e.length) + " bytes past the meta group");
        if (!e.tag.is(0x0002, 0x0010)) {
            c.skip(e.length, "value");
            continue;
        }
        syntax.assign(e.length, '\0');
        c.read(syntax.data(), e.length, "TransferSyntaxUID");
        while (!syntax.empty() && (syntax.back() == '\0' || syntax.back() == ' ')) syntax.pop_back();
    }
    return syntax;
}

void check_transfer_syntax(Cursor& c, const std::string& syntax) {
    if (syntax == kImplicitLittle || syntax == kExplicitLittle) return;
    const bool compressed = syntax.rfind("1.2.840.10008.1.2.4.", 0) == 0 || syntax == "1.2.840.10008.1.2.5" ||
                            syntax == "1.2.840.10008.1.2.1.99";
    c.fail("(0002,0010) TransferSyntaxUID",
           "'" + syntax + "'" + (compressed ? " (compressed: JPEG, JPEG-LS, JPEG 2000, RLE or deflate)" : "") +
               ": sombra reads uncompressed DICOM only (implicit or explicit VR little endian)");
}

void check_image(Cursor& c, const ImageFields& f) {
    if (!f.rows || !f.columns) c.fail("(0028,0010) Rows / (0028,0011) Columns", "missing or 0: not an image");
    if (f.bits != 8 && f.bits != 16 && f.bits != 32)
        c.fail("(0028,0100) BitsAllocated", std::to_string(f.bits) + " (sombra reads 8, 16 or 32)");
    if (f.samples != 1) c.fail("(0028,0002) SamplesPerPixel", std::to_string(f.samples) + " (expected 1: grey)");
    // grey values only: a palette's indices are no densities (and GDCM asserts on a missing palette)
    // (GDCM asserts on a missing or empty one: its decoders start from a known interpretation)
    if (f.photometric != "MONOCHROME1" && f.photometric != "MONOCHROME2")
        c.fail("(0028,0004) PhotometricInterpretation",
               (f.photometric.empty() ? std::string("missing or empty") : "'" + f.photometric + "'") +
                   " (sombra reads MONOCHROME1 or MONOCHROME2)");
    if (f.has_bits_stored && (f.bits_stored < 1 || f.bits_stored > f.bits))
        c.fail("(0028,0101) BitsStored", std::to_string(f.bits_stored) + " (1 … BitsAllocated " + std::to_string(f.bits) + ")");
    // GDCM clears unused high bits of 16- and 32-bit pixels only; for 8-bit ones it asserts that all
    // 8 are stored (ImageCodec::DecodeByStreams)
    if (f.has_bits_stored && f.bits == 8 && f.bits_stored != 8)
        c.fail("(0028,0101) BitsStored", std::to_string(f.bits_stored) + " of BitsAllocated 8 (8-bit pixels must store all 8 bits)");
    if (f.has_high_bit && f.high_bit >= f.bits)
        c.fail("(0028,0102) HighBit", std::to_string(f.high_bit) + " (below BitsAllocated " + std::to_string(f.bits) + ")");
    if (f.frames < 1 || f.frames > kMaxFrames)
        c.fail("(0028,0008) NumberOfFrames", std::to_string(f.frames) + " (1 … " + std::to_string(kMaxFrames) + ")");
    if (!f.pixels) c.fail("(7FE0,0010) PixelData", "missing");
    const std::uint64_t need = f.rows * f.columns * f.frames * (f.bits / 8);
    if (f.pixel_bytes < need)
        c.fail("(7FE0,0010) PixelData", std::to_string(f.pixel_bytes) + " bytes, the image needs " + std::to_string(need) +
                                            " (" + std::to_string(f.rows) + " rows x " + std::to_string(f.columns) +
                                            " columns x " + std::to_string(f.frames) + " frames x " +
                                            std::to_string(f.bits / 8) + " bytes)");
}

bool has_part10_magic(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    char head[132] = {};
    in.read(head, sizeof head);
    return in.gcount() == 132 && std::memcmp(head + 128, "DICM", 4) == 0;
}

}  // namespace

void check_dicom_file(const std::string& path, bool part10_only) {
    Cursor c(path, detail::regular_file_size(path));
    if (part10_only && !has_part10_magic(path)) return;
    const std::string syntax = walk_meta(c);
    check_transfer_syntax(c, syntax);
    ImageFields image;
    walk_elements(c, syntax == kExplicitLittle, c.at() + c.left(), 0, false, &image);
    check_image(c, image);
}

}  // namespace sombra::volume_io
