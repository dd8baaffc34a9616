// sombra — Wavefront OBJ meshes through tinyobjloader (Debian libtinyobjloader-dev, compiled into
// this file so that the sanitizers and the fuzzer see it). Replaces Assimp, whose post-processing
// aborted on an assertion and whose OBJ importer leaked on malformed files (issue 12). The file is
// read by us (a regular file, size-capped), only its v, vn and f lines are parsed, from memory (so
// `mtllib` never opens another file); polygons are triangulated here as fans, every index checked.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>

#include <cctype>
#include <cmath>
#include <map>
#include <utility>

#include "scene/input_file.h"
#include "scene/mesh_formats.h"
#include "sombra/error.h"
#include "sombra/limits.h"

namespace sombra::detail {

namespace {

// The statements sombra uses — v, vn and f — with every other line emptied (line numbers stay),
// so that no other part of tinyobjloader's parser sees hostile input (fuzzing found a `vw` line
// whose joint id inf it converts to int: undefined behaviour). Face indices of more than 9 digits
// are refused: tinyobjloader reads them with atoi, which maps 99999999999999999999 to a valid index.
std::string used_statements(const std::string& path, const std::vector<unsigned char>& bytes) {
    std::string text;
    text.reserve(bytes.size());
    std::size_t line_number = 1;
    for (std::size_t start = 0; start < bytes.size(); ++line_number) {
        std::size_t end = start;
        while (end < bytes.size() && bytes[end] != '\n') ++end;
        std::size_t word = start;
        while (word < end && (bytes[word] == ' ' || bytes[word] == '\t')) ++word;
        std::size_t word_end = word;
        while (word_end < end && !std::isspace(bytes[word_end])) ++word_end;
        const std::string keyword(bytes.begin() + std::ptrdiff_t(word), bytes.begin() + std::ptrdiff_t(word_end));
        if (keyword == "v" || keyword == "vn" || keyword == "f") {
            std::size_t digits = 0;
            for (std::size_t i = word_end; i < end; ++i) {
                digits = std::isdigit(bytes[i]) ? digits + 1 : 0;
                if (keyword == "f" && digits > 9)
                    throw file_error(path, "line " + std::to_string(line_number), "face index does not fit in 32 bits");
            }
            text.append(bytes.begin() + std::ptrdiff_t(start), bytes.begin() + std::ptrdiff_t(end));
        }
        text += '\n';
        start = end + 1;
    }
    return text;
}

}  // namespace

Mesh read_obj(const std::string& path) {
    const std::vector<unsigned char> bytes = read_regular_file(path, limits::kMaxInputFileBytes);
    tinyobj::ObjReaderConfig config;
    config.triangulate = false;  // fans below, with checked indices
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    if (!reader.ParseFromString(used_statements(path, bytes), "", config)) {
        std::string why = reader.Error();
        while (!why.empty() && (why.back() == '\n' || why.back() == '.')) why.pop_back();
        throw file_error(path, "", "cannot read mesh" + (why.empty() ? std::string() : " (" + why.substr(0, 200) + ")"));
    }
    const tinyobj::attrib_t& attrib = reader.GetAttrib();
    const std::size_t positions = attrib.vertices.size() / 3, normals = attrib.normals.size() / 3;

    // Corners with identical position and normal are welded into one vertex (as Assimp did).
    struct Key {
        std::array<float, 3> p, n;
        bool operator<(const Key& o) const { return std::tie(p, n) < std::tie(o.p, o.n); }
    };
    std::map<Key, std::uint32_t> weld;
    Mesh mesh;
    bool every_corner_has_normal = true;
    const auto corner = [&](const tinyobj::index_t& index, std::size_t face) -> std::uint32_t {
        if (index.vertex_index < 0 || std::size_t(index.vertex_index) >= positions)
            throw file_error(path, "face " + std::to_string(face),
                             "vertex index out of range (" + std::to_string(positions) + " vertices)");
        const bool has_normal = index.normal_index >= 0 && std::size_t(index.normal_index) < normals;
        every_corner_has_normal &= has_normal;
        Key key{};
        for (int a = 0; a < 3; ++a) {
            key.p[std::size_t(a)] = attrib.vertices[std::size_t(index.vertex_index) * 3 + std::size_t(a)];
            if (has_normal) key.n[std::size_t(a)] = attrib.normals[std::size_t(index.normal_index) * 3 + std::size_t(a)];
        }
        const auto inserted = weld.emplace(key, std::uint32_t(mesh.positions.size()));
        if (inserted.second) {
            mesh.positions.push_back(key.p);
            mesh.normals.push_back(key.n);
        }
        return inserted.first->second;
    };

    std::size_t face_number = 0;
    for (const tinyobj::shape_t& shape : reader.GetShapes()) {  // every group of the file, joined
        const auto& indices = shape.mesh.indices;
        std::size_t offset = 0;
        for (const unsigned char count : shape.mesh.num_face_vertices) {
            if (offset + count > indices.size())
                throw file_error(path, "face " + std::to_string(face_number), "a face has more than 255 corners");
            for (std::size_t k = 2; k < count; ++k) {
                mesh.triangles.push_back({corner(indices[offset], face_number), corner(indices[offset + k - 1], face_number),
                                          corner(indices[offset + k], face_number)});
                if (mesh.triangles.size() > limits::kMaxMeshTriangles)
                    throw file_error(path, "", "more than " + std::to_string(limits::kMaxMeshTriangles) + " triangles");
            }
            offset += count;
            ++face_number;
        }
        if (offset != indices.size())  // tinyobjloader keeps a face's corner count in 8 bits
            throw file_error(path, "face", "a face has more than 255 corners");
    }
    if (!every_corner_has_normal) mesh.normals.clear();  // some corners without normals: none at all
    else
        for (auto& n : mesh.normals) {  // unit length, as Assimp's import gave
            const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (length > 0.f && std::isfinite(length))
                for (float& c : n) c /= length;
        }
    return mesh;
}

}  // namespace sombra::detail
