// sombra — the OpenCL sources of cl/, embedded at build time by cmake/EmbedKernels.cmake.
#pragma once
#include <map>
#include <string>

namespace sombra::host {
// Path relative to cl/ → file content.
const std::map<std::string, std::string>& embedded_kernel_sources();
}
