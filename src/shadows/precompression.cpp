#include "shadows/precompression.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>

#include "shared/compress.h"
#include "sombra/error.h"

namespace sombra::shadows {
namespace {

// Transparency at which σ is capped (the TF table's convention: α = 1 ↦ σ = −ln(1e-6)/unit).
constexpr double kMinTransparency = 1e-6;

// Mean of −ln w over w ∈ [wa, wb] (either order), w ≥ kMinTransparency > 0: the average extinction
// (times opacity_unit) over a piece where α = 1 − w is linear in density.
double mean_neg_log(double wa, double wb) {
    double h = wb - wa, m = 0.5 * (wa + wb);
    if (std::fabs(h) < 1e-3 * std::min(wa, wb)) return -std::log(m) + h * h / (24.0 * m * m);  // Taylor, no cancellation
    auto K = [](double w) { return w - w * std::log(w); };  // antiderivative of −ln w
    return (K(wb) - K(wa)) / h;
}

// F(d) = ∫ σ(x) dx from the first opacity point to d, exact for the TF's piecewise-linear opacity
// (same interpolation as TransferFunction::opacity, constant beyond the end points) with σ capped.
class ExtinctionIntegral {
public:
    ExtinctionIntegral(const TransferFunction& tf, double opacity_unit) : inv_unit_(1.0 / opacity_unit) {
        const double cap = 1.0 - kMinTransparency;
        auto alpha = [&](std::size_t i) { return std::clamp(double(tf.opacity_points[i].alpha), 0.0, 1.0); };
        first_sigma_ = sigma_of(alpha(0));
        x_first_ = tf.opacity_points.front().x;
        double F = 0;
        for (std::size_t i = 0; i + 1 < tf.opacity_points.size(); ++i) {
            double x0 = tf.opacity_points[i].x, x1 = tf.opacity_points[i + 1].x;
            if (!(x1 > x0)) continue;  // a discontinuity: no width, no integral
            double a0 = alpha(i), a1 = alpha(i + 1);
            // split where α crosses the cap, so each piece is either linear-uncapped or constant σ_max
            if ((a0 < cap) != (a1 < cap) && a0 != a1) {
                double xs = x0 + (x1 - x0) * (cap - a0) / (a1 - a0);
                if (xs > x0 && xs < x1) {
                    F = push(x0, xs, a0, cap, F);
                    x0 = xs;
                    a0 = cap;
                }
            }
            F = push(x0, x1, a0, a1, F);
        }
        x_last_ = tf.opacity_points.back().x;
        F_last_ = F;
        last_sigma_ = sigma_of(alpha(tf.opacity_points.size() - 1));
    }

    double sigma_of(double a) const { return -std::log(std::max(1.0 - a, kMinTransparency)) * inv_unit_; }

    double operator()(double d) const {
        if (d <= x_first_) return first_sigma_ * (d - x_first_);
        if (d >= x_last_ || pieces_.empty()) return F_last_ + last_sigma_ * (d - x_last_);
        auto it = std::upper_bound(pieces_.begin(), pieces_.end(), d, [](double v, const Piece& p) { return v < p.x0; });
        const Piece& p = *(it - 1);
        double t = std::min(d, p.x1) - p.x0;
        if (p.capped) return p.F0 + t * max_sigma();
        double a = p.a0 + p.slope * t;
        return p.F0 + t * mean_neg_log(1.0 - p.a0, 1.0 - a) * inv_unit_;
    }

    // σ at density d (for constant-density segments).
    double sigma(double d, const TransferFunction& tf) const {
        return sigma_of(std::clamp(double(tf.opacity(float(d))), 0.0, 1.0));
    }

private:
    struct Piece {
        double x0, x1, a0, slope, F0;
        bool capped;
    };
    double max_sigma() const { return -std::log(kMinTransparency) * inv_unit_; }
    double push(double x0, double x1, double a0, double a1, double F0) {
        const double cap = 1.0 - kMinTransparency;
        Piece p{x0, x1, a0, (a1 - a0) / (x1 - x0), F0, std::min(a0, a1) >= cap};
        pieces_.push_back(p);
        double w = x1 - x0;
        return F0 + (p.capped ? w * max_sigma() : w * mean_neg_log(1.0 - a0, 1.0 - a1) * inv_unit_);
    }

