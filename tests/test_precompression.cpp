// Pre-compression table (Hadwiger et al. 2006 §3.2): per (front, back) density pair the compressed
// visibility of one step over a linear density ramp. V is recomputed here independently by brute
// force (midpoint rule, 10× the table's fine samples, TransferFunction::opacity in double).
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "shadows/precompression.h"

using sombra::TransferFunction;
using sombra::shadows::build_precompression_table;
using sombra::shadows::PrecompressionTable;

namespace {

constexpr int K = PrecompressionTable::kMaxNodes;

TransferFunction make_tf(std::vector<TransferFunction::OpacityPoint> opacity, float lo, float hi) {
    TransferFunction tf;
    tf.color_points = {{lo, 1, 1, 1}, {hi, 1, 1, 1}};
    tf.opacity_points = std::move(opacity);
    return tf;
}

// V(f_k), k = 1 … n, for the ramp front → back: midpoint rule with `refine` sub-intervals per sample.
std::vector<double> brute_force_visibility(const TransferFunction& tf, double unit, double step, double front,
                                           double back, int n, int refine = 10) {
    const double max_sigma = -std::log(1e-6) / unit;
    const int m = n * refine;
    std::vector<double> V(static_cast<std::size_t>(n));
    double tau = 0;
    for (int s = 0; s < m; ++s) {
        double u = (s + 0.5) / m;
        double alpha = std::clamp(double(tf.opacity(float(front + (back - front) * u))), 0.0, 1.0);
        double sigma = alpha >= 1.0 ? max_sigma : std::min(max_sigma, -std::log1p(-alpha) / unit);
        tau += sigma * step / m;
        if ((s + 1) % refine == 0) V[std::size_t((s + 1) / refine - 1)] = -std::expm1(-tau);
    }
    return V;
}

struct TableCheck {
    double worst = 0;                  // largest |V' − V| against the brute force
    std::size_t over_epsilon = 0;      // entries with an error above ε (must be over budget)
    std::size_t inexact_last = 0;      // entries whose last node differs from V(1) by more than 1e-5
};

// Checks every entry against the brute-force V.
TableCheck require_valid_table(const PrecompressionTable& t, const TransferFunction& tf, float unit, float step,
                               float epsilon, int n) {
    TableCheck check;
    for (int front = 0; front < t.size; ++front)
        for (int back = 0; back < t.size; ++back) {
            std::size_t e = t.entry(front, back);
            int count = t.counts[e];
            const float* fr = &t.fraction[e * K];
            const float* op = &t.opacity[e * K];
            std::vector<double> V = brute_force_visibility(tf, unit, step, t.density(front), t.density(back), n);
            bool empty = std::all_of(V.begin(), V.end(), [](double v) { return v == 0.0; });
            INFO("entry (" << front << ", " << back << "), count " << count);
            for (int i = 0; i < count; ++i) {
                REQUIRE(std::isfinite(fr[i]));
                REQUIRE(std::isfinite(op[i]));
                REQUIRE(fr[i] > 0.f);
                REQUIRE(fr[i] <= 1.f);
                REQUIRE(op[i] >= 0.f);
                REQUIRE(op[i] <= 1.f);
                if (i) {
                    REQUIRE(fr[i] > fr[i - 1]);   // sorted
                    REQUIRE(op[i] >= op[i - 1]);  // monotone
                }
            }
            for (int i = count; i < K; ++i) REQUIRE(fr[i] == 0.f);  // unused
            double entry_error = 0;
            for (int k = 1; k <= n; ++k) {
                double err = std::fabs(double(t.evaluate(front, back, float(k) / float(n))) - V[std::size_t(k - 1)]);
                entry_error = std::max(entry_error, err);
            }
            check.worst = std::max(check.worst, entry_error);
            if (entry_error > epsilon + 1e-5) ++check.over_epsilon;
            // the table's own bound (≤ ε within budget), up to the brute force's own error near the
            // α = 1 cap (measured up to 1.25e-4 since nodes sit on the function, issue 27 item 2)
            REQUIRE(entry_error <= t.max_error + 2e-4);
            if (empty) {
                REQUIRE(count == 0);  // empty space: no nodes
            } else {
                REQUIRE(count >= 1);
                REQUIRE(count <= K);
                REQUIRE(fr[count - 1] == 1.f);  // last node at f = 1, within ε of V(1)
                REQUIRE(std::fabs(op[count - 1] - V.back()) <= epsilon + 1e-5);
                if (std::fabs(op[count - 1] - V.back()) > 1e-5) ++check.inexact_last;
                // in fact exact (the whole step's opacity); the brute force itself is off by up to ~1e-4 where
                // the ramp runs into the α = 1 cap (σ = −ln(1 − α) is steep there)
                REQUIRE(std::fabs(op[count - 1] - V.back()) <= 5e-4);
            }
        }
    return check;
}

}  // namespace

