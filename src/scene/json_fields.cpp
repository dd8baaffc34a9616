#include "scene/json_fields.h"

#include "scene/input_file.h"
#include "sombra/limits.h"

namespace sombra::detail {

std::string json_error_text(const nlohmann::json::exception& e) {
    std::string text = e.what();
    if (text.size() > 200) text = text.substr(0, 200) + "…";  // it may quote a whole token
    return text;
}

nlohmann::json parse_json_file(const std::string& path) {
    const std::vector<unsigned char> bytes = read_regular_file(path, limits::kMaxInputFileBytes);
    const std::string text(bytes.begin(), bytes.end());
    try {
        return nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
    } catch (const nlohmann::json::parse_error& e) {
        std::size_t line = 1, column = 1;
        for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
            if (text[i] == '\n') { ++line; column = 1; } else { ++column; }
        }
        throw file_error(path, "line " + std::to_string(line) + " column " + std::to_string(column),
                         "JSON syntax error");
    } catch (const nlohmann::json::exception& e) {  // e.g. out_of_range 406: a number overflows double
        throw file_error(path, "json", json_error_text(e));
    }
}

}  // namespace sombra::detail
