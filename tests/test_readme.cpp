// The README's quick start works as printed: its scene block is valid JSON and renders with the
// command the README gives (at a small size).
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "test_support.h"

TEST_CASE("README quick start: the scene block is valid JSON and renders with deep shadow maps", "[cli][readme]") {
    namespace fs = std::filesystem;
    const fs::path root = fs::path(SOMBRA_DATA_DIR).parent_path();
    std::ifstream in(root / "README.md");
    REQUIRE(in);
    std::stringstream text;
    text << in.rdbuf();
    const std::string readme = text.str();
    const std::string marker = "<!-- quickstart-scene";
    std::size_t at = readme.find(marker);
    REQUIRE(at != std::string::npos);
    std::size_t begin = readme.find("```json\n", at);
    REQUIRE(begin != std::string::npos);
    begin += 8;
    std::size_t end = readme.find("```", begin);
    REQUIRE(end != std::string::npos);
    const std::string scene = readme.substr(begin, end - begin);
    nlohmann::json parsed;
    REQUIRE_NOTHROW(parsed = nlohmann::json::parse(scene));  // plain JSON, no comments or placeholders
    CHECK(parsed["volumes"].size() == 1);

    // the README says: save it in the repository's root folder — here a folder with the same data/
    const fs::path dir = sombra::test::temp_dir();
    fs::remove(dir / "data");
    fs::create_directory_symlink(SOMBRA_DATA_DIR, dir / "data");
    std::ofstream(dir / "my_scene.json") << scene;
    const fs::path image = dir / "head.png";
    std::string command = std::string(SOMBRA_CLI) + " render " + (dir / "my_scene.json").string() + " -o " + image.string() +
                          " --shadows dsm --width 64 --height 64 --stats " + (dir / "head.json").string() + " 2>/dev/null";
    CHECK(std::system(command.c_str()) == 0);
    CHECK(fs::exists(image));
    CHECK(fs::exists(dir / "head.json"));
}

TEST_CASE("docs/options.md lists every declared option with its flag and default", "[readme][options]") {
    std::ifstream in(std::filesystem::path(SOMBRA_DATA_DIR).parent_path() / "docs" / "options.md");
    REQUIRE(in);
    std::stringstream text;
    text << in.rdbuf();
    for (const sombra::OptionSpec& spec : sombra::render_option_specs()) {
        INFO(spec.key);
        const std::string row_start = "| `" + spec.key + "` | `" + spec.flag + "` |";
        const std::size_t at = text.str().find(row_start);
        REQUIRE(at != std::string::npos);
        const std::string row = text.str().substr(at, text.str().find('\n', at) - at);
        CHECK_THAT(row, Catch::Contains(sombra::option_range_text(spec).empty() ? "—" : sombra::option_range_text(spec)));
    }
}
