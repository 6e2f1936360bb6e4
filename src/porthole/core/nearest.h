// The names nearest a mistyped one, for "did you mean …" in errors (TOML keys, presets): Levenshtein
// distance over the names as given (callers normalise case and spacing first when that matters).
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace porthole {

// Insertions, deletions, substitutions and swaps of two neighbouring characters that turn `a` into
// `b` (the optimal-string-alignment distance: "tpye" is one edit from "type").
inline std::size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev2(b.size() + 1), prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) cur[j] = std::min(cur[j], prev2[j - 2] + 1);
    }
    std::swap(prev2, prev);
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// Up to `k` of `candidates` nearest `name`, nearest first (ties in the candidates' order), keeping
// only those within `max_distance` edits.
inline std::vector<std::string> NearestNames(std::string_view name, const std::vector<std::string>& candidates,
                                             std::size_t k, std::size_t max_distance) {
  std::vector<std::pair<std::size_t, std::size_t>> scored;  // (distance, index)
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const std::size_t d = EditDistance(name, candidates[i]);
    if (d <= max_distance) scored.emplace_back(d, i);
  }
  std::stable_sort(scored.begin(), scored.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<std::string> out;
  for (std::size_t i = 0; i < scored.size() && i < k; ++i) out.push_back(candidates[scored[i].second]);
  return out;
}

// How many edits a key of this length may have and still be taken for a typo of a known one: a
// third of its length, at least 1 and at most 3 ("radus_mm" → "radius_mm", not "x" → "n").
inline std::size_t TypoDistance(std::string_view name) {
  return std::clamp<std::size_t>(name.size() / 3, 1, 3);
}

}  // namespace porthole
