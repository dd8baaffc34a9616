// sombra — helpers shared by the volume file readers.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <type_traits>

namespace sombra::volume_io {

std::size_t type_size(ScalarType type) {
    switch (type) {
        case ScalarType::u8: case ScalarType::i8: return 1;
        case ScalarType::u16: case ScalarType::i16: return 2;
        case ScalarType::u32: case ScalarType::i32: case ScalarType::f32: return 4;
        case ScalarType::f64: return 8;
    }
    return 1;
}

Endian native_endian() {
    const std::uint16_t one = 1;
    unsigned char first = 0;
    std::memcpy(&first, &one, 1);
    return first == 1 ? Endian::little : Endian::big;
}

std::vector<unsigned char> read_file(const std::string& path) {
    return detail::read_regular_file(path, kMaxVolumeFileBytes);
}

std::size_t checked_voxel_count(const std::string& file, const std::array<long long, 3>& dims, std::uint64_t limit) {
    const std::string text = std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                             std::to_string(dims[2]);
    std::uint64_t count = 1;
    for (long long d : dims) {
        if (d <= 0) throw file_error(file, "dims", "empty volume " + text + " (every dimension must be > 0)");
        if (std::uint64_t(d) > limit / count)  // count * d would pass the limit (or overflow)
            throw file_error(file, "dims", "volume " + text + " has more than " + std::to_string(limit) + " voxels");
        count *= std::uint64_t(d);
    }
    return static_cast<std::size_t>(count);
}

void check_exact_size(const std::string& file, const std::string& field, std::uint64_t expected,
                      std::uint64_t actual, const std::string& subject) {
    const std::string who = subject.empty() ? "" : subject + " ";
    if (actual < expected)
        throw file_error(file, field, who + (subject.empty() ? "" : "is ") + "truncated: expected " +
                                          std::to_string(expected) + " bytes, found " + std::to_string(actual));
    if (actual > expected)
        throw file_error(file, field, who + "has " + std::to_string(actual - expected) + " extra bytes (expected " +
                                          std::to_string(expected) + ")");
}

long long parse_int(const std::string& file, const std::string& field, const std::string& text) {
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || errno != 0)
        throw file_error(file, field, "not an integer: '" + text + "'");
    return v;
}

double parse_number(const std::string& file, const std::string& field, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(v))
        throw file_error(file, field, "not a finite number: '" + text + "'");
    return v;
}

void set_geometry(Volume& v, const std::string& file, const std::string& field,
                  const std::array<std::array<double, 3>, 3>& axes, const std::array<double, 3>& origin) {
    std::array<std::array<double, 3>, 3> unit{};  // unit[a]: direction of index axis a
    for (int a = 0; a < 3; ++a) {
        const double len = std::sqrt(axes[a][0] * axes[a][0] + axes[a][1] * axes[a][1] + axes[a][2] * axes[a][2]);
        if (!(std::isfinite(len) && len >= double(limits::kMinLength) && len <= 1e18))
            throw file_error(file, field, "voxel size along axis " + std::to_string(a) + " is " +
                                              (std::isfinite(len) ? std::to_string(len) : std::string("not finite")) +
                                              " (must be > 0 and finite)");
        for (int r = 0; r < 3; ++r) unit[a][r] = axes[a][r] / len;
        v.spacing[std::size_t(a)] = float(len);
    }
    const double det = unit[0][0] * (unit[1][1] * unit[2][2] - unit[1][2] * unit[2][1]) -
                       unit[1][0] * (unit[0][1] * unit[2][2] - unit[0][2] * unit[2][1]) +
                       unit[2][0] * (unit[0][1] * unit[1][2] - unit[0][2] * unit[1][1]);
    if (!(std::fabs(det) > 1e-6))
        throw file_error(file, field, "the voxel axes are (nearly) parallel: the volume would be flat");
    std::array<double, 3> centre = origin;  // world position of voxel ((n−1)/2, …)
    for (int a = 0; a < 3; ++a)
        for (int r = 0; r < 3; ++r) centre[r] += axes[a][r] * 0.5 * double(v.dims[std::size_t(a)] - 1);
    for (int r = 0; r < 3; ++r) {
        if (!(std::fabs(centre[r]) <= double(limits::kMaxCoordinate)))
            throw file_error(file, field, "places the volume beyond ±1e18");
        for (int a = 0; a < 3; ++a) v.placement[std::size_t(r * 4 + a)] = float(unit[a][r]);
        v.placement[std::size_t(r * 4 + 3)] = float(centre[r]);
    }
    v.placement[12] = v.placement[13] = v.placement[14] = 0.f;
    v.placement[15] = 1.f;
}

std::string one_line(const std::string& text) {
    std::string out;
    for (char c : text) {
        const bool blank = c == '\n' || c == '\r' || c == '\t' || c == ' ';
        if (blank) {
            if (!out.empty() && out.back() != ' ') out += ' ';
        } else {
            out += c;
        }
    }
    while (!out.empty() && out.back() == ' ') out.pop_back();
    return out;
}

namespace {
template <typename T>
void convert(const unsigned char* data, std::size_t count, bool swap, float* out) {
    unsigned char buf[sizeof(T)];
    for (std::size_t i = 0; i < count; ++i, data += sizeof(T)) {
        for (std::size_t b = 0; b < sizeof(T); ++b) buf[b] = swap ? data[sizeof(T) - 1 - b] : data[b];
        T value;
        std::memcpy(&value, buf, sizeof(T));
        if constexpr (std::is_same_v<T, double>)  // out of float range: Inf, for the NaN/Inf policy
            if (std::fabs(value) > std::numeric_limits<float>::max()) value = std::copysign(HUGE_VAL, value);
        out[i] = static_cast<float>(value);
    }
}
}  // namespace

const char* type_name(ScalarType type) {
    switch (type) {
        case ScalarType::u8: return "uint8";
        case ScalarType::i8: return "int8";
        case ScalarType::u16: return "uint16";
        case ScalarType::i16: return "int16";
        case ScalarType::u32: return "uint32";
        case ScalarType::i32: return "int32";
        case ScalarType::f32: return "float32";
        default: return "float64";
    }
}

std::vector<float> to_float(const unsigned char* data, std::size_t count, ScalarType type, Endian endian) {
    std::vector<float> out(count);
    const bool swap = endian != native_endian();
    switch (type) {
        case ScalarType::u8: convert<std::uint8_t>(data, count, false, out.data()); break;
        case ScalarType::i8: convert<std::int8_t>(data, count, false, out.data()); break;
        case ScalarType::u16: convert<std::uint16_t>(data, count, swap, out.data()); break;
        case ScalarType::i16: convert<std::int16_t>(data, count, swap, out.data()); break;
        case ScalarType::u32: convert<std::uint32_t>(data, count, swap, out.data()); break;
        case ScalarType::i32: convert<std::int32_t>(data, count, swap, out.data()); break;
        case ScalarType::f32: convert<float>(data, count, swap, out.data()); break;
        case ScalarType::f64: convert<double>(data, count, swap, out.data()); break;
    }
    return out;
}

}  // namespace sombra::volume_io
