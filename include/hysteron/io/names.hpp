#pragma once
// Close-name suggestions for error messages ("did you mean ...?"), shared by the CLI and
// the library's own parsers.
#include <cstddef>
#include <string_view>

namespace hysteron::io {

// Edit distance: insertions, deletions, substitutions and adjacent swaps each cost 1.
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace hysteron::io
