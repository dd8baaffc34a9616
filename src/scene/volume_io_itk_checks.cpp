// sombra — what the ITK-read formats declare, checked by us before ITK (or libtiff, MetaIO, teem)
// sees the file (docs/hostile-input.md "Every reader is ours to bound"):
//  - NRRD and MetaImage headers: the dimension count, the geometry fields (finite, non-zero),
//    and the data files a detached header names (one file, a LIST, or a printf pattern): each
//    resolved against the header's folder and opened by the same rules as every input (regular
//    files only: never a FIFO or a device), their sizes summed so the voxel count can be checked
//    against the bytes that really exist;
//  - TIFF: the chain of image directories walked by hand, so a loop, an offset past the end or
//    pages of different sizes or sample layouts are refused instead of hanging or being cropped.
// No ITK header here (they cost ~20 s of compile time): plain text and bytes.
#include "scene/volume_io_itk_checks.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "scene/input_file.h"

namespace sombra::volume_io {
namespace {

constexpr std::size_t kMaxDataFiles = 65536;    // files of a LIST or pattern (one per slice)
constexpr std::size_t kMaxHeaderLines = 4096;   // lines read before the header must have ended
constexpr std::uint64_t kMaxTiffPages = 65536;  // image directories followed in a TIFF

std::string trim(const std::string& text) {
    std::size_t a = 0, b = text.size();
    while (a < b && std::isspace(static_cast<unsigned char>(text[a]))) ++a;
    while (b > a && std::isspace(static_cast<unsigned char>(text[b - 1]))) --b;
    return text.substr(a, b - a);
}

std::vector<std::string> tokens(const std::string& text) {
    std::istringstream in(text);
    std::vector<std::string> out;
    for (std::string t; in >> t;) out.push_back(t);
    return out;
}

std::string lower(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return text;
}

// A printf pattern with exactly one integer conversion (%d, %03d, %i, %u …) and no other '%'
// but "%%": the only patterns the formats define; anything else could read past the argument list.
bool safe_integer_pattern(const std::string& pattern) {
    int conversions = 0;
    for (std::size_t i = 0; i < pattern.size(); ++i) {
        if (pattern[i] != '%') continue;
        if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
            ++i;
            continue;
        }
        std::size_t k = i + 1;
        while (k < pattern.size() && (std::isdigit(static_cast<unsigned char>(pattern[k])) || pattern[k] == '0')) ++k;
        if (k >= pattern.size() || (pattern[k] != 'd' && pattern[k] != 'i' && pattern[k] != 'u') || k - i > 4) return false;
        ++conversions;
        i = k;
    }
    return conversions == 1;
}

// The data files of "data file:" (NRRD) or "ElementDataFile =" (MetaImage) after the key: a
// name, "LIST" (names on the lines after the header: `rest`), or "PATTERN MIN MAX STEP".
std::vector<std::string> data_file_names(const std::string& header, const std::string& field, const std::string& value,
                                         std::istream& rest) {
    const std::vector<std::string> words = tokens(value);
    if (words.empty()) throw file_error(header, field, "names no data file");
    if (words[0] == "LIST") {
        std::vector<std::string> names;
        for (std::string line; std::getline(rest, line);) {
            line = trim(line);
            if (line.empty()) continue;
            if (names.size() == kMaxDataFiles)
                throw file_error(header, field, "LIST names more than " + std::to_string(kMaxDataFiles) + " files");
            names.push_back(line);
        }
        if (names.empty()) throw file_error(header, field, "LIST names no file");
        return names;
    }
    if (words.size() >= 4 && words[0].find('%') != std::string::npos) {
        if (!safe_integer_pattern(words[0]))
            throw file_error(header, field, "pattern '" + words[0] + "' must hold one integer conversion such as %03d");
        const long long first = parse_int(header, field, words[1]), last = parse_int(header, field, words[2]),
                        step = parse_int(header, field, words[3]);
        if (step == 0 || (last - first) / step < 0)
            throw file_error(header, field, "pattern range " + words[1] + " … " + words[2] + " step " + words[3] + " is empty");
        const long long count = (last - first) / step + 1;
        if (count > static_cast<long long>(kMaxDataFiles))
            throw file_error(header, field, "pattern names " + std::to_string(count) + " files, more than " +
                                                std::to_string(kMaxDataFiles));
        std::vector<std::string> names;
        for (long long i = 0; i < count; ++i) {
            char name[4096];
            const int n = std::snprintf(name, sizeof name, words[0].c_str(), first + i * step);
            if (n < 0 || n >= int(sizeof name)) throw file_error(header, field, "pattern gives a name too long");
            names.emplace_back(name);
        }
        return names;
    }
    return {trim(value)};
}

// Each data file resolved against the header's folder and opened as an input; their total size.
std::uint64_t data_file_bytes(const std::string& header, const std::string& field, const std::vector<std::string>& names) {
    const std::filesystem::path folder = std::filesystem::path(header).parent_path();
    std::uint64_t total = 0;
    for (const std::string& name : names) {
        const std::filesystem::path p(name);
        const std::string resolved = (p.is_absolute() ? p : folder / p).string();
        try {
            total += detail::regular_file_size(resolved);
        } catch (const Error& e) {
            throw file_error(header, field, "data file " + name + ": " + one_line(e.what()));
        }
    }
    return total;
}

// "(a,b,c)" → three finite numbers; "none" → nothing. NRRD's vector syntax.
bool nrrd_vector(const std::string& header, const std::string& field, const std::string& word, std::array<double, 3>* v) {
    if (word == "none") return false;
    if (word.size() < 2 || word.front() != '(' || word.back() != ')')
        throw file_error(header, field, "expected vectors such as (1,0,0), got '" + word + "'");
    std::string inner = word.substr(1, word.size() - 2);
    std::replace(inner.begin(), inner.end(), ',', ' ');
    const std::vector<std::string> parts = tokens(inner);
    if (parts.size() != 3) throw file_error(header, field, "expected 3 components, got '" + word + "'");
    for (int i = 0; i < 3; ++i) (*v)[std::size_t(i)] = parse_number(header, field, parts[std::size_t(i)]);
    return true;
}

void check_length(const std::string& header, const std::string& field, double length, int axis) {
    if (!(std::isfinite(length) && length >= double(limits::kMinLength) && length <= 1e18))
        throw file_error(header, field, "voxel size along axis " + std::to_string(axis) + " is " +
                                            (std::isfinite(length) ? std::to_string(length) : std::string("not finite")) +
                                            " (must be > 0 and finite)");
}

// Reads a NRRD header's "field: value" lines from `in` (comments and "key:=value" pairs skipped,
// keys lower-case) up to the blank line that ends an attached header, handing each to `field`,
// which returns false to stop. Returns whether the blank line was reached.
template <typename Field>
bool read_nrrd_fields(std::istream& in, Field&& field) {
    std::string line;
    for (std::size_t n = 0; n < kMaxHeaderLines && std::getline(in, line); ++n) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) return true;  // the end of the header
        if (line[0] == '#' || line.find(":=") != std::string::npos) continue;  // comments, key/value pairs
        const std::size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        if (!field(lower(trim(line.substr(0, colon))), trim(line.substr(colon + 1)))) return false;
    }
    return false;
}

