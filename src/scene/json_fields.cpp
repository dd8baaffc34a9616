#include "scene/json_fields.h"

#include <fstream>
#include <sstream>

namespace sombra::detail {

nlohmann::json parse_json_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw file_error(path, "", "cannot open file");
    std::stringstream buffer;
    buffer << in.rdbuf();
    std::string text = buffer.str();
    try {
        return nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
    } catch (const nlohmann::json::parse_error& e) {
        std::size_t line = 1, column = 1;
        for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
            if (text[i] == '\n') { ++line; column = 1; } else { ++column; }
        }
        throw file_error(path, "line " + std::to_string(line) + " column " + std::to_string(column),
                         "JSON syntax error");
    }
}

}  // namespace sombra::detail
