#include "host/progress.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <sstream>

namespace sombra {
namespace {

using clock_type = std::chrono::steady_clock;

std::string format_seconds(double s) {
    long whole = std::lround(std::max(s, 0.0));
    return whole < 60 ? std::to_string(whole) + " s" : std::to_string(whole / 60) + " min " + std::to_string(whole % 60) + " s";
}

// The terminal bar: "sombra: camera pass [#######.............]  35%  ETA 12 s".
std::string bar(const ProgressReport& r) {
    constexpr int width = 24;
    int filled = int(r.fraction * width);
    std::ostringstream line;
    line << "sombra: " << r.stage << " [" << std::string(std::size_t(filled), '#') << std::string(std::size_t(width - filled), '.')
         << "] " << int(r.fraction * 100) << "%";
    if (r.fraction > 0.01 && r.elapsed_ms > 500)  // too early, and the estimate is noise
        line << "  ETA " << format_seconds(r.elapsed_ms * (1 - r.fraction) / r.fraction * 1e-3);
    return line.str();
}

}  // namespace

std::string format_ms(double ms) {
    std::string digits = std::to_string(std::llround(std::max(ms, 0.0)));
    for (std::ptrdiff_t at = std::ptrdiff_t(digits.size()) - 3; at > 0; at -= 3) digits.insert(std::size_t(at), ",");
    return digits;
}

ProgressCallback text_progress(std::ostream& out, bool terminal) {
    struct Drawn {
        std::string stage;
        clock_type::time_point at;
    };
    auto last = std::make_shared<Drawn>();
    return [&out, terminal, last](const ProgressReport& r) {
        if (r.done) {
            if (terminal) out << "\r\033[K";  // the bar goes
            if (!r.failed) out << "sombra: " << r.stage << " " << format_ms(r.elapsed_ms) << " ms\n";
            out.flush();
            return;
        }
        auto now = clock_type::now();
        if (!terminal || (r.stage == last->stage && now - last->at < std::chrono::milliseconds(100))) return;
        *last = {r.stage, now};
        out << "\r" << bar(r) << "\033[K" << std::flush;
    };
}

}  // namespace sombra

namespace sombra::host {

void Progress::begin(const std::string& stage, double units) {
    if (depth_++ > 0) return;
    silent_ = !(units > 0);
    stage_ = stage;
    total_ = std::max(units, 0.0), done_ = 0;
    base_fraction_ = 0, base_done_ = 0, fraction_ = 0;
    last_launch_ms = -1;
    start_ = clock_type::now();
    report(false, false);
}

void Progress::advance(double units) {
    if (depth_ == 0) return;
    done_ += units;
    double rest = total_ - base_done_;
    double f = rest > 0 ? base_fraction_ + (1 - base_fraction_) * (done_ - base_done_) / rest : 1.0;
    fraction_ = std::clamp(f, fraction_, 1.0);
    report(false, false);
}

void Progress::extend(double units) {
    if (depth_ == 0) return;
    base_fraction_ = fraction_, base_done_ = done_;
    total_ = std::max(total_, done_) + units;
}

void Progress::end(bool failed) {
    if (depth_ == 0 || --depth_ > 0) return;
    if (!failed) fraction_ = 1;
    report(true, failed);
}

void Progress::report(bool done, bool failed) {
    if (!callback || silent_) return;
    ProgressReport r;
    r.stage = stage_;
    r.fraction = fraction_;
    r.elapsed_ms = std::chrono::duration<double, std::milli>(clock_type::now() - start_).count();
    r.done = done, r.failed = failed;
    callback(r);
}

ProgressStage::ProgressStage(Progress& progress, const std::string& stage, double units)
    : progress_(progress), exceptions_(std::uncaught_exceptions()) {
    progress_.begin(stage, units);
}

ProgressStage::~ProgressStage() { progress_.end(std::uncaught_exceptions() > exceptions_); }

ProgressScope::ProgressScope(Progress& progress, ProgressCallback callback)
    : progress_(progress), previous_(std::move(progress.callback)) {
    progress_.callback = std::move(callback);
}

ProgressScope::~ProgressScope() { progress_.callback = std::move(previous_); }

}  // namespace sombra::host
