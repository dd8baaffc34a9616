// sombra — NumPy .npy arrays and .npz archives holding exactly one array.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"

#include <zip.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <map>
#include <memory>

namespace sombra::volume_io {
namespace {

// The header is a Python dict literal: {'descr': '<f4', 'fortran_order': False, 'shape': (z, y, x), }
class DictParser {
public:
    DictParser(const std::string& name, const std::string& text) : name_(name), s_(text) {}

    std::map<std::string, std::string> parse() {  // key -> value text (strings unquoted)
        std::map<std::string, std::string> out;
        expect('{');
        while (skip_space(), peek() != '}') {
            const std::string key = quoted();
            expect(':');
            skip_space();
            out[key] = peek() == '\'' || peek() == '"' ? quoted() : raw_value();
            skip_space();
            if (peek() == ',') ++i_;
            else if (peek() != '}') fail("expected ',' or '}' after '" + key + "'");
        }
        return out;
    }

private:
    char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
    void skip_space() { while (std::isspace(static_cast<unsigned char>(peek()))) ++i_; }
    [[noreturn]] void fail(const std::string& what) const { throw file_error(name_, "header", what); }
    void expect(char c) {
        skip_space();
        if (peek() != c) fail(std::string("expected '") + c + "' in the header dictionary");
        ++i_;
    }
    std::string quoted() {
        skip_space();
        const char q = peek();
        if (q != '\'' && q != '"') fail("expected a quoted key or value");
        const std::size_t end = s_.find(q, i_ + 1);
        if (end == std::string::npos) fail("unterminated string");
        std::string v = s_.substr(i_ + 1, end - i_ - 1);
        i_ = end + 1;
        return v;
    }
    std::string raw_value() {  // True/False or a tuple "(a, b, c)"
        const std::size_t start = i_;
        if (peek() == '(') {
            const std::size_t end = s_.find(')', i_);
            if (end == std::string::npos) fail("unterminated tuple");
            i_ = end + 1;
        } else {
            while (std::isalnum(static_cast<unsigned char>(peek()))) ++i_;
        }
        return s_.substr(start, i_ - start);
    }

