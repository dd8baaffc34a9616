// sombra — legacy VTK files holding STRUCTURED_POINTS with one scalar point array
// (ASCII, or BINARY which is big-endian).
#include "scene/volume_io_common.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <map>
#include <sstream>

namespace sombra::volume_io {
namespace {

// Walks the file line by line; the binary payload starts right after the header's last line.
class Lines {
public:
    Lines(const std::string& path, const std::vector<unsigned char>& bytes) : path_(path), b_(bytes) {}

    // Next line split into words (words[0] upper-cased); blank lines are skipped when asked.
    std::vector<std::string> words(const char* expected, bool skip_blank = true) {
        for (;;) {
            if (pos_ >= b_.size()) throw file_error(path_, expected, "missing (unexpected end of file)");
            std::string line = next_line();
            std::istringstream in(line);
            std::vector<std::string> w;
            for (std::string t; in >> t;) w.push_back(t);
            if (w.empty() && skip_blank) continue;
            if (!w.empty()) std::transform(w[0].begin(), w[0].end(), w[0].begin(),
                                          [](unsigned char c) { return char(std::toupper(c)); });
            return w;
        }
    }
    std::string next_line() {
        const std::size_t start = pos_;
        while (pos_ < b_.size() && b_[pos_] != '\n') ++pos_;
        std::string line(b_.begin() + start, b_.begin() + pos_);
        if (pos_ < b_.size()) ++pos_;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        return line;
    }
    std::size_t pos() const { return pos_; }
    void rewind(std::size_t pos) { pos_ = pos; }

private:
    const std::string& path_;
    const std::vector<unsigned char>& b_;
    std::size_t pos_ = 0;
};

ScalarType vtk_type(const std::string& path, const std::string& name) {
    static const std::map<std::string, ScalarType> types = {
        {"unsigned_char", ScalarType::u8}, {"char", ScalarType::i8},          {"short", ScalarType::i16},
        {"unsigned_short", ScalarType::u16}, {"int", ScalarType::i32},        {"unsigned_int", ScalarType::u32},
        {"float", ScalarType::f32},        {"double", ScalarType::f64}};
    const auto it = types.find(name);
    if (it == types.end()) throw file_error(path, "SCALARS", "unsupported data type '" + name + "'");
    return it->second;
}

std::vector<float> parse_ascii(const std::string& path, const std::vector<unsigned char>& bytes, std::size_t pos,
                               std::size_t count) {
    std::string text(bytes.begin() + pos, bytes.end());
    std::vector<float> out(count);
    const char* p = text.c_str();
    for (std::size_t i = 0; i < count; ++i) {
        char* end = nullptr;
        out[i] = std::strtof(p, &end);
        if (end == p) {
            while (std::isspace(static_cast<unsigned char>(*p))) ++p;
            throw file_error(path, "data", *p ? "value " + std::to_string(i) + " is not a number"
                                              : "expected " + std::to_string(count) + " values, found " + std::to_string(i));
        }
        p = end;
    }
    return out;
}

}  // namespace

Volume read_vtk(const std::string& path) {
    const std::vector<unsigned char> bytes = read_file(path);
    Lines lines(path, bytes);
    if (lines.next_line().rfind("# vtk DataFile Version", 0) != 0) throw file_error(path, "header", "not a legacy VTK file");
    lines.next_line();  // title
    const std::vector<std::string> mode = lines.words("ASCII/BINARY");
    const bool binary = mode.size() == 1 && mode[0] == "BINARY";
    if (!binary && !(mode.size() == 1 && mode[0] == "ASCII"))
        throw file_error(path, "format", "expected ASCII or BINARY on line 3");
    const std::vector<std::string> dataset = lines.words("DATASET");
    if (dataset.size() != 2 || dataset[0] != "DATASET" || dataset[1] != "STRUCTURED_POINTS")
        throw file_error(path, "DATASET", "only DATASET STRUCTURED_POINTS is supported");

    Volume volume;
    std::array<long long, 3> dims{0, 0, 0};
    bool have_dims = false;
    std::vector<std::string> w = lines.words("POINT_DATA");
    for (; w[0] != "POINT_DATA"; w = lines.words("POINT_DATA")) {
        if (w[0] != "DIMENSIONS" && w[0] != "SPACING" && w[0] != "ASPECT_RATIO" && w[0] != "ORIGIN")
            throw file_error(path, w[0], "unexpected keyword before POINT_DATA");
        if (w.size() != 4) throw file_error(path, w[0], "expected 3 values");
        for (int a = 0; a < 3; ++a) {
            if (w[0] == "DIMENSIONS") dims[a] = parse_int(path, w[0], w[a + 1]);
            if (w[0] == "SPACING" || w[0] == "ASPECT_RATIO") {
                const double s = parse_number(path, w[0], w[a + 1]);
                if (s <= 0) throw file_error(path, w[0], "voxel size must be > 0");
                volume.spacing[a] = float(s);
            }
        }
        have_dims |= w[0] == "DIMENSIONS";
    }
    if (!have_dims) throw file_error(path, "DIMENSIONS", "missing before POINT_DATA");
    const std::size_t count = checked_voxel_count(path, dims);
    if (w.size() != 2 || parse_int(path, "POINT_DATA", w[1]) != static_cast<long long>(count))
        throw file_error(path, "POINT_DATA", "point count must equal the DIMENSIONS product " + std::to_string(count));

    w = lines.words("SCALARS");
    if (w[0] != "SCALARS" || w.size() < 3 || w.size() > 4)
        throw file_error(path, "SCALARS", "expected 'SCALARS name type [1]' after POINT_DATA");
    if (w.size() == 4 && parse_int(path, "SCALARS", w[3]) != 1)
        throw file_error(path, "SCALARS", "only one component per point is supported");
    const ScalarType type = vtk_type(path, w[2]);
    const std::size_t after_scalars = lines.pos();
    if (after_scalars < bytes.size()) {  // LOOKUP_TABLE is optional
        const std::vector<std::string> table = lines.words("LOOKUP_TABLE", !binary);
        if (table.empty() || table[0] != "LOOKUP_TABLE") lines.rewind(after_scalars);
    }

    volume.dims = {int(dims[0]), int(dims[1]), int(dims[2])};
    volume.stored_type = type_name(type);
    if (binary) {
        const std::size_t needed = count * type_size(type), available = bytes.size() - lines.pos();
        if (available < needed) check_exact_size(path, "data", needed, available);  // throws "truncated"
        volume.voxels = to_float(bytes.data() + lines.pos(), count, type, Endian::big);
    } else {
        // n ASCII values need at least 2n - 1 bytes (digits and separators): check before allocating
        const std::size_t available = bytes.size() - lines.pos();
        if (available < 2 * count - 1)
            throw file_error(path, "data", "truncated: " + std::to_string(count) + " ASCII values need at least " +
                                               std::to_string(2 * count - 1) + " bytes, found " + std::to_string(available));
        volume.voxels = parse_ascii(path, bytes, lines.pos(), count);
    }
    volume.source = path;
    return volume;
}

}  // namespace sombra::volume_io
