#pragma once
// Parameter checks shared by the model kinds (models.cpp, kernels.cpp). Each throws
// hysteron::Error naming the model and the key.
#include <cmath>
#include <cstddef>
#include <span>
#include <string_view>

#include "format.hpp"
#include "hysteron/error.hpp"
#include "hysteron/models.hpp"

namespace hysteron::detail {

inline void require_finite(double v, std::string_view model, std::string_view key) {
  if (!std::isfinite(v)) throw Error(detail::format("{}: {} must be a finite number, got {}", model, key, v));
}

inline void check_limits(const Limits& l, std::string_view model) {
  if (std::isnan(l.lo) || std::isnan(l.hi) || !(l.lo < l.hi))
    throw Error(detail::format("{}: input_limits must satisfy lo < hi, got [{}, {}]", model, l.lo, l.hi));
}

// Snapshots (Model, Inverse, Pid: snapshot() / restore()): the size, a finite value, and a
// count or a flag stored as a double. WHAT names the object ("gpi: snapshot").
inline void check_snapshot_size(std::span<const double> s, std::size_t size, std::string_view what) {
  if (s.size() != size) throw Error(detail::format("{} has {} values, expected {}", what, s.size(), size));
}
inline double snapshot_finite(double v, std::string_view what) {
  if (!std::isfinite(v)) throw Error(detail::format("{} = {} is not finite", what, v));
  return v;
}
inline std::size_t snapshot_count(double v, std::string_view what, double max = 9007199254740992.0) {
  if (!(v >= 0 && v <= max && v == std::floor(v)))
    throw Error(detail::format("{} = {} must be a whole number in 0..{}", what, v, max));
  return static_cast<std::size_t>(v);
}

}  // namespace hysteron::detail
