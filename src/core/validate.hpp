#pragma once
// Parameter checks shared by the model kinds (models.cpp, kernels.cpp). Each throws
// hysteron::Error naming the model and the key.
#include <cmath>
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

}  // namespace hysteron::detail
