// sombra — the walk of an OpenVDB file that runs before OpenVDB reads it
// (src/scene/volume_io_vdb_checks.cpp). Internal to src/scene. No OpenVDB headers.
#pragma once
#include <string>

namespace sombra::volume_io {

// Walks a .vdb file as OpenVDB 10's io::Stream will read it: header (magic, format 222 … 224, UUID),
// metadata, grid descriptors, transforms, tree topology and every node's value chunks. Every count
// and length is checked against the bytes left in the file, every compressed chunk's declared size
// against the buffer OpenVDB reads it into (OpenVDB copies an uncompressed chunk before checking its
// length: a heap overflow), node origins, masks and flags against what OpenVDB assumes, and the
// tree's memory against a limit. Grid types other than float, double, int32, int64 and vec3 trees
// (bool, mask, points) and frustum transforms are refused. Throws "FILE: FIELD: …".
void check_vdb_file(const std::string& path);

}  // namespace sombra::volume_io
