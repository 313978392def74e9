// The user's own references (ExperimentOptions::references, `hysteron experiment --reference`):
// parsed from their SPECs, checked against the control period, sampled as the papers' are.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "detail.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/results.hpp"  // time_unit_named, time_unit_seconds
#include "hysteron/io/table.hpp"
#include "hysteron/io/units.hpp"
#include "hysteron/signals.hpp"
#include "hysteron/io/numbers.hpp"

namespace hysteron {

namespace {

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

const char* kind_name(UserReference::Kind k) {
  switch (k) {
    case UserReference::Kind::sine: return "sine";
    case UserReference::Kind::triangle: return "triangle";
    case UserReference::Kind::file: return "file";
  }
  return "?";
}

// A finite number, the whole text but surrounding space (io/numbers.hpp); nullopt otherwise.
std::optional<double> number(std::string_view text) { return io::finite_number(trimmed(text)); }

bool reserved_name(std::string_view n) {
  return std::find(io::kKeysBesideReferenceNames.begin(), io::kKeysBesideReferenceNames.end(), n) !=
         io::kKeysBesideReferenceNames.end();
}

std::string reserved_list() {
  std::string s;
  for (const std::string_view k : io::kKeysBesideReferenceNames) s += fmt::format("{}{}", s.empty() ? "" : ", ", k);
  return s;
}

bool valid_name(std::string_view n) {
  if (n.empty() || n.size() > 40 || reserved_name(n)) return false;
  return std::all_of(n.begin(), n.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
  });
}

// The unit a column's NAME suggests by one of its tokens (split at anything but letters and
// digits, case ignored): "time_ms" "ms", "x_m" "m"; "" for none. `units` maps tokens to units.
std::string unit_in_name(std::string_view name, std::initializer_list<std::pair<std::string_view, const char*>> units) {
  std::string token;
  std::string found;
  const auto check = [&] {
    for (const auto& [t, u] : units)
      if (token == t && found.empty()) found = u;
    token.clear();
  };
  for (const char c : name) {
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'))
      token += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else
      check();
  }
  check();
  return found;
}

// The record of a file reference: its time [s, from 0] and contraction [mm] columns; time_unit
// and unit: the spec's time_unit= (s, ms, us) and unit= (mm, m, um), "" where not given.
void read_record(UserReference& r, const std::string& time_col, const std::string& x_col, const std::string& time_unit,
                 const std::string& unit) {
  io::ReadOptions to, xo;
  to.column_spec = time_col;
  xo.column_spec = x_col;
  io::NamedColumn t, x;
  try {
    t = io::read_named_column(r.path, to);
    x = io::read_named_column(r.path, xo);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", r.origin, e.what()));
  }
  if (io::NamedColumn::same(t, x))
    throw Error(fmt::format("{}: time ({}) and contraction ({}) are the same column of {}", r.origin, time_col, x_col,
                            r.path));
  if (t.values.size() != x.values.size())
    throw Error(fmt::format("{}: {}: the time column {} has {} values, the contraction column {} {}", r.origin, r.path,
                            time_col, t.values.size(), x_col, x.values.size()));
  if (t.values.size() < 2)
    throw Error(fmt::format("{}: {} has {} sample(s): a reference needs at least 2", r.origin, r.path, t.values.size()));
  // the time column's unit: its header's (checked against time_unit=), time_unit=, else s where
  // its name suggests no other (a note says so)
  std::string tu = io::time_unit_named(t.unit, fmt::format("{}: the time column {}", r.origin, time_col));
  if (tu.empty() && !t.unit.empty())
    throw Error(fmt::format("{}: the time column {} of {} is in \"{}\", not a time unit (s, ms or us)", r.origin,
                            time_col, r.path, t.unit));
  if (!time_unit.empty() && !tu.empty() && tu != time_unit)
    throw Error(fmt::format("{}: time_unit={} but {} gives the time column {} the unit \"{}\": one of them is wrong "
                            "(drop time_unit if the file is right)",
                            r.origin, time_unit, r.path, time_col, t.unit));
  bool time_unit_given = !tu.empty() || !time_unit.empty();
  if (tu.empty()) tu = time_unit.empty() ? "s" : time_unit;
  if (!time_unit_given) {
    if (const std::string u = unit_in_name(t.name, {{"s", "s"},        {"sec", "s"},          {"secs", "s"},
                                                    {"seconds", "s"},  {"ms", "ms"},          {"msec", "ms"},
                                                    {"msecs", "ms"},   {"millis", "ms"},      {"millisec", "ms"},
                                                    {"millisecond", "ms"}, {"milliseconds", "ms"}, {"us", "us"},
                                                    {"usec", "us"},    {"usecs", "us"},       {"micros", "us"},
                                                    {"microsec", "us"}, {"microsecond", "us"}, {"microseconds", "us"},
                                                    {"ns", "ns"},      {"nanos", "ns"},       {"min", "min"},
                                                    {"mins", "min"},   {"minutes", "min"},    {"hours", "h"},
                                                    {"hrs", "h"}});
        u == "s")
      time_unit_given = true;  // "t_s": the name gives it
    else if (!u.empty())
      throw Error(fmt::format("{}: the time column {} of {} gives no unit but its name suggests {}: give time_unit=ms, "
                              "us or s (or the unit in its header: \"{} [{}]\")",
                              r.origin, t.name.empty() ? time_col : t.name, r.path, u, t.name, u));
  }
  const double to_s = io::time_unit_seconds(tu, r.origin);
  // the contraction's: its header's (checked against unit=), unit=, else mm where its name
  // suggests no other length
  double to_mm = 1.0;
  if (!unit.empty()) to_mm = 1e3 / io::length_units_per_metre(unit);
  if (!x.unit.empty()) {
    const double per_m = io::length_units_per_metre(x.unit);
    if (!(per_m > 0.0))
      throw Error(fmt::format("{}: the contraction column {} of {} is in \"{}\", not a length (mm expected)", r.origin,
                              x_col, r.path, x.unit));
    if (!unit.empty() && std::abs(1e3 / per_m - to_mm) > 1e-12 * to_mm)
      throw Error(fmt::format("{}: unit={} but {} gives the contraction column {} the unit \"{}\": one of them is "
                              "wrong (drop unit if the file is right)",
                              r.origin, unit, r.path, x_col, x.unit));
    to_mm = 1e3 / per_m;
  } else if (unit.empty()) {
    if (const std::string u = unit_in_name(x.name, {{"m", "m"}, {"metre", "m"}, {"metres", "m"}, {"meter", "m"},
                                                    {"meters", "m"}, {"cm", "cm"}, {"um", "um"}, {"micron", "um"},
                                                    {"microns", "um"}, {"nm", "nm"}, {"in", "in"}, {"inch", "in"}});
        !u.empty())
      throw Error(fmt::format("{}: the contraction column {} of {} gives no unit but its name suggests {}: give "
                              "unit=mm, m or um (or the unit in its header: \"{} [{}]\")",
                              r.origin, x.name.empty() ? x_col : x.name, r.path, u, x.name, u));
  }
  r.t_s.resize(t.values.size());
  r.x_mm.resize(x.values.size());
  for (std::size_t k = 0; k < t.values.size(); ++k) {
    r.t_s[k] = (t.values[k] - t.values[0]) * to_s;
    r.x_mm[k] = x.values[k] * to_mm;
    if (k > 0 && !(r.t_s[k] > r.t_s[k - 1]))
      throw Error(fmt::format("{}: the time column {} of {} does not increase at sample {} (data row {}: {} after {}): "
                              "a reference needs strictly increasing time stamps",
                              r.origin, time_col, r.path, k, k + 1, t.values[k], t.values[k - 1]));
  }
  if (!time_unit_given)
    r.note = fmt::format("{}: {} samples over {:g} s: time read as s (its header gives no unit; time_unit=ms if it is "
                         "not)",
                         r.origin, r.t_s.size(), r.t_s.back());
}

// The record resampled at tc by linear interpolation: samples k tc, k = 0 .. n - 1 [mm].
std::vector<double> resampled(const UserReference& r, std::size_t n, double tc) {
  std::vector<double> out(n);
  std::size_t j = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = std::min(static_cast<double>(k) * tc, r.t_s.back());
    while (j + 2 < r.t_s.size() && r.t_s[j + 1] < t) ++j;
    const double a = std::clamp((t - r.t_s[j]) / (r.t_s[j + 1] - r.t_s[j]), 0.0, 1.0);
    out[k] = r.x_mm[j] + a * (r.x_mm[j + 1] - r.x_mm[j]);
  }
  return out;
}