TEST_CASE("pre-compression: constant opacity gives one exact segment per entry", "[precompression]") {
    const float alpha = 0.3f, unit = 1.f, step = 0.5f, epsilon = 0.01f;
    TransferFunction tf = make_tf({{0.f, alpha}, {1.f, alpha}}, 0.f, 1.f);
    PrecompressionTable t = build_precompression_table(tf, unit, step, 32, epsilon);
    REQUIRE(t.size == 32);
    REQUIRE(t.counts.size() == 32u * 32u);
    REQUIRE(t.fraction.size() == 32u * 32u * K);
    const double exact = 1.0 - std::pow(1.0 - double(alpha), double(step / unit));
    for (std::size_t e = 0; e < t.counts.size(); ++e) {
        REQUIRE(t.counts[e] >= 1);
        REQUIRE(t.counts[e] <= 2);
        REQUIRE(t.counts[e] == 1);  // the origin (0, 0) is implicit: one node (1, V(1))
        REQUIRE(t.fraction[e * K] == 1.f);
        REQUIRE(std::fabs(t.opacity[e * K] - exact) <= 1e-6);
        for (int i = 1; i < K; ++i) REQUIRE(t.fraction[e * K + i] == 0.f);
    }
    REQUIRE(t.entries_over_budget == 0);
    REQUIRE(t.max_error <= epsilon);
    REQUIRE(t.evaluate(3, 7, 0.5f) == Approx(0.5 * exact).margin(1e-6));
    SUCCEED("constant TF: max error " << t.max_error);
}

TEST_CASE("pre-compression: random piecewise-linear TFs, every entry against brute force", "[precompression]") {
    std::mt19937 rng(20060706);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const int size = 40, n = 256;
    for (int trial = 0; trial < 4; ++trial) {
        float lo = -3.f + 2.f * u(rng), hi = lo + 1.f + 4.f * u(rng);
        int points = 2 + int(u(rng) * 6);
        std::vector<TransferFunction::OpacityPoint> op;
        float x = lo + 0.2f * (hi - lo) * u(rng);  // color points extend past the opacity points
        for (int i = 0; i < points && x <= hi; ++i) {
            float r = u(rng), a = r < 0.3f ? 0.f : r < 0.4f ? 1.f : r < 0.5f ? 0.99f : u(rng);
            op.push_back({x, a});
            x += (0.03f + 0.3f * u(rng)) * (hi - lo);
        }
        TransferFunction tf = make_tf(op, lo, hi);
        float unit = 0.5f + u(rng), step = unit * (0.1f + 1.5f * u(rng)), epsilon = trial == 0 ? 0.002f : 0.01f;
        PrecompressionTable t = build_precompression_table(tf, unit, step, size, epsilon, n);
        REQUIRE(t.size == size);
        REQUIRE(t.domain_min == lo);
        REQUIRE(t.domain_scale == Approx(float(size - 1) / (hi - lo)));
        TableCheck check = require_valid_table(t, tf, unit, step, epsilon, n);
        // entries whose error exceeds ε are exactly the ones that needed more than 4 nodes
        REQUIRE(check.over_epsilon <= t.entries_over_budget);
        if (t.entries_over_budget == 0) REQUIRE(t.max_error <= epsilon + 1e-6);
        // the table's own error estimate agrees with the independent brute force
        REQUIRE(std::fabs(check.worst - t.max_error) <= 2e-4);  // the brute force near the α = 1 cap: measured 1.25e-4
        std::size_t empty = std::count(t.counts.begin(), t.counts.end(), 0);
        SUCCEED("random TF " << trial << " (" << op.size() << " points, step/unit " << step / unit << ", eps "
                             << epsilon << "): max error " << t.max_error << " (brute force " << check.worst
                             << "), entries over budget " << t.entries_over_budget << " of " << t.counts.size()
                             << ", empty entries " << empty << ", last node off V(1) by > 1e-5: "
                             << check.inexact_last);
    }
}

