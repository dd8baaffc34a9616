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

// Times of one frame (ms; < 0: unknown). `on_ms`, `off_ms`: the mean of the last two measured
// renders with the cache on and off; the estimates: the first probe's (fill + cached camera pass,
// per-sample camera pass); `last_on`: the mode of the last render.
struct AutoHistory {
    double on_ms = -1, off_ms = -1;
    double estimated_on_ms = -1, estimated_off_ms = -1;
    bool last_on = false;
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
//  - was measured faster by more than kHistorySwitch (5 %: a close call does not flip from run
//    to run on the noise of two measurements), or
//  - was not measured, and its estimate is under kHistoryExplore (1.25) × the last mode's time:
//    it may be faster (estimates spread by ± 40 %), so it is measured once.
// So a frame settles on the faster measured mode within a few runs, and a run that measures the
// other mode costs at most what its estimate allowed.
enum class HistoryChoice { Probe, Off, On };
constexpr double kHistorySwitch = 1.05, kHistoryExplore = 1.25;
HistoryChoice choose_from_history(const std::optional<AutoHistory>& history);
// The history after a render in mode `on` that took `ms` (the mean with the mode's previous time).
AutoHistory with_measurement(AutoHistory history, bool on, double ms);

}  // namespace sombra::pipeline