    const std::string& name_;
    const std::string& s_;
    std::size_t i_ = 0;
};

ScalarType dtype(const std::string& name, const std::string& descr, Endian* endian) {
    static const std::map<std::string, ScalarType> kinds = {
        {"u1", ScalarType::u8},  {"i1", ScalarType::i8},  {"b1", ScalarType::u8},  {"u2", ScalarType::u16},
        {"i2", ScalarType::i16}, {"u4", ScalarType::u32}, {"i4", ScalarType::i32}, {"f4", ScalarType::f32},
        {"f8", ScalarType::f64}};
    const auto it = descr.size() == 3 ? kinds.find(descr.substr(1)) : kinds.end();
    const char order = descr.empty() ? '?' : descr[0];
    const bool one_byte = descr.size() == 3 && descr[2] == '1';
    const bool order_ok = order == '<' || order == '>' || order == '=' || (order == '|' && one_byte);
    if (it == kinds.end() || !order_ok)
        throw file_error(name, "descr", "unsupported dtype '" + descr + "' (expected u1, i1, u2, i2, u4, i4, f4 or f8)");
    *endian = order == '>' ? Endian::big : order == '<' ? Endian::little : native_endian();
    return it->second;
}

std::array<long long, 3> shape(const std::string& name, const std::string& text) {
    if (text.empty() || text[0] != '(')
        throw file_error(name, "shape", "expected a 3-D shape (z, y, x), found '" + text + "'");
    std::vector<long long> values;
    const char* p = text.c_str() + 1;  // after '('
    while (*p && *p != ')' && values.size() <= 3) {
        char* end = nullptr;
        const long long v = std::strtoll(p, &end, 10);
        if (end == p) throw file_error(name, "shape", "not a tuple of integers: " + text);
        values.push_back(v);
        p = end;
        while (*p == ',' || std::isspace(static_cast<unsigned char>(*p))) ++p;
    }
    if (values.size() != 3)
        throw file_error(name, "shape", "expected a 3-D shape (z, y, x), found " + text);
    return {values[2], values[1], values[0]};
}

}  // namespace

std::size_t npy_header_size(const std::string& name, const unsigned char* data, std::size_t size) {
    static const unsigned char kMagic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
    if (size < 10 || !std::equal(kMagic, kMagic + 6, data)) throw file_error(name, "magic", "not a .npy file");
    const int version = data[6];
    if (version < 1 || version > 3) throw file_error(name, "version", "unsupported .npy version " + std::to_string(version));
    const std::size_t len_bytes = version == 1 ? 2 : 4;
    if (size < 8 + len_bytes) throw file_error(name, "header", "truncated header");
    std::size_t header_len = 0;
    for (std::size_t i = 0; i < len_bytes; ++i) header_len |= std::size_t(data[8 + i]) << (8 * i);
    return 8 + len_bytes + header_len;
}

RawLayout parse_npy_header(const std::string& name, const unsigned char* data, std::size_t header_size, std::uint64_t file_size,
                           std::uint64_t voxel_limit) {
    const std::size_t data_start = npy_header_size(name, data, header_size);
    if (data_start > header_size) throw file_error(name, "header", "truncated header");
    const std::size_t len_bytes = data[6] == 1 ? 2 : 4;
    const std::string header(reinterpret_cast<const char*>(data) + 8 + len_bytes, data_start - 8 - len_bytes);
    std::map<std::string, std::string> dict = DictParser(name, header).parse();
    for (const auto& [key, value] : dict)
        if (key != "descr" && key != "fortran_order" && key != "shape")
            throw file_error(name, "header", "unknown key '" + key + "'");
    for (const char* key : {"descr", "fortran_order", "shape"})
        if (!dict.count(key)) throw file_error(name, key, "missing from the header");
    if (dict["fortran_order"] != "False")
        throw file_error(name, "fortran_order", "must be False (C order), found " + dict["fortran_order"]);

    RawLayout layout;
    layout.data_file = name;
    layout.offset = data_start;
    layout.type = dtype(name, dict["descr"], &layout.endian);
    layout.dims = shape(name, dict["shape"]);
    const std::size_t count = checked_voxel_count(name, layout.dims, voxel_limit);
    check_exact_size(name, "data", std::uint64_t(count) * type_size(layout.type), file_size - std::min<std::uint64_t>(file_size, data_start));
    return layout;
}

Volume parse_npy(const std::string& name, const unsigned char* data, std::size_t size) {
    const RawLayout layout = parse_npy_header(name, data, size, size);
    Volume volume;
    volume.dims = {int(layout.dims[0]), int(layout.dims[1]), int(layout.dims[2])};
    volume.voxels = to_float(data + layout.offset, volume.voxel_count(), layout.type, layout.endian);
    volume.stored_type = type_name(layout.type);
    volume.source = name;
    return volume;
}

Volume read_npy(const std::string& path) {
    const std::vector<unsigned char> bytes = read_file(path);
    return parse_npy(path, bytes.data(), bytes.size());
}

Volume read_npz(const std::string& path) {
    detail::regular_file_size(path);  // libzip would block on a FIFO
    int code = 0;
    std::unique_ptr<zip_t, int (*)(zip_t*)> archive(zip_open(path.c_str(), ZIP_RDONLY, &code), zip_close);
    if (!archive) {
        zip_error_t error;
        zip_error_init_with_code(&error, code);
        const std::string what = zip_error_strerror(&error);
        zip_error_fini(&error);
        throw file_error(path, "archive", "cannot open as a zip archive: " + what);
    }
    const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
    const char* member = entries == 1 ? zip_get_name(archive.get(), 0, 0) : nullptr;
    const std::string member_name = member ? member : "";
    if (entries != 1 || member_name.size() < 4 || member_name.compare(member_name.size() - 4, 4, ".npy") != 0)
        throw file_error(path, "members", "expected exactly one .npy member, found " + std::to_string(entries) +
                                              " member(s)" + (entries == 1 ? " named '" + member_name + "'" : ""));

    const std::string name = path + ":" + member_name;
    zip_stat_t st;
    if (zip_stat_index(archive.get(), 0, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
        throw file_error(name, "archive", "cannot read the member size");
    if (st.size > kMaxVolumeFileBytes)
        throw file_error(name, "archive", "member declares " + std::to_string(st.size) + " bytes, more than a volume may hold");
    std::unique_ptr<zip_file_t, int (*)(zip_file_t*)> file(zip_fopen_index(archive.get(), 0, 0), zip_fclose);
    if (!file) throw file_error(name, "archive", std::string("cannot open the member: ") + zip_strerror(archive.get()));
    // The declared size is only a claim: memory grows with the bytes that really decompress.
    bool overrun = false, failed = false;
    const std::vector<unsigned char> bytes = detail::read_declared(
        st.size, [&](unsigned char* to, std::size_t n) -> long long { return zip_fread(file.get(), to, n); },
        &overrun, &failed);
    if (failed) throw file_error(name, "archive", std::string("cannot decompress the member: ") + zip_file_strerror(file.get()));
    if (bytes.size() != st.size || overrun)
        throw file_error(name, "archive", "member declares " + std::to_string(st.size) + " bytes but holds " +
                                              (overrun ? "more" : std::to_string(bytes.size())));
    return parse_npy(name, bytes.data(), bytes.size());
}

}  // namespace sombra::volume_io
