#pragma once
// Numbers read from text: one rule for data files, rig overrides, references and the CLI's
// options. A number is a decimal (or decimal-exponent) floating-point literal, the whole text,
// with an optional leading '+': no hexadecimal ("0x10"), no leading or trailing space, no
// "nan" or "inf" as a value.
#include <optional>
#include <string_view>

namespace hysteron::io {

enum class NumberParse {
  ok,
  empty,         // ""
  malformed,     // not a decimal literal, or text left after it
  non_finite,    // "nan", "inf", "infinity" (any case)
  out_of_range,  // beyond the range of a double (underflow to 0 or a subnormal is ok)
};

// Parses `text` into `out`; `out` is written only on ok.
NumberParse parse_number(std::string_view text, double& out);

// The finite number `text` is, or nullopt.
std::optional<double> finite_number(std::string_view text);

}  // namespace hysteron::io
