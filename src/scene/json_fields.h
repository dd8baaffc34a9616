// sombra — strict reading of JSON objects: every key must be known, every value of the right type,
// and every error names the file and the field path ("scene.json: lights[0].intensity: …").
#pragma once
#include <nlohmann/json.hpp>

#include <array>
#include <set>
#include <string>

#include "sombra/error.h"

namespace sombra::detail {

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
        if (!has(key)) fail(key, "is required");
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
    int integer(const std::string& key, int fallback) {
        if (!has(key)) return fallback;
        const auto& v = object_.at(key);
        if (!v.is_number_integer()) fail(key, "must be an integer");
        return v.get<int>();
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

    // Throws for any key of the object that no accessor asked for.
    void finish() const {
        for (auto it = object_.begin(); it != object_.end(); ++it)
            if (!used_.count(it.key())) fail(it.key(), "unknown key");
    }

private:
    float number_of(const nlohmann::json& v, const std::string& key) const {
        if (!v.is_number()) fail(key, "must be a number");
        double d = v.get<double>();
        if (!std::isfinite(d)) fail(key, "must be finite");
        return float(d);
    }

    const nlohmann::json& object_;
    std::string file_, path_;
    std::set<std::string> used_;
};

// Parses a whole JSON file; a syntax error names the line and column.
nlohmann::json parse_json_file(const std::string& path);

}  // namespace sombra::detail
