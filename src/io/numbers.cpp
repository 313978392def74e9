// Numbers read from text (numbers.hpp).
#include "hysteron/io/numbers.hpp"

#include <locale.h>
#include <stdlib.h>

#include <charconv>
#include <cmath>
#include <string>

namespace hysteron::io {

NumberParse parse_number(std::string_view s, double& out) {
  if (s.empty()) return NumberParse::empty;
  // from_chars takes neither '+' nor space nor "0x" in its general format; a second sign
  // ("++5", "+-5") is malformed
  if (s.front() == '+') {
    s.remove_prefix(1);
    if (s.empty() || s.front() == '+' || s.front() == '-') return NumberParse::malformed;
  }
  double v = 0.0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ptr != s.data() + s.size()) return NumberParse::malformed;
  if (res.ec == std::errc::result_out_of_range) {
    // from_chars also reports underflow (to a subnormal or 0) as out of range: only an overflow
    // is an error; strtod of the same (decimal) text tells the two apart, in the "C" locale
    // whatever the process's LC_NUMERIC (a German one would stop "1.5e400" at the '.')
    static const locale_t c_locale = newlocale(LC_NUMERIC_MASK, "C", static_cast<locale_t>(nullptr));
    const std::string t(s);
    v = c_locale ? strtod_l(t.c_str(), nullptr, c_locale) : std::strtod(t.c_str(), nullptr);
    if (!std::isfinite(v)) return NumberParse::out_of_range;
    out = v;
    return NumberParse::ok;
  }
  if (res.ec != std::errc()) return NumberParse::malformed;
  if (!std::isfinite(v)) return NumberParse::non_finite;
  out = v;
  return NumberParse::ok;
}

std::optional<double> finite_number(std::string_view text) {
  double v = 0.0;
  if (parse_number(text, v) != NumberParse::ok) return std::nullopt;
  return v;
}

}  // namespace hysteron::io
