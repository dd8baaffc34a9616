/* sombra — picks the deep shadow map storage backend by define (SOMBRA_DSM_ATLAS,
 * SOMBRA_DSM_CHUNKED, else compact). */
#ifndef SOMBRA_DSM_STORAGE_H
#define SOMBRA_DSM_STORAGE_H
#if defined(SOMBRA_DSM_ATLAS)
#include "storage_atlas.h"
#elif defined(SOMBRA_DSM_CHUNKED)
#include "storage_chunked.h"
#else
#include "storage_compact.h"
#endif
#endif
