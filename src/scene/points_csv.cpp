// sombra — the points file of `sombra visibility`.
#include <cmath>
#include <sstream>

#include "scene/input_file.h"
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/scene.h"

namespace sombra {

std::vector<Vec3> load_points_csv(const std::string& path) {
    const std::vector<unsigned char> bytes = detail::read_regular_file(path, limits::kMaxInputFileBytes);
    std::istringstream in(std::string(bytes.begin(), bytes.end()));
    std::vector<Vec3> points;
    std::string line;
    for (std::uint64_t number = 1; std::getline(in, line); ++number) {
        if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
        for (char& c : line)
            if (c == ',' || c == ';') c = ' ';
        std::istringstream fields(line);
        Vec3 p;
        std::string rest;
        if (!(fields >> p[0] >> p[1] >> p[2]) || (fields >> rest) || !std::isfinite(p[0]) || !std::isfinite(p[1]) ||
            !std::isfinite(p[2]))
            throw file_error(path, "line " + std::to_string(number), "expected three finite numbers x,y,z");
        if (points.size() == limits::kMaxPoints)
            throw file_error(path, "line " + std::to_string(number), "more than " + std::to_string(limits::kMaxPoints) + " points");
        points.push_back(p);
    }
    return points;
}

}  // namespace sombra
