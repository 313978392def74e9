// Units as text (units.hpp).
#include "hysteron/io/units.hpp"

#include "mat.hpp"  // detail::trim

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace hysteron::io {

namespace detail {
std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}
}  // namespace detail

namespace {
using detail::trim;

// "name [unit]" / "name (unit)": the position of the bracket that opens a trailing unit, else npos.
// The bracket follows a blank ("x[0]", "sin(t)" have none) and holds more than digits ("p [3]").
std::size_t unit_bracket(std::string_view name) {
  name = trim(name);
  if (name.size() < 3) return std::string_view::npos;
  const char close = name.back();
  if (close != ']' && close != ')') return std::string_view::npos;
  const std::size_t open = name.rfind(close == ']' ? '[' : '(');
  if (open == std::string_view::npos || open + 2 > name.size() - 1) return std::string_view::npos;
  if (open > 0 && name[open - 1] != ' ' && name[open - 1] != '\t') return std::string_view::npos;
  const std::string_view inside = trim(name.substr(open + 1, name.size() - open - 2));
  if (inside.empty() || std::all_of(inside.begin(), inside.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::string_view::npos;
  return open;
}
}  // namespace

using detail::trim;

std::string strip_unit_brackets(std::string_view u) {
  u = trim(u);
  if (u.size() >= 2 && ((u.front() == '[' && u.back() == ']') || (u.front() == '(' && u.back() == ')')))
    u = trim(u.substr(1, u.size() - 2));
  return std::string(u);
}

std::string trailing_unit(std::string_view text) {
  text = trim(text);
  const std::size_t open = unit_bracket(text);
  if (open == std::string_view::npos) return std::string();
  return std::string(trim(text.substr(open + 1, text.size() - open - 2)));
}

std::string without_unit(std::string_view text) {
  text = trim(text);
  const std::size_t open = unit_bracket(text);
  return std::string(open == std::string_view::npos || open == 0 ? text : trim(text.substr(0, open)));
}

std::string canonical_unit(std::string_view unit) {
  const std::string u = strip_unit_brackets(trailing_unit(unit).empty() ? unit : std::string_view(trailing_unit(unit)));
  // symbols as written, and spellings that name one unit only (no "mpa": MPa or mPa?)
  static constexpr std::pair<std::string_view, std::string_view> table[] = {
      {"Pa", "Pa"},     {"hPa", "hPa"},   {"kPa", "kPa"},   {"KPa", "kPa"},   {"kpa", "kPa"},  {"KPA", "kPa"},
      {"MPa", "MPa"},   {"MPA", "MPa"},   {"Mpa", "MPa"},   {"bar", "bar"},   {"Bar", "bar"},  {"BAR", "bar"},
      {"mbar", "mbar"}, {"psi", "psi"},   {"PSI", "psi"},   {"Psi", "psi"},   {"atm", "atm"},  {"m", "m"},
      {"cm", "cm"},     {"mm", "mm"},     {"um", "um"},     {"\xC2\xB5m", "um"}, {"\xCE\xBCm", "um"},
      {"nm", "nm"},     {"in", "in"},     {"N", "N"},       {"kN", "kN"},     {"mN", "mN"},    {"lbf", "lbf"},
      {"V", "V"},       {"mV", "mV"},     {"kV", "kV"},     {"A", "A"},       {"mA", "mA"},    {"s", "s"},
      {"ms", "ms"},     {"us", "us"},     {"\xC2\xB5s", "us"}, {"\xCE\xBCs", "us"}, {"%", "%"},
      // gauge pressure, as hysteron's pressures are (a model in barg is one in bar to every check)
      {"barg", "bar"},  {"psig", "psi"},  {"kPag", "kPa"},  {"MPag", "MPa"}};
  for (const auto& [spelling, symbol] : table)
    if (u == spelling) return std::string(symbol);
  return std::string();
}

double length_units_per_metre(std::string_view unit) {
  const std::string u = canonical_unit(unit);
  for (const auto& [symbol, count] : {std::pair<std::string_view, double>{"m", 1.0}, {"cm", 100.0}, {"mm", 1000.0},
                                      {"um", 1e6}, {"nm", 1e9}, {"in", 1.0 / 0.0254}})
    if (u == symbol) return count;
  return 0.0;
}

bool pressure_unit_other_than_mpa(std::string_view unit) {
  const std::string u = canonical_unit(unit);
  for (const std::string_view p : {"Pa", "hPa", "kPa", "bar", "mbar", "psi", "atm"})
    if (u == p) return true;
  return false;
}

double mpa_per_pressure_unit(std::string_view unit) {
  const std::string u = canonical_unit(unit);
  for (const auto& [symbol, mpa] : {std::pair<std::string_view, double>{"Pa", 1e-6}, {"hPa", 1e-4}, {"kPa", 1e-3},
                                    {"MPa", 1.0}, {"bar", 0.1}, {"mbar", 1e-4}, {"psi", 0.006894757293168361},
                                    {"atm", 0.101325}})
    if (u == symbol) return mpa;
  return 0.0;
}

std::string input_unit_mismatch(std::string_view input_unit) {
  const std::string in = canonical_unit(input_unit);
  if (!pressure_unit_other_than_mpa(in)) return std::string();
  const double mpa = mpa_per_pressure_unit(in);
  return fmt::format("the model's input is in {}, not MPa, but the controller's pressures (its limits, PID gains and "
                     "output, commands) are in MPa: the model would take them as {}, {:.4g}x off, and its inverse "
                     "saturate; refit the model with its pressure in MPa (1 {} = {:.10g} MPa: the record's pressure "
                     "column times {:.10g})",
                     in, in, 1.0 / mpa, in, mpa, mpa);
}

std::string model_scale_mismatch(double model_scale, std::string_view output_unit) {
  const double per_metre = length_units_per_metre(output_unit);
  if (per_metre <= 0 || std::abs(model_scale - per_metre) <= 1e-4 * per_metre) return std::string();
  return fmt::format("model_scale = {} model output units per metre, but the model's output is in {} ({:.10g} per "
                     "metre)",
                     model_scale, output_unit, per_metre);
}

}  // namespace hysteron::io
