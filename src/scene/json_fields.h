// sombra — strict reading of JSON objects: every key must be known, every value of the right type,
// and every error names the file and the field path ("scene.json: lights[0].intensity: …").
#pragma once
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>

#include "scene/suggest.h"
#include "sombra/error.h"

namespace sombra::detail {

// Conversions that check the value as the type it is used as, never after a narrowing cast:
// a JSON integer within [lo, hi] (64-bit, signed or unsigned in the file) ...
inline std::optional<std::int64_t> integer_in(const nlohmann::json& v, std::int64_t lo, std::int64_t hi) {
    if (v.is_number_unsigned()) {
        const std::uint64_t u = v.get<std::uint64_t>();
        if (u > std::uint64_t(std::numeric_limits<std::int64_t>::max()) || std::int64_t(u) < lo || std::int64_t(u) > hi)
            return std::nullopt;
        return std::int64_t(u);
    }
    if (!v.is_number_integer()) return std::nullopt;
    const std::int64_t i = v.get<std::int64_t>();
    if (i < lo || i > hi) return std::nullopt;
    return i;
}
// ... and a JSON number that is still finite as a float (1e39 is not).
inline std::optional<float> finite_float(const nlohmann::json& v) {
    if (!v.is_number()) return std::nullopt;
    const double d = v.get<double>();
    if (!(std::fabs(d) <= double(std::numeric_limits<float>::max()))) return std::nullopt;
    return float(d);
}

class JsonFields {
public:
    JsonFields(const nlohmann::json& object, std::string file, std::string path)
        : object_(object), file_(std::move(file)), path_(std::move(path)) {
        if (!object_.is_object()) fail("", "must be an object");
    }

    bool has(const std::string& key) {
        used_.insert(key);
        return object_.contains(key);
    }
    const nlohmann::json& at(const std::string& key) {
        if (!has(key)) {
            // a misspelt required key is reported as the unknown key it is, not as a missing one
            for (auto it = object_.begin(); it != object_.end(); ++it)
                if (!used_.count(it.key()) && closest_name(it.key(), {key}) == key) fail_unknown(it.key(), {key});
            fail(key, "is required");
        }
        return object_.at(key);
    }
    std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw file_error(file_, key.empty() ? path_ : field(key), what);
    }

    float number(const std::string& key, float fallback) {
        if (!has(key)) return fallback;
        return number_of(object_.at(key), key);
    }
    float number(const std::string& key) { return number_of(at(key), key); }
    // An integer within [lo, hi] (checked as a 64-bit value, before any narrowing).
    std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi) {
        if (!has(key)) return fallback;
        const auto value = integer_in(object_.at(key), lo, hi);
        if (!value) fail(key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
        return *value;
    }
    std::string string(const std::string& key) {
        const auto& v = at(key);
        if (!v.is_string()) fail(key, "must be a string");
        return v.get<std::string>();
    }
    std::string string(const std::string& key, const std::string& fallback) { return has(key) ? string(key) : fallback; }
    std::array<float, 3> vec3(const std::string& key, const std::array<float, 3>& fallback) {
        if (!has(key)) return fallback;
        const auto& v = object_.at(key);
        if (!v.is_array() || v.size() != 3) fail(key, "must be an array of 3 numbers");
        return {number_of(v[0], key), number_of(v[1], key), number_of(v[2], key)};
    }

    // Throws for any key of the object that no accessor asked for, suggesting the closest one
    // that was asked for: "scene.json: volumes[0]: unknown key 'opacty' (did you mean 'opacity'?)".
    void finish() const {
        for (auto it = object_.begin(); it != object_.end(); ++it)
            if (!used_.count(it.key())) fail_unknown(it.key(), std::vector<std::string>(used_.begin(), used_.end()));
    }
    [[noreturn]] void fail_unknown(const std::string& key, const std::vector<std::string>& known) const {
        throw file_error(file_, path_, "unknown key '" + key + "'" + did_you_mean(key, known));
    }

    // v (an element of key's value) as a finite float.
    float number_of(const nlohmann::json& v, const std::string& key) const {
        if (!v.is_number()) fail(key, "must be a number");
        const auto value = finite_float(v);
        if (!value) fail(key, "must be finite (|value| <= 3.4e38)");
        return *value;
    }

private:

    const nlohmann::json& object_;
    std::string file_, path_;
    std::set<std::string> used_;
};

// nlohmann's message of e, cut to one short line.
std::string json_error_text(const nlohmann::json::exception& e);

// Parses a whole JSON file; a syntax error names the line and column, any other JSON error (a
// number that overflows a double) is "FILE: json: …".
nlohmann::json parse_json_file(const std::string& path);

}  // namespace sombra::detail
