// sombra — public API. Include this one header.
#pragma once
#include "sombra/device.h"
#include "sombra/distributed.h"
#include "sombra/error.h"
#include "sombra/mesh.h"
#include "sombra/progress.h"
#include "sombra/render.h"
#include "sombra/scene.h"
#include "sombra/shadows.h"
#include "sombra/transfer_function.h"
#include "sombra/volume.h"
#include "sombra/limits.h"
