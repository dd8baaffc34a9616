// sombra — helpers shared by the volume file readers.
#include "scene/volume_io_common.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
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
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw file_error(path, "", std::string("cannot open for reading: ") + std::strerror(errno));
    const std::streamoff size = in.tellg();
    if (size < 0) throw file_error(path, "", "cannot determine the file size");
    std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
    in.seekg(0);
    if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) throw file_error(path, "", "read error");
    return bytes;
}

std::size_t checked_voxel_count(const std::string& file, const std::array<long long, 3>& dims,
                                std::size_t item_size) {
    const std::string text = std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                             std::to_string(dims[2]);
    std::uint64_t count = 1;
    for (long long d : dims) {
        if (d <= 0) throw file_error(file, "dims", "empty volume " + text + " (every dimension must be > 0)");
        if (d > std::numeric_limits<int>::max()) throw file_error(file, "dims", "dimension too large in " + text);
        count *= std::uint64_t(d);
        if (count > (std::uint64_t(1) << 40) / std::max<std::size_t>(item_size, 1))
            throw file_error(file, "dims", "volume " + text + " is too large");
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
