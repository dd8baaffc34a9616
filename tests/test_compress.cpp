// On-the-fly visibility compression (cl/shared/compress.h, the code the DSM kernel runs): property
// tests over many random visibility functions plus the stiff and extreme cases of docs/architecture.md.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "shared/compress.h"

namespace {

struct Sample { float z, alpha; };
struct Node { float z, alpha; };

std::vector<Node> compress(const std::vector<Sample>& samples, float epsilon, float first_z) {
    VisibilityCompressor c;
    compressor_init(&c, epsilon);
    std::vector<Node> nodes;
    auto take = [&](const CompressorOutput& out) {
        for (int i = 0; i < out.count; ++i) nodes.push_back({out.z[i], out.alpha[i]});
    };
    float previous_z = first_z;
    for (const Sample& s : samples) {
        take(compressor_add(&c, s.z, s.alpha, previous_z));
        previous_z = s.z;
    }
    take(compressor_finish(&c));
    return nodes;
}

// V'(z): Knecht Eq. 3.7, clamped to [0, 1] as the lookups do.
float evaluate(const std::vector<Node>& nodes, float z) {
    if (nodes.empty() || z < nodes.front().z) return 0.f;
    if (z >= nodes.back().z) return std::clamp(nodes.back().alpha, 0.f, 1.f);
    auto upper = std::upper_bound(nodes.begin(), nodes.end(), z, [](float v, const Node& n) { return v < n.z; });
    const Node& b = *upper;
    const Node& a = *(upper - 1);
    float f = b.z > a.z ? (z - a.z) / (b.z - a.z) : 1.f;
    return std::clamp(a.alpha + f * (b.alpha - a.alpha), 0.f, 1.f);
}

// A random visibility function: opacity accumulated (Knecht Eq. 3.2) over samples at random
// increasing depths, with empty runs, smooth media, isosurface-like steps and saturation.
std::vector<Sample> random_function(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.f, 1.f);
    int n = 1 + int(u(rng) * 80);
    float z = u(rng) * 100.f, transmittance = 1.f;
    int kind = int(u(rng) * 4);
    std::vector<Sample> out;
    for (int i = 0; i < n; ++i) {
        z += 0.01f + u(rng) * (kind == 3 ? 0.001f : 2.f);  // kind 3: tiny separations far away
        float r = u(rng), a;
        if (kind == 0) a = r < 0.6f ? 0.f : r * 0.2f;           // sparse
        else if (kind == 1) a = r < 0.1f ? 1.f : r * 0.05f;     // steps
        else a = r * r * 0.3f;                                  // smooth
        transmittance *= 1.f - a;
        out.push_back({z, 1.f - transmittance});
    }
    return out;
}

void require_valid(const std::vector<Sample>& samples, const std::vector<Node>& nodes, float epsilon) {
    for (const Sample& s : samples) {
        float v = evaluate(nodes, s.z);
        REQUIRE(std::isfinite(v));
        REQUIRE(std::fabs(v - s.alpha) <= epsilon + 2e-5f);  // Knecht Eq. 3.1 (+ float rounding)
    }
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        REQUIRE(std::isfinite(nodes[i].alpha));
        REQUIRE(nodes[i].alpha >= 0.f);
        if (i) {
            REQUIRE(nodes[i].z >= nodes[i - 1].z);
            REQUIRE(nodes[i].alpha >= nodes[i - 1].alpha - 1e-6f);  // monotone
        }
    }
    REQUIRE(nodes.size() <= samples.size() + 1);  // + the node where opacity leaves 0
}

}  // namespace

TEST_CASE("compressor: error ≤ ε, monotone, few nodes, over 100 000 random functions", "[compress]") {
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::size_t total_samples = 0, total_nodes = 0;
    for (int trial = 0; trial < 100000; ++trial) {
        auto samples = random_function(rng);
        float epsilon = trial % 10 == 0 ? 0.f : u(rng) * 0.2f;
        auto nodes = compress(samples, epsilon, samples.front().z - 0.5f);
        require_valid(samples, nodes, epsilon);
        total_samples += samples.size();
        total_nodes += nodes.size();
    }
    INFO("nodes per sample: " << double(total_nodes) / double(total_samples));
    CHECK(total_nodes < total_samples);  // compression compresses
}

TEST_CASE("compressor: ε = 0 keeps every sample after the first opaque one, ε ≥ 1 one segment", "[compress]") {
    std::vector<Sample> s;
    float t = 1.f;
    for (int i = 0; i < 50; ++i) s.push_back({float(i), 1.f - (t *= 0.9f)});  // strictly concave: no 3 collinear
    auto exact = compress(s, 0.f, -1.f);
    CHECK(exact.size() == s.size() + 1);
    require_valid(s, exact, 0.f);
    for (float epsilon : {1.f, 5.f}) {
        auto one = compress(s, epsilon, -1.f);
        CHECK(one.size() == 2);
        require_valid(s, one, epsilon);
    }
}

TEST_CASE("compressor: empty space produces no nodes — a saturating step stays exact", "[compress][numerics]") {
    std::vector<Sample> empty{{1.f, 0.f}, {2.f, 0.f}, {3.f, 0.f}};
    CHECK(compress(empty, 0.01f, 0.f).empty());
    // σΔ ≫ 1: opacity jumps from 0 to 1 in one step, then stays
    std::vector<Sample> stiff{{1.f, 0.f}, {2.f, 0.f}, {3.f, 1.f}, {4.f, 1.f}, {50.f, 1.f}};
    auto nodes = compress(stiff, 0.01f, 0.f);
    require_valid(stiff, nodes, 0.01f);
    CHECK(nodes.front().z == 2.f);  // opacity leaves 0 after the last empty sample
    CHECK(evaluate(nodes, 2.5f) == Approx(0.5f).margin(0.02));
}
