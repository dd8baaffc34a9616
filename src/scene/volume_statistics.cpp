// sombra — a volume's value statistics (sombra info) and the transfer-function presets of volume
// scenes derived from them.
#include <algorithm>
#include <cmath>

#include "sombra/error.h"
#include "sombra/scene.h"

namespace sombra {
namespace {

constexpr std::size_t kMaxExactVoxels = std::size_t(1) << 24;

// Percentiles (linear between the closest ranks) of `values`, which are reordered.
std::array<double, 7> percentiles_of(std::vector<float>& values) {
    std::array<double, 7> out{};
    if (values.empty()) return out;
    auto begin = values.begin();  // the percentiles ascend: each selection needs only the rest
    for (std::size_t i = 0; i < out.size(); ++i) {
        const double position = VolumeStatistics::kPercentiles[i] / 100.0 * double(values.size() - 1);
        const std::size_t k = std::size_t(position);
        std::nth_element(begin, values.begin() + std::ptrdiff_t(k), values.end());
        begin = values.begin() + std::ptrdiff_t(k);
        double lo = values[k], hi = lo;
        if (k + 1 < values.size()) hi = *std::min_element(values.begin() + std::ptrdiff_t(k + 1), values.end());
        out[i] = lo + (position - double(k)) * (hi - lo);
    }
    return out;
}

}  // namespace

VolumeStatistics volume_statistics(const Volume& volume, int bins) {
    VolumeStatistics s;
    s.voxels = volume.voxels.size();
    s.histogram.assign(std::size_t(std::max(bins, 1)), 0);
    if (volume.voxels.empty()) return s;
    double lo = volume.voxels.front(), hi = lo, sum = 0;
    for (float v : volume.voxels) lo = std::min(lo, double(v)), hi = std::max(hi, double(v)), sum += v;
    s.min = lo, s.max = hi, s.mean = sum / double(s.voxels);
    s.background_threshold = lo + 0.01 * (hi - lo);
    const std::size_t stride = (s.voxels + kMaxExactVoxels - 1) / kMaxExactVoxels;
    std::vector<float> all, foreground;
    all.reserve(s.voxels / stride + 1);
    for (std::size_t i = 0; i < s.voxels; i += stride) all.push_back(volume.voxels[i]);
    const double width = (hi - lo) / double(s.histogram.size());
    for (float v : volume.voxels) {
        if (v <= s.background_threshold) ++s.background_voxels;
        std::size_t bin = width > 0 ? std::size_t((v - lo) / width) : 0;
        ++s.histogram[std::min(bin, s.histogram.size() - 1)];
    }
    for (float v : all)
        if (v > s.background_threshold) foreground.push_back(v);
    s.percentiles = percentiles_of(all);
    s.foreground_percentiles = foreground.empty() ? s.percentiles : percentiles_of(foreground);
    return s;
}

TransferPreset parse_transfer_preset(const std::string& name) {
    if (name == "auto") return TransferPreset::Auto;
    if (name == "ct") return TransferPreset::Ct;
    if (name == "mri") return TransferPreset::Mri;
    if (name == "fog") return TransferPreset::Fog;
    throw Error("unknown preset '" + name + "' (auto, ct, mri, fog)");
}

const char* transfer_preset_name(TransferPreset preset) {
    switch (preset) {
        case TransferPreset::Ct: return "ct";
        case TransferPreset::Mri: return "mri";
        case TransferPreset::Fog: return "fog";
        default: return "auto";
    }
}

TransferPreset choose_transfer_preset(const VolumeStatistics& s, const std::string& format) {
    if (s.min < -200 || s.max - s.min > 1000) return TransferPreset::Ct;
    if (format == "vdb") return TransferPreset::Fog;
    if (s.min >= 0 && s.max <= 1 && double(s.background_voxels) > 0.4 * double(s.voxels)) return TransferPreset::Fog;
    if (double(s.background_voxels) < 0.2 * double(s.voxels)) return TransferPreset::Ct;  // the data fill the box
    return TransferPreset::Mri;
}

TransferFunction preset_transfer_function(const VolumeStatistics& s, TransferPreset preset) {
    const auto& fg = s.foreground_percentiles;  // p1 p5 p25 p50 p75 p95 p99
    const double top = s.max > s.min ? s.max : s.min + 1;
    // (value, opacity, r, g, b) rows; values made non-decreasing (percentiles of integer data coincide)
    struct Row { double x, a, r, g, b; };
    std::vector<Row> rows;
    switch (preset) {
        case TransferPreset::Ct:
            rows = {{s.min, 0, 0, 0, 0}, {fg[4], 0, 0.55, 0.25, 0.2}, {fg[5], 0.05, 0.9, 0.75, 0.6},
                    {fg[6], 0.6, 0.97, 0.92, 0.85}, {top, 0.9, 1, 1, 1}};
            break;
        case TransferPreset::Mri:
            rows = {{s.min, 0, 0, 0, 0}, {fg[2], 0, 0.7, 0.5, 0.45}, {fg[3], 0.05, 0.8, 0.62, 0.55},
                    {fg[5], 0.25, 0.92, 0.85, 0.78}, {top, 0.6, 1, 1, 1}};
            break;
        case TransferPreset::Fog:
            rows = {{s.background_threshold, 0, 0.85, 0.85, 0.88}, {fg[3], 0.1, 0.92, 0.92, 0.94}, {fg[6], 0.3, 0.97, 0.97, 0.98},
                    {top, 0.5, 1, 1, 1}};
            break;
        default: throw Error("preset_transfer_function: choose a preset first (choose_transfer_preset)");
    }
    TransferFunction tf;
    double x = rows.front().x;
    for (const Row& row : rows) {
        x = std::min(std::max(x, row.x), top);
        tf.color_points.push_back({float(x), float(row.r), float(row.g), float(row.b)});
        tf.opacity_points.push_back({float(x), float(row.a)});
    }
    return tf;
}

}  // namespace sombra