std::uint64_t check_nrrd(const std::string& header, std::uint64_t header_bytes) {
    std::ifstream in(header, std::ios::binary);
    std::vector<std::string> names;
    bool detached = false;
    read_nrrd_fields(in, [&](const std::string& key, const std::string& value) {
        if (key == "dimension") {
            const long long d = parse_int(header, "dimension", value);
            if (d < 1 || d > 4) throw file_error(header, "dimension", std::to_string(d) + " (must be 1 … 4)");
        } else if (key == "space directions") {
            int axis = 0;
            for (const std::string& word : tokens(value)) {
                std::array<double, 3> v{};
                if (nrrd_vector(header, key, word, &v)) check_length(header, key, std::hypot(v[0], v[1], v[2]), axis);
                ++axis;
            }
        } else if (key == "spacings") {
            int axis = 0;
            for (const std::string& word : tokens(value)) {
                if (lower(word) != "nan") check_length(header, key, std::fabs(parse_number(header, key, word)), axis);
                ++axis;
            }
        } else if (key == "data file" || key == "datafile") {
            names = data_file_names(header, key, value, in);
            detached = true;
            if (tokens(value).front() == "LIST") return false;  // the names took the rest of the file
        }
        return true;
    });
    return detached ? data_file_bytes(header, "data file", names) : header_bytes;
}