    double inv_unit_;
    double x_first_ = 0, x_last_ = 0, F_last_ = 0, first_sigma_ = 0, last_sigma_ = 0;
    std::vector<Piece> pieces_;
};

struct Node {
    float f, alpha;
};

// Compresses V sampled at f_k = k/n (k = 1 … n; V(0) = 0) with the DSM compressor (cl/shared/compress.h).
// Samples 1 … n−1 go through compressor_add as in the DSM kernel. The end differs from
// compressor_finish: the node at f = 1 carries V(1) exactly (it is the whole step's opacity, which
// accumulates over every step of a ray, so a bias there would compound), not the wedge's middle line:
//  - if the exact slope from the current origin lies in the slope wedge, that line closes the function;
//  - otherwise a node is placed at f_{n−1} (inside the wedge, nearest V(f_{n−1})) before (1, V(1));
//  - V' is replaced by min(V', V(1)): the first node above V(1) moves back along its segment to where
//    that segment crosses V(1), and the nodes after it (all ≥ V(1)) are dropped. Since V ≤ V(1),
//    min(V', V(1)) stays within ε of every sample and monotone, and it never adds a node.
// The compressor's first node at f = 0 is the implicit origin and dropped. Returns the number of
// nodes, or limit + 1 as soon as more than `limit` are certain (nodes below V(1) all survive).
int compress_entry(const float* V, int n, float epsilon, std::vector<Node>& out, int limit) {
    out.clear();
    const float v1 = std::clamp(V[n - 1], 0.f, 1.f);
    int below = 0;  // emitted nodes with α < V(1): each one survives, and (1, V(1)) follows
    VisibilityCompressor c;
    compressor_init(&c, epsilon);
    auto take = [&](const CompressorOutput& o) {
        for (int i = 0; i < o.count; ++i) {
            if (out.empty() && o.z[i] <= 0.f) continue;  // implicit (0, 0)
            out.push_back({o.z[i], o.alpha[i]});
            below += o.alpha[i] < v1;
        }
    };
    float previous = 0.f;
    for (int k = 1; k < n; ++k) {
        float f = float(k) / float(n);
        take(compressor_add(&c, f, V[k - 1], previous));
        previous = f;
        if (below + 1 > limit) return limit + 1;
    }
    if (!c.started) {  // opacity 0 up to f_{n−1}
        if (v1 > 0.f) {
            out.push_back({previous, 0.f});
            out.push_back({1.f, v1});
        }
        return int(out.size());
    }
    const float slope = (v1 - c.origin_alpha) / (1.f - c.origin_z);
    if (!(slope >= c.m_lo && slope <= c.m_hi)) {
        const float pz = c.prev_z - c.origin_z;  // > 0 once started
        const float lo = c.origin_alpha + c.m_lo * pz, hi = c.origin_alpha + c.m_hi * pz;
        out.push_back({c.prev_z, std::clamp(c.prev_alpha, lo, hi)});  // within ε of every sample since the origin
    }
    std::size_t kept = 0;
    float f_prev = 0.f, a_prev = 0.f;  // the implicit origin
    for (std::size_t i = 0; i < out.size(); ++i) {
        Node node = out[i];
        if (node.alpha >= v1) {
            if (node.alpha > v1) {  // where the segment from the previous node crosses V(1)
                float f_cross = f_prev + (v1 - a_prev) / (node.alpha - a_prev) * (node.f - f_prev);
                if (f_cross > f_prev) node = {std::min(f_cross, node.f), v1};
                else if (kept) { out[kept - 1].alpha = v1; break; }  // crossing within rounding of it
                else node = {node.f, v1};
            }
            out[kept++] = node;
            break;  // the rest is flat at V(1)
        }
        out[kept++] = node;
        f_prev = node.f;
        a_prev = node.alpha;
    }
    out.resize(kept);
    if (!out.empty() && out.back().f >= 1.f) out.pop_back();
    out.push_back({1.f, v1});
    return int(out.size());
}

// max_k |V'(f_k) − V(f_k)| with V' clamped to [0, 1].
double entry_error(const std::vector<Node>& nodes, const double* V, int n) {
    double err = 0;
    std::size_t j = 0;  // first node with f ≥ current sample
    float f0 = 0.f, a0 = 0.f;
    for (int k = 1; k <= n; ++k) {
        float f = float(k) / float(n);
        while (j < nodes.size() && nodes[j].f < f) {
            f0 = nodes[j].f;
            a0 = nodes[j].alpha;
            ++j;
        }
        double v;
        if (j < nodes.size()) {
            const Node& b = nodes[j];
            double t = b.f > f0 ? (double(f) - f0) / (double(b.f) - f0) : 1.0;
            v = a0 + t * (double(b.alpha) - a0);
        } else {
            v = nodes.empty() ? 0.0 : a0;
        }
        v = std::clamp(v, 0.0, 1.0);
        err = std::max(err, std::fabs(v - V[k - 1]));
    }
    return err;
}

}  // namespace

int PrecompressionTable::index(float d) const {
    float u = std::clamp((d - domain_min) * domain_scale, 0.f, float(size - 1));
    return std::min(int(u + 0.5f), size - 1);
}

float PrecompressionTable::evaluate(int front, int back, float f) const {
    std::size_t e = entry(front, back);
    int count = counts[e];
    const float* fr = &fraction[e * kMaxNodes];
    const float* op = &opacity[e * kMaxNodes];
    float f0 = 0.f, a0 = 0.f;
    for (int i = 0; i < count; ++i) {
        if (f <= fr[i]) {
            float t = fr[i] > f0 ? (f - f0) / (fr[i] - f0) : 1.f;
            return std::clamp(a0 + t * (op[i] - a0), 0.f, 1.f);
        }
        f0 = fr[i];
        a0 = op[i];
    }
    return std::clamp(a0, 0.f, 1.f);
}

PrecompressionTable build_precompression_table(const TransferFunction& tf, float opacity_unit, float step, int size,
                                               float epsilon, int fine_samples) {
    const std::string where = "build_precompression_table";
    tf.validate(where + ": transfer function");
    if (!(opacity_unit > 0.f) || !std::isfinite(opacity_unit)) throw Error(where + ": opacity_unit must be > 0");
    if (!(step > 0.f) || !std::isfinite(step)) throw Error(where + ": step must be > 0");
    if (!(epsilon > 0.f) || !std::isfinite(epsilon)) throw Error(where + ": epsilon must be > 0");
    if (size < 2) throw Error(where + ": size must be at least 2");
    if (size > 4096) throw Error(where + ": size must be at most 4096");
    if (fine_samples < 2 || fine_samples > 65536) throw Error(where + ": fine_samples must lie in [2, 65536]");
    if (double(size - 1) * double(fine_samples) > double(1 << 26))
        throw Error(where + ": (size - 1) * fine_samples must be at most 2^26");

    PrecompressionTable table;
    table.size = size;
    const double lo = tf.domain_min(), hi = tf.domain_max();
    table.domain_min = float(lo);
    table.domain_scale = hi > lo ? float(size - 1) / float(hi - lo) : 0.f;
    table.opacity_unit = opacity_unit;
    table.step = step;
    table.epsilon = epsilon;
    table.fine_samples = fine_samples;
    const std::size_t entries = std::size_t(size) * std::size_t(size);
    table.fraction.assign(entries * PrecompressionTable::kMaxNodes, 0.f);
    table.opacity.assign(entries * PrecompressionTable::kMaxNodes, 0.f);
    table.counts.assign(entries, 0);

    // Every fine sample of every entry lies on one grid: d(f_k) = lo + h·(front + (back − front)·k/n)
    // = lo + (h/n)·(n·front + (back − front)·k) with h the table's density step. F (the antiderivative
    // of σ over density, exact) is tabulated on that grid once, so an entry's samples are lookups:
    // ∫₀^{f_k} σ(d(u)) du = (F(d(f_k)) − F(front)) / (back − front).
    const int n = fine_samples;
    const std::size_t axis = static_cast<std::size_t>(size);
    const std::size_t grid = std::size_t(size - 1) * std::size_t(n) + 1;
    const ExtinctionIntegral F(tf, opacity_unit);
    std::vector<double> F_grid(grid);
    for (std::size_t j = 0; j < grid; ++j)
        F_grid[j] = hi > lo ? F(lo + (hi - lo) * double(j) / double(grid - 1)) : 0.0;
    const double h = hi > lo ? (hi - lo) / double(size - 1) : 0.0;
    std::vector<double> sigma_at(axis);  // for front == back (or an empty domain)
    for (int i = 0; i < size; ++i) sigma_at[std::size_t(i)] = F.sigma(lo + h * i, tf);
    const double delta = step;
    constexpr int K = PrecompressionTable::kMaxNodes;

    std::atomic<int> next_row{0};
    unsigned threads = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(size)));
    std::vector<double> errors(threads, 0.0);
    std::vector<std::size_t> over(threads, 0);
    auto work = [&](unsigned t) {
        std::vector<double> V(static_cast<std::size_t>(n));
        std::vector<float> Vf(static_cast<std::size_t>(n));
        std::vector<Node> nodes;
        nodes.reserve(static_cast<std::size_t>(n) + 2);
        for (int front; (front = next_row.fetch_add(1)) < size;) {
            const std::size_t base = std::size_t(front) * std::size_t(n);
            for (int back = 0; back < size; ++back) {
                if (back == front || h == 0.0) {
                    double s = sigma_at[std::size_t(front)] * delta;
                    for (int k = 1; k <= n; ++k) V[std::size_t(k - 1)] = -std::expm1(-s * double(k) / n);
                } else {
                    const long m = long(back) - long(front);
                    const double scale = delta / (double(m) * h);
                    const double F0 = F_grid[base];
                    for (int k = 1; k <= n; ++k) {
                        double tau = (F_grid[std::size_t(long(base) + m * k)] - F0) * scale;
                        V[std::size_t(k - 1)] = -std::expm1(-std::max(0.0, tau));
                    }
                }
                bool any = false;
                for (int k = 0; k < n; ++k) {
                    Vf[std::size_t(k)] = float(V[std::size_t(k)]);
                    any = any || Vf[std::size_t(k)] > 0.f;
                }
                if (!any) continue;  // empty space: no nodes
                int count = compress_entry(Vf.data(), n, epsilon, nodes, K);
                if (count > K) {
                    // Over budget: the smallest ε (doubling, then bisection) for which ≤ 4 nodes suffice.
                    ++over[t];
                    float bad = epsilon, good = epsilon;
                    do {
                        bad = good;
                        good *= 2.f;
                        count = compress_entry(Vf.data(), n, good, nodes, K);
                    } while (count > K && good < 4.f);
                    for (int i = 0; i < 6 && count <= K; ++i) {
                        float mid = 0.5f * (bad + good);
                        if (compress_entry(Vf.data(), n, mid, nodes, K) <= K) good = mid;
                        else bad = mid;
                    }
                    count = compress_entry(Vf.data(), n, good, nodes, K);
                    if (count > K) {  // not expected (ε ≥ 1 needs ≤ 3 nodes); keep a chord
                        nodes = {Node{1.f, std::clamp(Vf[std::size_t(n - 1)], 0.f, 1.f)}};
                        count = 1;
                    }
                }
                const std::size_t e = table.entry(front, back);
                table.counts[e] = static_cast<unsigned char>(count);
                for (int i = 0; i < count; ++i) {
                    table.fraction[e * K + std::size_t(i)] = nodes[std::size_t(i)].f;
                    table.opacity[e * K + std::size_t(i)] = nodes[std::size_t(i)].alpha;
                }
                errors[t] = std::max(errors[t], entry_error(nodes, V.data(), n));
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& th : pool) th.join();
    for (unsigned t = 0; t < threads; ++t) {
        table.max_error = std::max(table.max_error, errors[t]);
        table.entries_over_budget += over[t];
    }
    return table;
}

}  // namespace sombra::shadows
