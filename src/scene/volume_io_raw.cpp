// sombra — raw voxel files described by a small JSON header (see data/README.md, "raw volumes"):
//   {"raw": "file.raw", "dims": [x, y, z], "spacing": [sx, sy, sz], "type": "uint8",
//    "endian": "little", "header_bytes": 0}
#include "scene/volume_io_common.h"

#include "scene/input_file.h"
#include "scene/json_fields.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>

namespace sombra::volume_io {
namespace {

using nlohmann::json;

const std::map<std::string, ScalarType>& raw_types() {
    static const std::map<std::string, ScalarType> types = {
        {"uint8", ScalarType::u8},   {"int8", ScalarType::i8},   {"uint16", ScalarType::u16},
        {"int16", ScalarType::i16},  {"uint32", ScalarType::u32}, {"int32", ScalarType::i32},
        {"float32", ScalarType::f32}, {"float64", ScalarType::f64}};
    return types;
}

const json& field(const std::string& path, const json& doc, const char* key, bool required) {
    static const json absent;
    if (doc.contains(key)) return doc[key];
    if (required) throw file_error(path, key, "missing");
    return absent;
}

std::string string_field(const std::string& path, const json& doc, const char* key, const char* fallback) {
    const json& v = field(path, doc, key, fallback == nullptr);
    if (v.is_null()) return fallback;
    if (!v.is_string()) throw file_error(path, key, "must be a string");
    return v.get<std::string>();
}

const json& triple(const std::string& path, const json& v, const char* key) {
    if (!v.is_array() || v.size() != 3) throw file_error(path, key, "must be an array of 3 numbers");
    return v;
}

}  // namespace

RawLayout raw_json_layout(const std::string& path, Volume& volume, std::uint64_t voxel_limit) {
    const std::vector<unsigned char> text = detail::read_regular_file(path, limits::kMaxInputFileBytes);
    json doc;
    try {
        doc = json::parse(text.begin(), text.end());
    } catch (const json::exception& e) {  // syntax errors, and numbers that overflow a double
        throw file_error(path, "json", detail::json_error_text(e));
    }
    if (!doc.is_object()) throw file_error(path, "json", "the header must be a JSON object");
    for (const auto& item : doc.items()) {
        static const char* known[] = {"raw", "dims", "spacing", "type", "endian", "header_bytes"};
        if (std::find(std::begin(known), std::end(known), item.key()) == std::end(known))
            throw file_error(path, item.key(), "unknown key (expected raw, dims, spacing, type, endian, header_bytes)");
    }

    const std::string raw = string_field(path, doc, "raw", nullptr);
    const json& d = triple(path, field(path, doc, "dims", true), "dims");
    std::array<long long, 3> dims{};
    for (int a = 0; a < 3; ++a) {
        const auto n = detail::integer_in(d[a], 1, std::numeric_limits<int>::max());
        if (!n) throw file_error(path, "dims", "must hold 3 integers in [1, 2147483647]");
        dims[a] = *n;
    }
    const std::string type_name = string_field(path, doc, "type", nullptr);
    const auto type_it = raw_types().find(type_name);
    if (type_it == raw_types().end())
        throw file_error(path, "type", "unknown type '" + type_name + "' (expected uint8, int8, uint16, int16, "
                                                                      "uint32, int32, float32 or float64)");
    const std::string endian = string_field(path, doc, "endian", "little");
    if (endian != "little" && endian != "big") throw file_error(path, "endian", "must be \"little\" or \"big\"");
    const json& skip = field(path, doc, "header_bytes", false);
    const auto header_bytes = skip.is_null() ? std::optional<std::int64_t>(0)
                                             : detail::integer_in(skip, 0, std::numeric_limits<std::int64_t>::max());
    if (!header_bytes) throw file_error(path, "header_bytes", "must be an integer in [0, 2^63 - 1]");

    const json& spacing = field(path, doc, "spacing", false);
    if (!spacing.is_null()) {
        const json& s = triple(path, spacing, "spacing");
        for (int a = 0; a < 3; ++a) {
            const auto size = detail::finite_float(s[a]);
            if (!size || !(*size > 0)) throw file_error(path, "spacing", "voxel sizes must be finite numbers > 0");
            volume.spacing[a] = *size;
        }
    }

    const ScalarType type = type_it->second;
    const std::size_t count = checked_voxel_count(path, dims, voxel_limit);
    const std::string raw_path = (std::filesystem::path(path).parent_path() / raw).string();
    // Sizes against the file's real size before anything is read (count * size < 2^34: no overflow).
    std::uint64_t raw_size = 0;
    try {
        raw_size = detail::regular_file_size(raw_path);
    } catch (const Error& e) {
        throw file_error(path, "raw", e.what());
    }
    const std::uint64_t data_bytes = std::uint64_t(count) * type_size(type);
    if (std::uint64_t(*header_bytes) > raw_size)
        throw file_error(path, "header_bytes", std::to_string(*header_bytes) + " is more than the size of '" + raw_path +
                                                   "' (" + std::to_string(raw_size) + " bytes)");
    check_exact_size(path, "raw", data_bytes, raw_size - std::uint64_t(*header_bytes),
                     "'" + raw_path + "' after " + std::to_string(*header_bytes) + " header bytes");
    volume.dims = {int(dims[0]), int(dims[1]), int(dims[2])};
    volume.stored_type = volume_io::type_name(type);
    volume.source = path;
    return {raw_path, std::uint64_t(*header_bytes), dims, type, endian == "big" ? Endian::big : Endian::little};
}

Volume read_raw_json(const std::string& path) {
    Volume volume;
    const RawLayout layout = raw_json_layout(path, volume);
    const std::string& raw_path = layout.data_file;
    const std::size_t count = volume.voxel_count();
    std::vector<unsigned char> bytes;
    try {
        bytes = read_file(raw_path);
    } catch (const Error& e) {
        throw file_error(path, "raw", e.what());
    }
    check_exact_size(path, "raw", layout.offset + std::uint64_t(count) * type_size(layout.type), bytes.size(), "'" + raw_path + "'");
    volume.voxels = to_float(bytes.data() + layout.offset, count, layout.type, layout.endian);
    return volume;
}

}  // namespace sombra::volume_io
