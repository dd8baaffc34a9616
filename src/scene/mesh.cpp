#include "sombra/mesh.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>

#include "math_constants.h"
#include "scene/input_file.h"
#include "scene/mesh_formats.h"
#include "sombra/error.h"
#include "sombra/limits.h"

namespace sombra {

void validate_mesh(const Mesh& mesh, const std::string& where) {
    if (mesh.triangles.empty()) throw file_error(where, "", "mesh has no triangles");
    for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        for (float c : mesh.positions[i])
            if (!std::isfinite(c)) throw file_error(where, "vertex " + std::to_string(i), "non-finite coordinate");
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
        for (auto k : mesh.triangles[i])
            if (k >= mesh.positions.size())
                throw file_error(where, "triangle " + std::to_string(i),
                                 "index " + std::to_string(k) + " out of range (" +
                                     std::to_string(mesh.positions.size()) + " vertices)");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        throw file_error(where, "normals", "must be one per vertex");
}

void check_closed(const Mesh& mesh, const std::string& where) {
    std::map<std::array<float, 3>, std::uint32_t> weld;  // identical positions → one corner
    std::vector<std::uint32_t> id(mesh.positions.size());
    for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        id[i] = weld.emplace(mesh.positions[i], std::uint32_t(weld.size())).first->second;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    for (const auto& tri : mesh.triangles) {
        std::uint32_t c[3] = {id[tri[0]], id[tri[1]], id[tri[2]]};
        if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0]) continue;  // degenerate: no area, no edge
        for (int k = 0; k < 3; ++k) ++edges[std::minmax(c[k], c[(k + 1) % 3])];
    }
    for (const auto& [edge, count] : edges)
        if (count != 2)
            throw file_error(where, "", "mesh is not closed (an edge belongs to " + std::to_string(count) +
                                            (count == 1 ? " triangle" : " triangles") + ", not 2)");
    if (edges.empty()) throw file_error(where, "", "mesh is not closed (no triangle with area)");
}

Mesh load_mesh(const std::string& path) {
    const std::uint64_t size = detail::regular_file_size(path);
    if (size > limits::kMaxInputFileBytes)
        throw file_error(path, "", "file too large: " + std::to_string(size) + " bytes (at most " +
                                       std::to_string(limits::kMaxInputFileBytes) + ")");
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    Mesh mesh;
    if (extension == ".ply") mesh = detail::read_ply(path);
    else if (extension == ".obj") mesh = detail::read_obj(path);
    else throw file_error(path, "", "unknown mesh format (expected .obj or .ply)");
    mesh.source = path;
    validate_mesh(mesh, path);
    return mesh;
}

Mesh make_uv_sphere(int stacks, int slices, float radius) {
    if (stacks < 2 || slices < 3) throw Error("make_uv_sphere: needs stacks ≥ 2 and slices ≥ 3");
    Mesh m;
    m.source = "uv_sphere";
    m.positions.push_back({0, 0, radius});  // north pole
    for (int i = 1; i < stacks; ++i) {
        float theta = float(kPi) * float(i) / float(stacks);
        for (int j = 0; j < slices; ++j) {
            float phi = 2.f * float(kPi) * float(j) / float(slices);
            m.positions.push_back({radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi),
                                   radius * std::cos(theta)});
        }
    }
    m.positions.push_back({0, 0, -radius});  // south pole
    const auto south = std::uint32_t(m.positions.size() - 1);
    auto ring = [&](int i, int j) { return std::uint32_t(1 + (i - 1) * slices + (j % slices)); };
    for (int j = 0; j < slices; ++j) {  // counter-clockwise seen from outside
        m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
        m.triangles.push_back({south, ring(stacks - 1, j + 1), ring(stacks - 1, j)});
    }
    for (int i = 1; i + 1 < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
            m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
        }
    for (auto& p : m.positions) {
        float len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        m.normals.push_back({p[0] / len, p[1] / len, p[2] / len});
    }
    return m;
}

}  // namespace sombra
