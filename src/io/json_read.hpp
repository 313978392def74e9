#pragma once
// The strict JSON readers of the io layer's result files (results.cpp, loop_design.cpp):
// a missing key or a wrong type is a hysteron::Error naming `where` and the key; null reads
// as the given value (NaN unless said). Internal to src/io.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/error.hpp"
#include "hysteron/io/names.hpp"

namespace hysteron::io::json_read {

using nlohmann::json;
inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();

inline json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

inline std::string key_where(std::string_view where, std::string_view key) { return fmt::format("{}.{}", where, key); }

inline const json& need(const json& j, std::string_view key, std::string_view where) {
  if (!j.is_object()) throw Error(fmt::format("{}: expected a JSON object, got {}", where, j.type_name()));
  const auto it = j.find(key);
  if (it == j.end()) throw Error(fmt::format("{}: missing key \"{}\"", where, key));
  return *it;
}

// Every key of the object j is one of `known`: else "WHERE: unknown key 'K', did you mean 'C'? (the
// keys: ...)" (a typo in a hand-written object would be ignored silently, its value the default).
inline void check_keys(const json& j, std::initializer_list<std::string_view> known, std::string_view where) {
  if (!j.is_object()) return;  // the readers name a wrong type
  for (const auto& [key, value] : j.items()) {
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string keys;
    for (const std::string_view k : known) keys += fmt::format("{}{}", keys.empty() ? "" : ", ", k);
    const std::string_view hint = closest_name(key, known);
    throw Error(fmt::format("{}: unknown key '{}'{} (the keys: {})", where, key,
                            hint.empty() ? "" : fmt::format(", did you mean '{}'?", hint), keys));
  }
}

[[noreturn]] inline void wrong_type(const json& v, std::string_view key, std::string_view where, std::string_view expected) {
  throw Error(fmt::format("{}: key \"{}\": expected {}, got {}", where, key, expected, v.type_name()));
}

inline double as_double(const json& v, std::string_view key, std::string_view where, double null_value = nan) {
  if (v.is_null()) return null_value;
  if (!v.is_number()) wrong_type(v, key, where, "a number or null");
  return v.get<double>();
}
inline double get_double(const json& j, std::string_view key, std::string_view where, double null_value = nan) {
  return as_double(need(j, key, where), key, where, null_value);
}
// An array of numbers; null entries read as null_value.
inline std::vector<double> get_doubles(const json& j, std::string_view key, std::string_view where, double null_value = nan) {
  const json& v = need(j, key, where);
  if (!v.is_array()) wrong_type(v, key, where, "an array of numbers");
  std::vector<double> out;
  out.reserve(v.size());
  for (const auto& x : v) out.push_back(as_double(x, key, where, null_value));
  return out;
}
inline double opt_double(const json& j, std::string_view key, std::string_view where, double def) {
  return j.contains(key) ? get_double(j, key, where) : def;
}
inline std::size_t as_size(const json& v, std::string_view key, std::string_view where) {
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<long long>() >= 0))
    wrong_type(v, key, where, "a non-negative integer");
  return v.get<std::size_t>();
}
inline std::size_t get_size(const json& j, std::string_view key, std::string_view where) {
  return as_size(need(j, key, where), key, where);
}
inline int get_int(const json& j, std::string_view key, std::string_view where) {
  const json& v = need(j, key, where);
  if (!v.is_number_integer()) wrong_type(v, key, where, "an integer");
  return v.get<int>();
}
inline int opt_int(const json& j, std::string_view key, std::string_view where, int def) {
  return j.contains(key) ? get_int(j, key, where) : def;
}
inline bool get_bool(const json& j, std::string_view key, std::string_view where) {
  const json& v = need(j, key, where);
  if (!v.is_boolean()) wrong_type(v, key, where, "true or false");
  return v.get<bool>();
}
inline bool opt_bool(const json& j, std::string_view key, std::string_view where, bool def) {
  return j.contains(key) ? get_bool(j, key, where) : def;
}
inline std::string get_string(const json& j, std::string_view key, std::string_view where) {
  const json& v = need(j, key, where);
  if (!v.is_string()) wrong_type(v, key, where, "a string");
  return v.get<std::string>();
}
inline std::string opt_string(const json& j, std::string_view key, std::string_view where, std::string def = {}) {
  return j.contains(key) ? get_string(j, key, where) : def;
}
inline const json& get_array(const json& j, std::string_view key, std::string_view where) {
  const json& v = need(j, key, where);
  if (!v.is_array()) wrong_type(v, key, where, "an array");
  return v;
}

}  // namespace hysteron::io::json_read
