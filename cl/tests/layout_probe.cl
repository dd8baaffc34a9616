/* sombra — writes sizeof/offsetof of the shared structs as the kernel compiler sees them. */
#include "shared/types.h"

#define SOMBRA_OFFSET(type, member) ((uint)(size_t)&(((__global type*)0)->member))
__kernel void layout_probe(__global uint* out) {
    uint i = 0;
#define SOMBRA_LAYOUT_ENTRY(type, member) out[i++] = SOMBRA_OFFSET(type, member);
#define SOMBRA_LAYOUT_SIZE(type) out[i++] = (uint)sizeof(type);
#include "tests/layout_fields.h"
}