// Samples of one period (periodic file) or of the whole record at tc.
std::size_t record_samples(const UserReference& r, double tc) {
  const double T = r.t_s.back();
  return r.periodic ? static_cast<std::size_t>(std::lround(T / tc))
                    : static_cast<std::size_t>(std::floor(T / tc * (1.0 + 1e-12))) + 1;
}

double seconds_of(const UserReference& r) {
  if (r.kind == UserReference::Kind::file) return r.periodic ? r.t_s.back() * r.periods : r.t_s.back();
  return static_cast<double>(r.periods) / r.frequency_hz;
}

}  // namespace

std::optional<std::string> reference_file_path(std::string_view spec) {
  const std::size_t colon = spec.find(':');
  if (colon == std::string_view::npos || trimmed(spec.substr(0, colon)) != "file") return std::nullopt;
  const std::string_view rest = spec.substr(colon + 1);
  const std::string path(trimmed(rest.substr(0, rest.find(','))));
  if (path.empty()) return std::nullopt;
  return path;
}

std::vector<UserReference> parse_references(const std::vector<std::string>& specs, std::string_view option) {
  std::vector<UserReference> out;
  std::vector<bool> named;
  for (const std::string& spec : specs) {
    UserReference r;
    r.origin = fmt::format("{} '{}'", option, spec);
    const auto fail = [&](std::string_view why) { return Error(fmt::format("{}: {}", r.origin, why)); };
    const std::size_t colon = spec.find(':');
    const std::string_view kind = trimmed(std::string_view(spec).substr(0, colon));
    if (colon == std::string::npos || (kind != "sine" && kind != "triangle" && kind != "file"))
      throw fail("expected sine:KEY=VALUE,..., triangle:KEY=VALUE,... or file:PATH[,KEY=VALUE...]");
    r.kind = kind == "sine" ? UserReference::Kind::sine
             : kind == "triangle" ? UserReference::Kind::triangle
                                  : UserReference::Kind::file;
    const bool file = r.kind == UserReference::Kind::file;
    std::string_view rest = std::string_view(spec).substr(colon + 1);
    if (file) {
      const std::size_t comma = rest.find(',');
      r.path = reference_file_path(spec).value_or("");
      if (r.path.empty()) throw fail("file: no PATH (file:PATH[,time=COL][,contraction=COL][,periodic][,periods=N])");
      rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    }
    const std::set<std::string> known = file ? std::set<std::string>{"time", "contraction", "periodic", "periods", "name",
                                                                     "time_unit", "unit"}
                                             : std::set<std::string>{"amplitude", "offset", "frequency", "periods", "name"};
    std::string known_list;
    for (const auto& k : known) known_list += (known_list.empty() ? "" : ", ") + k;
    std::map<std::string, std::string> kv;
    std::vector<std::string_view> items;
    for (std::string_view left = rest; !rest.empty();) {
      const std::size_t comma = left.find(',');
      items.push_back(trimmed(left.substr(0, comma)));
      if (comma == std::string_view::npos) break;
      left = left.substr(comma + 1);
    }
    for (const std::string_view item : items) {
      if (item.empty()) throw fail("an empty KEY=VALUE (two commas, or one at the end)");
      const std::size_t eq = item.find('=');
      const std::string key(trimmed(item.substr(0, eq)));
      if (!known.count(key))
        throw fail(fmt::format("unknown key \"{}\" (a {} reference takes {}){}", key, kind, known_list,
                               file && eq == std::string_view::npos
                                   ? "; if it is part of PATH: a PATH cannot contain a comma (the spec's separator), "
                                     "rename the file or link it under a name without one"
                                   : ""));
      if (kv.count(key)) throw fail(fmt::format("key \"{}\" given twice", key));
      if (key == "periodic") {
        if (eq != std::string_view::npos) throw fail("key \"periodic\" takes no value (file:PATH,periodic)");
        kv[key] = "";
        continue;
      }
      if (eq == std::string_view::npos) throw fail(fmt::format("key \"{}\" has no value ({}=VALUE)", key, key));
      kv[key] = std::string(trimmed(item.substr(eq + 1)));
      if (kv[key].empty()) throw fail(fmt::format("key \"{}\" has an empty value", key));
    }
    const auto value = [&](const std::string& key, const char* unit) {
      const auto v = number(kv.at(key));
      if (!v) throw fail(fmt::format("{} = \"{}\" is not a finite number ({})", key, kv.at(key), unit));
      return *v;
    };
    const auto periods = [&] {
      const double p = value("periods", "a whole number >= 1");
      if (!(p >= 1.0) || p != std::floor(p) || p > 1e6)
        throw fail(fmt::format("periods = {} must be a whole number from 1 to 1000000", kv.at("periods")));
      return static_cast<int>(p);
    };
    if (!file) {
      for (const char* key : {"amplitude", "offset", "frequency", "periods"})
        if (!kv.count(key))
          throw fail(fmt::format("missing key \"{}\" ({}:amplitude=MM,offset=MM,frequency=HZ,periods=N)", key, kind));
      r.amplitude_mm = value("amplitude", "mm");
      if (r.amplitude_mm < 0.0) throw fail(fmt::format("amplitude = {} mm must be >= 0", kv.at("amplitude")));
      r.offset_mm = value("offset", "mm");
      r.frequency_hz = value("frequency", "Hz");
      if (!(r.frequency_hz > 0.0)) throw fail(fmt::format("frequency = {} Hz must be > 0", kv.at("frequency")));
      r.periods = periods();
    } else {
      r.periodic = kv.count("periodic") > 0;
      if (kv.count("periods") && !r.periodic)
        throw fail("key \"periods\" needs \"periodic\" (a file reference is one period only where it says so)");
      r.periods = kv.count("periods") ? periods() : 1;
      const std::string tcol = kv.count("time") ? kv.at("time") : "0";
      const std::string xcol = kv.count("contraction") ? kv.at("contraction") : "1";
      for (const auto& [key, units] : {std::pair<const char*, std::set<std::string>>{"time_unit", {"s", "ms", "us"}},
                                       {"unit", {"mm", "m", "um"}}})
        if (kv.count(key) && !units.count(kv.at(key)))
          throw fail(fmt::format("{} = \"{}\": expected {}", key, kv.at(key),
                                 std::string(key) == "unit" ? "mm, m or um" : "s, ms or us"));
      read_record(r, tcol, xcol, kv.count("time_unit") ? kv.at("time_unit") : "",
                  kv.count("unit") ? kv.at("unit") : "");
      if (r.periodic) {
        const auto [lo, hi] = std::minmax_element(r.x_mm.begin(), r.x_mm.end());
        if (std::abs(r.x_mm.back() - r.x_mm.front()) > kReferenceResolution * (*hi - *lo))
          throw fail(fmt::format("periodic: the record ends at {:.4g} mm and starts at {:.4g} mm, more than {:g} % of "
                                 "its span apart: a periodic record is one period, its last sample closing it",
                                 r.x_mm.back(), r.x_mm.front(), 100.0 * kReferenceResolution));
      }
    }
    if (kv.count("name")) {
      r.name = kv.at("name");
      if (reserved_name(r.name))
        throw fail(fmt::format("name = \"{}\" is reserved: result.json keys the references by name beside {}",
                               r.name, reserved_list()));
      if (!valid_name(r.name))
        throw fail(fmt::format("name = \"{}\": a name is 1 to 40 letters, digits, '-' or '_' (it names the tracking "
                               "CSV files)",
                               r.name));
    }
    named.push_back(kv.count("name") > 0);
    out.push_back(std::move(r));
  }
  // default names: the kind, or refN where two references share it
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (named[i]) continue;
    const auto same = std::count_if(out.begin(), out.end(), [&](const UserReference& u) { return u.kind == out[i].kind; });
    out[i].name = same == 1 ? kind_name(out[i].kind) : fmt::format("ref{}", i + 1);
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (out[i].name == out[j].name)
        throw Error(fmt::format("{}: its name \"{}\" is that of {} too: give each reference its own name=NAME",
                                out[i].origin, out[i].name, out[j].origin));
  return out;
}

