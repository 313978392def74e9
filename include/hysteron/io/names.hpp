#pragma once
// Close-name suggestions for error messages ("did you mean ...?"), shared by the CLI and
// the library's own parsers.
#include <algorithm>
#include <cstddef>
#include <limits>
#include <string_view>

namespace hysteron::io {

// Edit distance: insertions, deletions, substitutions and adjacent swaps each cost 1.
std::size_t edit_distance(std::string_view a, std::string_view b);

// The candidate closest to `name` where `name` looks like a typo of it (edit distance at most
// max(2, |name| / 3)), else "": the "did you mean" of unknown keys (the rig parameters', a
// loop's). Candidates: anything a std::string_view is made from.
template <class Range>
std::string_view closest_name(std::string_view name, const Range& candidates) {
  std::string_view hint;
  std::size_t best = std::numeric_limits<std::size_t>::max();
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(name, c);
    if (d < best && d <= std::max<std::size_t>(2, name.size() / 3)) best = d, hint = c;
  }
  return hint;
}

}  // namespace hysteron::io
