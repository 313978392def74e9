#pragma once
// Helpers shared by the generated-C writers (export_c.cpp, export_loop.cpp, export_learning.cpp).
#include <fmt/format.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>

#include "hysteron/error.hpp"

namespace hysteron::io::detail {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A C double literal that reads back to the same double: the shortest round-trip
// decimal (fmt's "{}"), with ".0" added to integers; +-HUGE_VAL for infinities.
inline std::string num(double v) {
  if (std::isinf(v)) return v > 0 ? "HUGE_VAL" : "-HUGE_VAL";
  if (std::isnan(v)) throw Error("export: a constant of the model is NaN (this is a bug)");
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

// Counts of samples in the generated C are size_t constants; 2^31 - 1 fits every target's.
constexpr std::size_t kMaxCount = 2147483647u;

// A count as a C size_t literal; throws Error naming `what` if generated C cannot hold it.
inline std::string count_literal(std::size_t v, const char* what) {
  if (v > kMaxCount)
    throw Error(fmt::format("{} = {} samples is more than generated C holds (at most {})", what, v, kMaxCount));
  return fmt::format("{}u", v);
}

inline void replace_all(std::string& s, std::string_view from, std::string_view to) {
  for (std::size_t pos = 0; (pos = s.find(from, pos)) != std::string::npos; pos += to.size()) s.replace(pos, from.size(), to);
}

// Text for a C comment: no "*/", no control characters.
inline std::string comment_safe(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  replace_all(s, "*/", "* /");
  return s;
}

}  // namespace hysteron::io::detail