namespace experiment {

void check_user_references(const std::vector<UserReference>& refs, double tc) {
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const UserReference& r = refs[i];
    if (!valid_name(r.name))
      throw Error(fmt::format("experiment: {}: name \"{}\" must be 1 to 40 letters, digits, '-' or '_', and none of "
                              "{} (result.json's keys beside the references' names)",
                              r.origin, r.name, reserved_list()));
    for (std::size_t j = 0; j < i; ++j)
      if (refs[j].name == r.name)
        throw Error(fmt::format("experiment: {}: its name \"{}\" is that of {} too", r.origin, r.name, refs[j].origin));
    const bool file = r.kind == UserReference::Kind::file;
    if (!file && (!(r.frequency_hz > 0.0) || !std::isfinite(r.frequency_hz) || !(r.amplitude_mm >= 0.0) ||
                  !std::isfinite(r.amplitude_mm) || !std::isfinite(r.offset_mm)))
      throw Error(fmt::format("experiment: {}: amplitude >= 0, offset and frequency > 0 must be finite", r.origin));
    if (r.periods < 1) throw Error(fmt::format("experiment: {}: periods = {} must be >= 1", r.origin, r.periods));
    if (file && (r.t_s.size() < 2 || r.t_s.size() != r.x_mm.size()))
      throw Error(fmt::format("experiment: {}: the record needs at least 2 samples of time and contraction", r.origin));
    if (const double s = seconds_of(r); !(s <= kMaxReferenceSeconds))
      throw Error(fmt::format("experiment: {}: it lasts {:g} s, more than the {:g} s a reference may", r.origin, s,
                              kMaxReferenceSeconds));
    if (!file) {
      const double samples = 1.0 / (r.frequency_hz * tc);
      if (samples < kMinReferencePeriodSamples)
        throw Error(fmt::format("experiment: {}: frequency = {:g} Hz needs more than the control period resolves: a "
                                "period of {:g} ms is {:.1f} control periods of {:g} ms, fewer than {:g} (lower the "
                                "frequency or the --control-period)",
                                r.origin, r.frequency_hz, 1e3 / r.frequency_hz, samples, tc * 1e3,
                                kMinReferencePeriodSamples));
      continue;
    }
    const std::size_t n = record_samples(r, tc);
    if (r.periodic && static_cast<double>(n) < kMinReferencePeriodSamples)
      throw Error(fmt::format("experiment: {}: its period of {:g} s is {} control periods of {:g} ms, fewer than {:g}",
                              r.origin, r.t_s.back(), n, tc * 1e3, kMinReferencePeriodSamples));
    if (n < 2)
      throw Error(fmt::format("experiment: {}: the record lasts {:g} s, less than a control period of {:g} ms",
                              r.origin, r.t_s.back(), tc * 1e3));
    // the record as the loop sees it (samples at tc, linear between them) must reproduce it
    const std::vector<double> x = resampled(r, n, tc);
    const auto [lo, hi] = std::minmax_element(r.x_mm.begin(), r.x_mm.end());
    const double tol = kReferenceResolution * (*hi - *lo);
    for (std::size_t k = 0; k < r.t_s.size(); ++k) {
      const double u = r.t_s[k] / tc;
      const auto j = std::min(static_cast<std::size_t>(u), n - 1);
      const double a = j + 1 < n ? std::clamp(u - static_cast<double>(j), 0.0, 1.0) : 0.0;
      const double seen = j + 1 < n ? x[j] + a * (x[j + 1] - x[j]) : x[j];
      if (r.periodic && r.t_s[k] >= static_cast<double>(n - 1) * tc) break;  // the closing stretch wraps
      if (std::abs(seen - r.x_mm[k]) > tol)
        throw Error(fmt::format("experiment: {}: the record needs more than the control period resolves: at {:g} s "
                                "it is {:.4g} mm, sampled every {:g} ms it is {:.4g} mm, more than {:g} % of its span "
                                "off (lower the --control-period, or smooth the record)",
                                r.origin, r.t_s[k], r.x_mm[k], tc * 1e3, seen, 100.0 * kReferenceResolution));
    }
  }
}

