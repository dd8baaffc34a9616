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

std::size_t checked_voxel_count(const std::string& file, const std::array<long long, 3>& dims) {
    const std::string text = std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                             std::to_string(dims[2]);
    std::uint64_t count = 1;
    for (long long d : dims) {
        if (d <= 0) throw file_error(file, "dims", "empty volume " + text + " (every dimension must be > 0)");
        if (std::uint64_t(d) > limits::kMaxVolumeVoxels / count)  // count * d would pass the limit (or overflow)
            throw file_error(file, "dims", "volume " + text + " has more than " +
                                               std::to_string(limits::kMaxVolumeVoxels) + " voxels");
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
