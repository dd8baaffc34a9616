// sombra — the progress of the current call on a Runtime: stages begun and ended by the passes,
// advanced by the tiled launches (host/tiled_launch.h), reported to the call's ProgressCallback.
#pragma once
#include <chrono>
#include <string>

#include "sombra/progress.h"

namespace sombra::host {

class Progress {
public:
    // Begins a stage of `units` of work. A stage begun inside another is silent: its work is the
    // outer stage's (a kernel build inside the deep shadow maps, say); so is a stage of no work.
    void begin(const std::string& stage, double units);
    void advance(double units);  // of the outermost stage; nothing outside a stage
    // More work than planned turned up (a pool grown and the views run again): the rest of the
    // bar is shared out anew, so that the fraction never goes back.
    void extend(double units);
    void end(bool failed);
    ProgressCallback callback;  // the current call's (empty: silent)
    // Kernel time of the stage's last launch (host/tiled_launch.h), −1 before the first.
    double last_launch_ms = -1;

private:
    void report(bool done, bool failed);
    int depth_ = 0;
    bool silent_ = false;
    std::string stage_;
    double total_ = 0, done_ = 0;
    double base_fraction_ = 0, base_done_ = 0;  // where the last extend() left the bar
    double fraction_ = 0;
    std::chrono::steady_clock::time_point start_;
};

// The scope guards below act once: not copied.
struct NotCopied {
    NotCopied() = default;
    NotCopied(const NotCopied&) = delete;
    NotCopied& operator=(const NotCopied&) = delete;
};

// A stage for the scope of a block: ends it, as failed when an exception leaves the block.
class ProgressStage : NotCopied {
public:
    ProgressStage(Progress& progress, const std::string& stage, double units);
    ~ProgressStage();

private:
    Progress& progress_;
    int exceptions_;
};

// f() as a stage of `units`; returns what it returns.
template <typename F>
auto in_stage(Progress& progress, const std::string& stage, double units, F&& f) {
    ProgressStage scope(progress, stage, units);
    return f();
}

// Installs a call's callback for the scope of the call; restores the one before.
class ProgressScope : NotCopied {
public:
    ProgressScope(Progress& progress, ProgressCallback callback);
    ~ProgressScope();

private:
    Progress& progress_;
    ProgressCallback previous_;
};

}  // namespace sombra::host