TEST_CASE("pre-compression: an isosurface step inside a segment is placed where it lies", "[precompression]") {
    // opacity 0 below the threshold, 0.9 above (a discontinuity: two points at the same x)
    const float threshold = 0.3f, unit = 1.f, step = 1.f, epsilon = 0.02f;
    const int size = 256, n = 256;
    TransferFunction tf = make_tf({{0.f, 0.f}, {threshold, 0.f}, {threshold, 0.9f}, {1.f, 0.9f}}, 0.f, 1.f);
    auto t0 = std::chrono::steady_clock::now();
    PrecompressionTable t = build_precompression_table(tf, unit, step, size, epsilon, n);
    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const int below = t.index(threshold) - (t.density(t.index(threshold)) > threshold ? 1 : 0);
    double worst_pre = 0, worst_plain = 0;
    int checked = 0;
    for (int front = 0; front <= below; front += 7)
        for (int back = below + 1; back < size; back += 5) {
            double df = t.density(front), db = t.density(back);
            REQUIRE(df < threshold);
            REQUIRE(db > threshold);
            double f_star = (threshold - df) / (db - df);
            std::size_t e = t.entry(front, back);
            int count = t.counts[e];
            REQUIRE(count >= 2);
            // the rise: the node where the opacity leaves 0
            REQUIRE(t.opacity[e * K] == 0.f);
            double rise = t.fraction[e * K];
            double err_pre = std::fabs(rise - f_star);
            // plain sampling at the step's end puts the whole step's opacity at f = 1
            double err_plain = std::fabs(1.0 - f_star);
            INFO("entry (" << front << ", " << back << "): f* " << f_star << ", rise " << rise);
            REQUIRE(err_pre <= 1.0 / n + 1e-6);
            if (f_star < 1.0 - 2.0 / n) REQUIRE(err_plain > err_pre);
            REQUIRE(t.evaluate(front, back, float(rise)) == 0.f);  // nothing before the surface
            if (rise > 1e-3) REQUIRE(t.evaluate(front, back, float(rise) - 1e-3f) == 0.f);
            double v1 = 1.0 - std::pow(0.1, (1.0 - f_star) * step / unit);
            REQUIRE(t.opacity[e * K + count - 1] == Approx(v1).margin(1e-4));  // the whole step, exact
            worst_pre = std::max(worst_pre, err_pre);
            worst_plain = std::max(worst_plain, err_plain);
            ++checked;
        }
    REQUIRE(checked > 100);
    // The reversed direction (leaving the material): opacity from f = 0, flat after f*.
    {
        int front = size - 1, back = 0;
        double f_star = (threshold - 1.0) / (0.0 - 1.0);
        float v1 = t.evaluate(front, back, 1.f);
        REQUIRE(v1 == Approx(1.0 - std::pow(0.1, f_star * step / unit)).margin(1e-5));
        REQUIRE(t.evaluate(front, back, float(f_star) + 2.f / n) >= v1 - epsilon - 1e-5f);
    }
    // The entry from the worked example.
    {
        int front = 20, back = 200;
        double f_star = (threshold - t.density(front)) / (t.density(back) - t.density(front));
        double rise = t.fraction[t.entry(front, back) * K];
        SUCCEED("step TF, entry (20, 200): f* " << f_star << ", pre-compressed rise at " << rise << " (error "
                                                << std::fabs(rise - f_star) << "), plain sampling at f = 1 (error "
                                                << 1.0 - f_star << ")");
    }
    SUCCEED("step TF (size " << size << ", " << n << " fine samples, eps " << epsilon << "): built in " << ms
                             << " ms; " << checked << " entries straddling the surface: max rise error "
                             << worst_pre << " (pre-compressed) vs " << worst_plain
                             << " (plain); max error " << t.max_error << ", entries over budget "
                             << t.entries_over_budget);
}

TEST_CASE("pre-compression: build time for size 256", "[precompression]") {
    TransferFunction tf = make_tf({{0.f, 0.f}, {0.2f, 0.05f}, {0.45f, 0.f}, {0.5f, 0.8f}, {0.55f, 0.1f},
                                   {0.8f, 1.f}, {1.f, 0.6f}},
                                  0.f, 1.f);
    const float epsilon = 0.01f;
    auto t0 = std::chrono::steady_clock::now();
    PrecompressionTable t = build_precompression_table(tf, 1.f, 0.5f, 256, epsilon);
    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    REQUIRE(t.counts.size() == 256u * 256u);
    if (t.entries_over_budget == 0) REQUIRE(t.max_error <= epsilon + 1e-6);
    std::size_t nodes = 0;
    for (unsigned char c : t.counts) nodes += c;
    SUCCEED("size 256 × 256 entries × 256 fine samples: built in " << ms << " ms, max error " << t.max_error
                                                                    << ", entries over budget "
                                                                    << t.entries_over_budget << ", mean nodes/entry "
                                                                    << double(nodes) / double(t.counts.size()));
}
