// sombra — π, defined once for the host code (the kernels use OpenCL's M_PI_F); every host file uses it.
#pragma once

namespace sombra {
inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegreesPerRadian = 180.0 / kPi;
}  // namespace sombra
