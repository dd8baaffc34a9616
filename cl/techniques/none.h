/* sombra — shadow technique "none": every light reaches every point (techniques/technique.h). */
#define SHADOW_TERM 0
#define SHADOW_PARAMS
typedef struct {
    char unused;
} ShadowState;
#define SHADOW_STATE_INIT(s)