// A MetaImage header as MetaIO reads it: "Key = value" lines of text up to ElementDataFile.
// MetaIO compares keys as C strings, so a NUL inside a line hides the rest of the key from it but
// not from us: the header must be printable text. NDims comes before the fields sized by it and
// DimSize (and ElementSpacing / ElementSize) hold exactly NDims values: MetaIO sizes its reads by
// its own reading of them, ITK its buffer by its, and where they differed MetaIO wrote past the
// buffer (found by fuzzing).
std::uint64_t check_metaimage(const std::string& header, std::uint64_t header_bytes) {
    std::ifstream in(header, std::ios::binary);
    std::string line;
    long long ndims = 0;
    bool dims_seen = false;
    const auto count_values = [&](const std::string& key, const std::string& value) {
        if (ndims == 0) throw file_error(header, key, "comes before NDims");
        const std::size_t n = tokens(value).size();
        if (n != std::size_t(ndims))
            throw file_error(header, key, std::to_string(n) + " values for NDims = " + std::to_string(ndims));
    };
    for (std::size_t n = 0; n < kMaxHeaderLines && std::getline(in, line); ++n) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        for (unsigned char c : line)
            if (c < 0x20 && c != '\t')
                throw file_error(header, "header", "line " + std::to_string(n + 1) + " is not text (a control byte)");
        if (trim(line).empty()) continue;
        // "Key = value" with Key an identifier of at most 64 characters and the value at most 250
        // (MetaIO copies keys and string values into 255-byte buffers unchecked: longer ones
        // aborted the process)
        const std::size_t eq = line.find('=');
        const std::string key = trim(line.substr(0, eq == std::string::npos ? 0 : eq));
        const bool identifier = !key.empty() && key.size() <= 64 && !std::isdigit(static_cast<unsigned char>(key[0])) &&
                                std::all_of(key.begin(), key.end(), [](unsigned char c) { return std::isalnum(c) || c == '_'; });
        if (eq == std::string::npos || !identifier)
            throw file_error(header, "header", "line " + std::to_string(n + 1) + " is not 'Key = value'");
        const std::string value = trim(line.substr(eq + 1));
        if (value.size() > 250) throw file_error(header, key, "value longer than 250 characters");
        if (key == "NDims") {
            ndims = parse_int(header, "NDims", value);
            if (ndims < 1 || ndims > 4) throw file_error(header, "NDims", std::to_string(ndims) + " (must be 1 … 4)");
        } else if (key == "DimSize") {
            count_values(key, value);
            for (const std::string& word : tokens(value))
                if (parse_int(header, key, word) < 1) throw file_error(header, key, "sizes must be ≥ 1, got " + word);
            dims_seen = true;
        } else if (key == "ElementSpacing" || key == "ElementSize") {
            count_values(key, value);
            int axis = 0;
            for (const std::string& word : tokens(value)) check_length(header, key, std::fabs(parse_number(header, key, word)), axis++);
        } else if (key == "ElementDataFile") {  // the last field: the data (or the LIST) follows
            if (!dims_seen) throw file_error(header, "DimSize", "missing");
            if (value == "LOCAL") return header_bytes;
            return data_file_bytes(header, key, data_file_names(header, key, value, in));
        }
    }
    throw file_error(header, "ElementDataFile", "missing (a MetaImage header ends with it)");
}

