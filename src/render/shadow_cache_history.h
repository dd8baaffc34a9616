// sombra — the shadow cache's auto across processes (issue 29 item 5): per frame, the measured
// times of the modes it ran with. A frame's first render probes (shadow_cache.cpp
// probe_volume_costs) and estimates both modes; each render then records the wall time its mode
// took (from auto's choice to the end of the camera pass, less the probe: what the two modes
// differ by), and a later process rendering the same frame chooses from these times instead of
// probing (choose_from_history). Kept as small files in a folder (docs/shadows.md "Auto across
// processes").
#pragma once

#include <optional>
#include <string>

namespace sombra::pipeline {

// Times of one frame (ms; < 0: unknown). `on_ms`, `off_ms`: the shortest measured render with
// the cache on and off (other load on the machine only lengthens a render, so the shortest is the
// frame's own cost; measured wall times of one frame spread by ± 10–25 ms on 2 busy cores), and
// how many renders each mode measured (counted up to kHistoryRuns); the estimates: the first
// probe's (fill + cached camera pass, per-sample camera pass); `last_on`: the mode of the last render;
// `mark_fill`: the first probe's choice whether a fill with the cache read marks the points the
// frame reads first (shadow_cache.cpp), kept so that later runs fill as the one that was timed.
struct AutoHistory {
    double on_ms = -1, off_ms = -1;
    int on_runs = 0, off_runs = 0;
    double estimated_on_ms = -1, estimated_off_ms = -1;
    bool last_on = false;
    bool mark_fill = true;
};

// The folder of the history: $SOMBRA_AUTO_HISTORY ("off": none, nothing read or written), else
// $XDG_CACHE_HOME/sombra/auto, else ~/.cache/sombra/auto; empty: none.
std::string auto_history_folder();

// The history of the frame whose choice key is `key` (shadow_cache.cpp the_choice_key); none when
// there is none, the folder is off, or the file cannot be read or is not ours.
std::optional<AutoHistory> load_auto_history(const std::string& key);
// Writes it (a temporary file renamed over the old: a reader sees the old or the new); a folder
// that cannot be written is skipped silently (the history only saves a probe).
void store_auto_history(const std::string& key, const AutoHistory& history);

// Auto from the history (the shadow cache on or off for a frame, or a probe when nothing is
// measured yet). The mode of the last render stays unless the other mode
//  - was not measured, and its estimate is under kHistoryExplore (1.25) × the last mode's time
//    plus kHistoryExploreMs (150 ms): it may be faster (estimates spread by ± 40 %, and more on
//    frames of 50–300 ms, where a probe's few launches are a few milliseconds each), so it is
//    measured once;
//  - was measured fewer than kHistoryRuns (3) times and its shortest time is under
//    kHistoryRecheck (1.15) × the last mode's: a close call is measured again, as the last
//    mode was, before it is settled (one measurement can be 25 ms off on a 100 ms frame);
//  - was measured faster by more than kHistorySwitch (5 %: a close call does not flip from run
//    to run).
// So a frame settles on the faster measured mode within a few runs, a run that measures the other
// mode costs at most what its estimate or the close call allowed, and a mode estimated far slower
// is never tried.
enum class HistoryChoice { Probe, Off, On };
constexpr double kHistorySwitch = 1.05, kHistoryExplore = 1.25, kHistoryExploreMs = 150, kHistoryRecheck = 1.15;
constexpr int kHistoryRuns = 3;
HistoryChoice choose_from_history(const std::optional<AutoHistory>& history);
// The history after a render in mode `on` that took `ms` (the mode's shortest time, one more run).
AutoHistory with_measurement(AutoHistory history, bool on, double ms);
// Whether a run of `wall_ms` whose kernels took `kernel_ms` compiled code on the way, and so is not
// recorded: more than kHistoryCompileFactor × its kernels' time + kHistoryCompileMs. PoCL
// generates a kernel variant's code at its first launch (a wiped ~/.cache/pocl: 1.6–7.8 s runs
// whose kernels took 20–600 ms; other runs spend 10–30 ms beyond their kernels). Recorded, such a
// run kept its mode unused for good (teapot_fog's DSM at 256²: off 2.55 s once, 0.28 s after).
constexpr double kHistoryCompileFactor = 1.25, kHistoryCompileMs = 150;
constexpr bool history_run_compiled(double wall_ms, double kernel_ms) {
    return wall_ms > kHistoryCompileFactor * kernel_ms + kHistoryCompileMs;
}

}  // namespace sombra::pipeline
