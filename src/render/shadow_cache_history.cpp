// sombra — the shadow cache's auto across processes (shadow_cache_history.h).
#include "render/shadow_cache_history.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>
#include <unistd.h>

#include "host/program_cache.h"

namespace sombra::pipeline {

namespace {

constexpr const char* kMagic = "sombra-auto-history 1";

// FNV-1a over the key from two starting points: one names the file, the other is kept in it and
// checked (a different frame whose name collides reads as no history).
std::uint64_t fnv1a(const std::string& text, std::uint64_t hash) {
    for (unsigned char c : text) hash = (hash ^ c) * 0x100000001b3ull;
    return hash;
}

std::string hex(std::uint64_t value) {
    char buffer[17];
    std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(value));
    return buffer;
}

std::string file_of(const std::string& folder, const std::string& key) { return folder + "/" + hex(fnv1a(key, 0xcbf29ce484222325ull)) + ".txt"; }
std::string check_of(const std::string& key) { return hex(fnv1a(key, 0x84222325cbf29ce4ull)); }

}  // namespace

std::string auto_history_folder() { return host::user_cache_folder("SOMBRA_AUTO_HISTORY", "auto"); }

std::optional<AutoHistory> load_auto_history(const std::string& key) {
    const std::string folder = auto_history_folder();
    if (folder.empty()) return std::nullopt;
    std::ifstream in(file_of(folder, key));
    std::string magic, check;
    if (!std::getline(in, magic) || magic != kMagic || !std::getline(in, check) || check != check_of(key)) return std::nullopt;
    AutoHistory h;
    int last_on = 0;
    if (!(in >> h.on_ms >> h.off_ms >> h.estimated_on_ms >> h.estimated_off_ms >> last_on)) return std::nullopt;
    h.last_on = last_on != 0;
    // the runs (after the times: a file without them counts one run per measured mode)
    if (!(in >> h.on_runs >> h.off_runs)) h.on_runs = h.on_ms >= 0, h.off_runs = h.off_ms >= 0;
    int mark_fill = 1;  // after the runs (a file without it: the fill marks, as before)
    if (in >> mark_fill) h.mark_fill = mark_fill != 0;
    return h;
}

void store_auto_history(const std::string& key, const AutoHistory& h) {
    const std::string folder = auto_history_folder();
    if (folder.empty()) return;
    std::error_code error;
    std::filesystem::create_directories(folder, error);
    // the temporary file is this thread's own (two processes or threads may record one frame at once)
    const std::string path = file_of(folder, key),
                      temporary = path + "." + std::to_string(::getpid()) + "-" +
                                  std::to_string(std::hash<std::thread::id>()(std::this_thread::get_id())) + ".tmp";
    {
        std::ofstream out(temporary);
        out << kMagic << "\n" << check_of(key) << "\n"
            << h.on_ms << " " << h.off_ms << " " << h.estimated_on_ms << " " << h.estimated_off_ms << " " << (h.last_on ? 1 : 0) << " "
            << h.on_runs << " " << h.off_runs << " " << (h.mark_fill ? 1 : 0) << "\n";
        if (!out) {
            std::filesystem::remove(temporary, error);
            return;
        }
    }
    std::filesystem::rename(temporary, path, error);
    if (error) std::filesystem::remove(temporary, error);
}

HistoryChoice choose_from_history(const std::optional<AutoHistory>& history) {
    if (!history) return HistoryChoice::Probe;
    const AutoHistory& h = *history;
    const double last_ms = h.last_on ? h.on_ms : h.off_ms;
    if (last_ms < 0) return HistoryChoice::Probe;
    const double other_ms = h.last_on ? h.off_ms : h.on_ms, other_estimate = h.last_on ? h.estimated_off_ms : h.estimated_on_ms;
    const int other_runs = h.last_on ? h.off_runs : h.on_runs;
    bool switch_mode;
    if (other_ms < 0)
        switch_mode = other_estimate >= 0 && other_estimate < kHistoryExplore * last_ms + kHistoryExploreMs;
    else if (other_runs < kHistoryRuns && other_ms < kHistoryRecheck * last_ms)
        switch_mode = true;
    else
        switch_mode = kHistorySwitch * other_ms < last_ms;
    return (h.last_on != switch_mode) ? HistoryChoice::On : HistoryChoice::Off;
}

AutoHistory with_measurement(AutoHistory h, bool on, double ms) {
    double& kept = on ? h.on_ms : h.off_ms;
    int& runs = on ? h.on_runs : h.off_runs;
    kept = kept < 0 ? ms : std::min(kept, ms);
    runs = std::min(runs + 1, kHistoryRuns);
    h.last_on = on;
    return h;
}

}  // namespace sombra::pipeline