// ---- TIFF: the image file directories (TIFF 6.0 §2; BigTIFF) ----

class TiffBytes {
public:
    TiffBytes(const std::string& path, std::uint64_t size) : path_(path), size_(size), in_(path, std::ios::binary) {}
    std::uint64_t size() const { return size_; }
    // n ≤ 8 bytes at `offset` in the file's byte order; throws when they lie past the end.
    std::uint64_t read(std::uint64_t offset, int n, const char* what) {
        unsigned char b[8] = {};
        if (offset > size_ || std::uint64_t(n) > size_ - offset)
            throw file_error(path_, "pages", std::string(what) + " at byte " + std::to_string(offset) + " lies past the end of the file");
        in_.seekg(std::streamoff(offset));
        in_.read(reinterpret_cast<char*>(b), n);
        if (in_.gcount() != n) throw file_error(path_, "pages", std::string("cannot read ") + what);
        return value_at(b, n);
    }
    // `count` values of n bytes from `offset` (inside the file, as the caller checked), in one read.
    std::vector<std::uint64_t> read_values(std::uint64_t offset, std::uint64_t count, int n, const char* what) {
        std::vector<unsigned char> b(count * std::uint64_t(n));
        if (offset > size_ || b.size() > size_ - offset)
            throw file_error(path_, "pages", std::string(what) + " at byte " + std::to_string(offset) + " lie past the end of the file");
        in_.seekg(std::streamoff(offset));
        in_.read(reinterpret_cast<char*>(b.data()), std::streamsize(b.size()));
        if (std::uint64_t(in_.gcount()) != b.size()) throw file_error(path_, "pages", std::string("cannot read ") + what);
        std::vector<std::uint64_t> values(count);
        for (std::uint64_t k = 0; k < count; ++k) values[k] = value_at(b.data() + k * std::uint64_t(n), n);
        return values;
    }
    void set_little(bool little) { little_ = little; }

private:
    // n bytes in the file's byte order
    std::uint64_t value_at(const unsigned char* b, int n) const {
        std::uint64_t v = 0;
        for (int i = 0; i < n; ++i) v |= std::uint64_t(b[little_ ? i : n - 1 - i]) << (8 * i);
        return v;
    }

    std::string path_;
    std::uint64_t size_;
    std::ifstream in_;
    bool little_ = true;
};

// What every page must share: ImageWidth, ImageLength, BitsPerSample, SamplesPerPixel,
// SampleFormat (the value field as stored: inline value or offset of the list).
struct TiffPage {
    std::uint64_t width = 0, length = 0, bits = 1, samples = 1, format = 1;
    bool operator==(const TiffPage& o) const {
        return width == o.width && length == o.length && bits == o.bits && samples == o.samples && format == o.format;
    }
    std::string describe() const {
        return std::to_string(width) + "×" + std::to_string(length) + ", " + std::to_string(samples) + " sample(s) of " +
               std::to_string(bits) + " bits, format " + std::to_string(format);
    }
};

// Whether a baseline or extension tag that ITK's tag reader takes as a given type has one it can
// take (TIFF 6.0 §8, §18–19): ITK copies ASCII tags as text and the numeric ones as SHORT or LONG;
// a DateTime stored as SHORT made it copy 20 bytes out of a 2-byte buffer. Other tags: any type.
bool tiff_type_allowed(std::uint64_t tag, std::uint64_t type) {
    const bool ascii = type == 2, short_or_long = type == 3 || type == 4, offsets = short_or_long || type == 16;
    switch (tag) {
        case 269: case 270: case 271: case 272: case 285: case 305: case 306: case 315: case 316: case 33432:
            return ascii;  // DocumentName … DateTime, Artist, HostComputer, Copyright
        case 256: case 257: case 278: case 322: case 323:  // sizes, RowsPerStrip, tile sizes
            return short_or_long;
        case 273: case 279: case 324: case 325:  // strip and tile offsets and byte counts
            return offsets;
        case 258: case 259: case 262: case 266: case 274: case 277: case 284: case 296: case 297: case 317:
        case 320: case 338: case 339: case 530:  // BitsPerSample … YCbCrSubSampling
            return type == 3;
        case 282: case 283: case 318: case 319: case 529: case 532:  // resolutions, chromaticities
            return type == 5;
        default:
            return true;
    }
}

