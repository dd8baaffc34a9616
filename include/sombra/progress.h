// sombra — progress of the long stages of a call (render, shadow_transmittance,
// build_deep_shadow_maps): kernel builds, deep shadow maps, summed-area tables, shadow cache and
// camera pass. Long kernels run as several launches over bands of rows, so progress is real.
#pragma once
#include <functional>
#include <ostream>
#include <string>

namespace sombra {

struct ProgressReport {
    std::string stage;      // "kernel build", "deep shadow maps", "summed-area tables", "shadow cache", "camera pass"
    double fraction = 0;    // of the stage's work: 0 at its start, never decreasing, 1 when it finished
    double elapsed_ms = 0;  // wall clock since the stage began
    bool done = false;      // the stage's last report
    bool failed = false;    // done, cut short by an error (fraction below 1 then)
};

// Called on the calling thread, at the start and end of each stage and after each launch.
using ProgressCallback = std::function<void(const ProgressReport&)>;

// The command line's reporter, writing to `out`: on a terminal, a bar with the stage, percentage
// and ETA, redrawn in place and replaced by the stage's line when it ends; otherwise only that
// line, one per stage: "sombra: shadow cache 16,967 ms".
ProgressCallback text_progress(std::ostream& out, bool terminal);

// Milliseconds as a whole number with thousands separators: 16966.6 → "16,967".
std::string format_ms(double ms);

}  // namespace sombra
