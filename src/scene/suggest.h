// sombra — "did you mean …?" for a misspelt name (command, option or JSON key), shared by the
// command line and the scene reader.
#pragma once
#include <algorithm>
#include <string>
#include <vector>

namespace sombra::detail {

// Optimal-string-alignment Damerau–Levenshtein distance: insertions, deletions, substitutions
// and transpositions of neighbours cost 1 each.
inline std::size_t edit_distance(const std::string& a, const std::string& b) {
    const std::size_t n = a.size(), m = b.size();
    std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
    for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= n; ++i)
        for (std::size_t j = 1; j <= m; ++j) {
            const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    return d[n][m];
}

// The candidate closest to `name` when it is close enough to be a likely typo (distance ≤ 2, or
// ≤ a third of the name's length for long names); "" when none is (or name is a candidate).
inline std::string closest_name(const std::string& name, const std::vector<std::string>& candidates) {
    if (name.size() > 256) return "";  // a hostile key: no quadratic work, no suggestion
    std::string best;
    std::size_t best_distance = std::max<std::size_t>(2, name.size() / 3) + 1;
    for (const std::string& c : candidates) {
        if (c == name) return "";
        const std::size_t d = edit_distance(name, c);
        if (d < best_distance) best = c, best_distance = d;
    }
    return best;
}

// " (did you mean 'X'?)" or "".
inline std::string did_you_mean(const std::string& name, const std::vector<std::string>& candidates) {
    const std::string best = closest_name(name, candidates);
    return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

}  // namespace sombra::detail