// Bytes per value of a TIFF field type (TIFF 6.0 §2, BigTIFF's 16–18); unknown types count 1.
std::uint64_t tiff_type_bytes(std::uint64_t type) {
    switch (type) {
        case 3: case 8: return 2;                     // SHORT, SSHORT
        case 4: case 9: case 11: case 13: return 4;   // LONG, SLONG, FLOAT, IFD
        case 5: case 10: case 12: case 16: case 17: case 18: return 8;  // RATIONAL, SRATIONAL, DOUBLE, LONG8, SLONG8, IFD8
        default: return 1;                            // BYTE, ASCII, SBYTE, UNDEFINED, …
    }
}

}  // namespace

std::uint64_t check_detached_header(const std::string& header, bool nrrd) {
    const std::uint64_t bytes = detail::regular_file_size(header);
    return nrrd ? check_nrrd(header, bytes) : check_metaimage(header, bytes);
}

std::optional<NrrdDataLocation> nrrd_data_location(const std::string& header) {
    std::ifstream in(header, std::ios::binary);
    if (!in) throw file_error(header, "", "cannot open");
    NrrdDataLocation where;
    std::string encoding = "raw";
    long long line_skip = 0;
    bool detached = false, several_files = false;
    const bool ended = read_nrrd_fields(in, [&](const std::string& key, const std::string& value) {
        if (key == "encoding") encoding = lower(value);
        else if (key == "line skip" || key == "lineskip") line_skip = parse_int(header, key, value);
        else if (key == "byte skip" || key == "byteskip") where.byte_skip = parse_int(header, key, value);
        else if (key == "data file" || key == "datafile") {
            const std::vector<std::string> words = tokens(value);
            several_files = words.empty() || words[0] == "LIST" || words.size() > 1;
            if (several_files) return false;
            const std::filesystem::path p(words[0]);
            where.data_file = (p.is_absolute() ? p : std::filesystem::path(header).parent_path() / p).string();
            detached = true;
        }
        return true;
    });
    if (several_files) return std::nullopt;
    if (encoding == "gzip" || encoding == "gz") where.gzip = true;
    else if (encoding != "raw") return std::nullopt;  // ascii, hex, bzip2: read whole
    if (line_skip < 0) throw file_error(header, "line skip", std::to_string(line_skip) + " (must be ≥ 0)");
    if (where.byte_skip < -1 || (where.gzip && where.byte_skip < 0))
        throw file_error(header, "byte skip", std::to_string(where.byte_skip) + (where.gzip ? " (must be ≥ 0 with gzip)" : " (must be ≥ −1)"));
    if (!detached) {
        if (!ended) throw file_error(header, "header", "no blank line ends the header and no data file is named");
        where.data_file = header;
        where.start = std::uint64_t(in.tellg());  // just after the blank line
    }
    if (line_skip > 0) {  // lines of text before the data
        std::ifstream data(where.data_file, std::ios::binary);
        data.seekg(std::streamoff(where.start));
        for (long long skipped = 0; skipped < line_skip;) {
            const int c = data.get();
            if (c == std::char_traits<char>::eof())
                throw file_error(header, "line skip", "'" + where.data_file + "' ends after " + std::to_string(skipped) +
                                                          " of " + std::to_string(line_skip) + " lines");
            ++where.start;
            if (c == '\n') ++skipped;
        }
    }
    return where;
}

