// sombra — triangle meshes (translucent geometry of issue 4): in-memory form and file reader.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sombra {

// An indexed triangle mesh in object coordinates.
struct Mesh {
    std::vector<std::array<float, 3>> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;  // indices into positions
    std::vector<std::array<float, 3>> normals;            // empty, or one unit normal per position
    std::string source;                                   // file path or generator name, for messages
};

// Reads a mesh, choosing the format by the file's name: Wavefront OBJ (.obj, through tinyobjloader;
// all groups joined, corners with identical position and normal welded; `mtllib` is ignored) or
// Stanford PLY (.ply, ASCII or binary, by sombra's own strict reader). Polygons are triangulated
// as fans. Throws sombra::Error "FILE: what" for a missing, malformed or empty file, a file
// that is not regular, counts past sombra/limits.h, out-of-range indices and non-finite coordinates.
Mesh load_mesh(const std::string& path);

// Checks a mesh built in memory (indices in range, finite positions, normals count); throws
// sombra::Error "WHERE: what".
void validate_mesh(const Mesh& mesh, const std::string& where);

// Checks that a mesh is closed: after welding corners at identical positions, every edge of a
// non-degenerate triangle belongs to exactly two triangles (edge-manifold, no boundary). Throws
// sombra::Error "WHERE: mesh is not closed (…)". Orientation is not checked (parity needs none).
void check_closed(const Mesh& mesh, const std::string& where);

// A closed, consistently wound UV sphere (tests, small scenes): `stacks` ≥ 2, `slices` ≥ 3.
Mesh make_uv_sphere(int stacks, int slices, float radius = 1.f);

}  // namespace sombra
