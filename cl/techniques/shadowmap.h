/* sombra — shadow technique "shadowmap": the binary shadow-map baseline, read from the same deep
 * shadow maps (techniques/dsm.h with DSM_BINARY_LOOKUP): per texel lit in front of the depth where
 * its opacity reaches 1/2 and dark behind it, 2×2 texels filtered bilinearly (percentage closer). */
#define DSM_BINARY_LOOKUP
#include "techniques/dsm.h"