void check_tiff_pages(const std::string& path, std::uint64_t max_voxels) {
    TiffBytes f(path, detail::regular_file_size(path));
    const std::uint64_t order = f.read(0, 2, "the byte-order mark");
    if (order != 0x4949 && order != 0x4d4d) throw file_error(path, "header", "not a TIFF file (no II or MM byte-order mark)");
    f.set_little(order == 0x4949);
    const std::uint64_t version = f.read(2, 2, "the version");
    const bool big = version == 43;
    if (version != 42 && !big) throw file_error(path, "header", "not a TIFF file (version " + std::to_string(version) + ")");
    const int offset_bytes = big ? 8 : 4, count_bytes = big ? 8 : 2, entry_bytes = big ? 20 : 12;
    std::uint64_t next = f.read(big ? 8 : 4, offset_bytes, "the first page's offset");
    std::set<std::uint64_t> seen;
    TiffPage first;
    for (std::uint64_t page = 0; next != 0; ++page) {
        if (page == kMaxTiffPages) throw file_error(path, "pages", "more than " + std::to_string(kMaxTiffPages) + " pages");
        if (!seen.insert(next).second)
            throw file_error(path, "pages", "page " + std::to_string(page) + " points back to an earlier page (a loop)");
        const std::uint64_t entries = f.read(next, count_bytes, "a page's entry count");
        if (entries > (f.size() - next) / std::uint64_t(entry_bytes))
            throw file_error(path, "pages", "page " + std::to_string(page) + " declares " + std::to_string(entries) +
                                                " entries, more than the file holds");
        TiffPage p;
        // one entry per tag (TIFF 6.0 §2): of a BitsPerSample given twice, libtiff and ITK took different ones
        std::set<std::uint64_t> tags;
        std::uint64_t offsets = 0, byte_counts = 0, compression = 1;  // strips or tiles, and how they are packed
        std::uint64_t offsets_at = 0, offsets_size = 0, counts_at = 0, counts_size = 0;  // where their values are
        for (std::uint64_t e = 0; e < entries; ++e) {
            const std::uint64_t at = next + std::uint64_t(count_bytes) + e * std::uint64_t(entry_bytes);
            const std::uint64_t tag = f.read(at, 2, "a tag"), type = f.read(at + 2, 2, "a tag type");
            if (!tags.insert(tag).second)
                throw file_error(path, "pages", "page " + std::to_string(page) + " gives tag " + std::to_string(tag) + " twice");
            if (!tiff_type_allowed(tag, type))
                throw file_error(path, "pages", "page " + std::to_string(page) + " tag " + std::to_string(tag) +
                                                    " has type " + std::to_string(type) + ", which TIFF 6.0 does not allow for it");
            const std::uint64_t count = f.read(at + 4, big ? 8 : 4, "a tag's count");
            // the tag's data: inline, or at an offset, and then wholly inside the file (libtiff
            // allocates count × size before it reads: a count of 10⁹ asked it for gigabytes)
            const std::uint64_t size = tiff_type_bytes(type);
            if (count > f.size() / size)
                throw file_error(path, "pages", "page " + std::to_string(page) + " tag " + std::to_string(tag) + " holds " +
                                                    std::to_string(count) + " values, more than the file");
            std::uint64_t data_at = at + 4 + std::uint64_t(big ? 8 : 4);  // inline values
            if (count * size > std::uint64_t(offset_bytes)) {
                data_at = f.read(data_at, offset_bytes, "a tag's offset");
                if (data_at > f.size() || count * size > f.size() - data_at)
                    throw file_error(path, "pages", "page " + std::to_string(page) + " tag " + std::to_string(tag) +
                                                        ": its values lie past the end of the file");
            }
            // ASCII values end in NUL (TIFF 6.0 §2): ITK's tag reader runs strlen over them
            if (type == 2 && count > 0 && f.read(data_at + count - 1, 1, "a tag's text") != 0)
                throw file_error(path, "pages", "page " + std::to_string(page) + " tag " + std::to_string(tag) +
                                                    ": text not terminated by NUL");
            if (type == 2 && count == 0)
                throw file_error(path, "pages", "page " + std::to_string(page) + " tag " + std::to_string(tag) + ": empty text");
            const int value_bytes = type == 3 ? 2 : type == 4 ? 4 : type == 16 ? 8 : offset_bytes;  // SHORT, LONG, LONG8
            std::uint64_t value = f.read(at + 4 + std::uint64_t(big ? 8 : 4), value_bytes, "a tag value");
            if (count != 1) value = (std::uint64_t(1) << 63) | count;  // a list (one per sample): compared by its length
            if (tag == 273 || tag == 324) offsets = count, offsets_at = data_at, offsets_size = size;
            else if (tag == 279 || tag == 325) byte_counts = count, counts_at = data_at, counts_size = size;
            else if (tag == 259) compression = value;
            if (tag == 256) p.width = value;
            else if (tag == 257) p.length = value;
            else if (tag == 258) p.bits = value;
            else if (tag == 277) p.samples = value;
            else if (tag == 339) p.format = value;
        }
        // where the pixels are: libtiff read a page without StripOffsets through a null table; and
        // only the lossless codecs of baseline TIFF and its common extensions (none, LZW, Deflate,
        // PackBits), not old-style JPEG and the rest, whose decoders fuzzers keep breaking
        if (offsets == 0 || offsets != byte_counts)
            throw file_error(path, "pages", "page " + std::to_string(page) + " has " + std::to_string(offsets) + " strip offsets and " +
                                                std::to_string(byte_counts) + " byte counts (needs as many, at least one)");
        // every strip inside the file: a stack cut in its last page's pixels keeps every directory
        // (writers that put a page's directory before its pixels), and libtiff then failed mid-read
        const std::vector<std::uint64_t> starts = f.read_values(offsets_at, offsets, int(offsets_size), "the strip offsets");
        const std::vector<std::uint64_t> lengths = f.read_values(counts_at, byte_counts, int(counts_size), "the strip byte counts");
        for (std::uint64_t i = 0; i < offsets; ++i) {
            const std::uint64_t at = starts[i], bytes = lengths[i];
            if (at > f.size() || bytes > f.size() - at)
                throw file_error(path, "pages", "page " + std::to_string(page) + " strip " + std::to_string(i) + ": its " +
                                                    std::to_string(bytes) + " bytes at byte " + std::to_string(at) +
                                                    " lie past the end of the file (" + std::to_string(f.size()) +
                                                    " bytes): the file is cut short");
        }
        if (compression != 1 && compression != 5 && compression != 8 && compression != 32773 && compression != 32946)
            throw file_error(path, "pages", "page " + std::to_string(page) + " has compression " + std::to_string(compression) +
                                                " (sombra reads none, LZW, Deflate and PackBits)");
        // grey: ITK sized its scanline buffers by SamplesPerPixel (30,977 of them asked for gigabytes)
        if (p.samples != 1)
            throw file_error(path, "pages", "page " + std::to_string(page) + " has " + std::to_string(p.samples & ~(std::uint64_t(1) << 63)) +
                                                " samples per pixel (colour or vector data); expected one (grey)");
        // sizes within the voxel limit before libtiff sizes its strip tables by them (an ImageLength of
        // 4·10⁹ had it allocate one entry per strip of 2 rows)
        if (p.width == 0 || p.length == 0 || p.width > max_voxels || p.length > max_voxels ||
            p.width * p.length > max_voxels / (page + 1))
            throw file_error(path, "pages", "page " + std::to_string(page) + " is " + p.describe() + ": " +
                                                std::to_string(page + 1) + " such pages pass the limit of " +
                                                std::to_string(max_voxels) + " voxels (or a size is 0)");
        if (page == 0) first = p;
        else if (!(p == first))
            throw file_error(path, "pages", "page " + std::to_string(page) + " is " + p.describe() + ", page 0 " +
                                                first.describe() + ": every page of a stack must match");
        next = f.read(next + std::uint64_t(count_bytes) + entries * std::uint64_t(entry_bytes), offset_bytes, "the next page's offset");
    }
    if (seen.empty()) throw file_error(path, "pages", "no page");
}

}  // namespace sombra::volume_io
