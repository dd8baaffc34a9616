// sombra — the PLY reader (internal to src/scene; load_mesh dispatches .ply files to it).
#pragma once
#include <string>

#include "sombra/mesh.h"

namespace sombra::detail {

// Positions, triangles (polygons as fans) and normals (when nx, ny, nz are present) of a PLY file;
// throws one-line sombra::Errors naming the file and the element or header field.
Mesh read_ply(const std::string& path);

}  // namespace sombra::detail