std::vector<Reference> user_references(const std::vector<UserReference>& refs, double tc) {
  std::vector<Reference> out;
  for (const UserReference& r : refs) {
    Reference ref;
    ref.name = r.name;
    ref.user = true;
    switch (r.kind) {
      case UserReference::Kind::sine: {
        // the papers' sine (Eq. 18) as a contraction: rest 0, length offset -O, phase pi/2:
        // x = 0 - (A sin(2 pi F t + pi/2) - O) = O - A cos(2 pi F t)
        const SinusoidParams p{r.amplitude_mm * 1e-3, r.frequency_hz, std::numbers::pi / 2, -r.offset_mm * 1e-3};
        ref.ref_m = gpi_sinusoid_reference(tc, r.periods / r.frequency_hz, 0.0, p);
        ref.period = static_cast<std::size_t>(std::lround(1.0 / (r.frequency_hz * tc)));
        break;
      }
      case UserReference::Kind::triangle:
        ref.ref_m = wave_sequence({{Waveform::triangle, 2e-3 * r.amplitude_mm, 1.0 / r.frequency_hz, r.periods,
                                    1e-3 * (r.offset_mm - r.amplitude_mm)}},
                                  tc);
        ref.period = static_cast<std::size_t>(std::lround(1.0 / (r.frequency_hz * tc)));
        break;
      case UserReference::Kind::file: {
        const std::size_t n = record_samples(r, tc);
        const std::vector<double> x = resampled(r, n, tc);
        for (int j = 0; j < (r.periodic ? r.periods : 1); ++j)
          for (double v : x) ref.ref_m.push_back(v * 1e-3);
        ref.period = r.periodic ? n : 0;
        break;
      }
    }
    ref.period = std::min(ref.period, ref.ref_m.size());
    out.push_back(std::move(ref));
  }
  return out;
}

}  // namespace experiment

}  // namespace hysteron
