#pragma once
// A minimal "{}" formatter for the error messages of the real-time core, which
// depends on the C++ standard library only (no fmt). Numbers are written in
// their shortest round-trip form (std::to_chars), like fmt's "{}". Used only
// at set-up, never in a per-sample step().
#include <charconv>
#include <string>
#include <string_view>
#include <type_traits>

namespace hysteron::detail {

template <class T>
void append_arg(std::string& out, const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    out += v ? "true" : "false";
  } else if constexpr (std::is_arithmetic_v<T>) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, r.ptr);
  } else {
    out += std::string_view(v);
  }
}

// format("{}: got {}", where, x): each "{}" takes the next argument in order.
template <class... Args>
std::string format(std::string_view pattern, const Args&... args) {
  std::string out;
  out.reserve(pattern.size() + 16 * sizeof...(Args));
  std::size_t pos = 0;
  auto next = [&](const auto& v) {
    const std::size_t at = pattern.find("{}", pos);
    if (at == std::string_view::npos) return;
    out.append(pattern.substr(pos, at - pos));
    append_arg(out, v);
    pos = at + 2;
  };
  (next(args), ...);
  out.append(pattern.substr(pos));
  return out;
}

}  // namespace hysteron::detail
