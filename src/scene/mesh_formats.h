// sombra — the mesh file readers (internal to src/scene; load_mesh picks one by the extension).
// Both throw one-line sombra::Errors naming the file and the element, face or header field.
#pragma once
#include <string>

#include "sombra/mesh.h"

namespace sombra::detail {

// Positions, triangles (polygons as fans) and normals (when nx, ny, nz are present) of a PLY file.
Mesh read_ply(const std::string& path);

// Positions, triangles (polygons as fans) and normals of a Wavefront OBJ file, all groups joined,
// corners with identical position and normal welded.
Mesh read_obj(const std::string& path);

}  // namespace sombra::detail
