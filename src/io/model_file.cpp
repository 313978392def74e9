#include "hysteron/io/model_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <unordered_set>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "hysteron/error.hpp"
#include "hysteron/io/files.hpp"

namespace hysteron::io {

namespace {

using nlohmann::json;

constexpr std::array<std::string_view, 4> kFreeKeys = {"units", "note", "metadata", "training"};

std::string type_name(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "boolean";
    case json::value_t::string: return "string";
    case json::value_t::array: return "array";
    case json::value_t::object: return "object";
    case json::value_t::binary: return "binary";
    case json::value_t::discarded: return "discarded";
    default: return "number";
  }
}

template <class Keys>
std::string join(const Keys& keys) {
  std::string s;
  for (std::string_view k : keys) {
    if (!s.empty()) s += ", ";
    s += '"';
    s += k;
    s += '"';
  }
  return s;
}

// Reads keys of one JSON object with a common message prefix, e.g.
// "m.json: gpi: key \"tau\": expected a number, got string".
class Reader {
 public:
  Reader(const json& obj, std::string prefix) : obj_(obj), prefix_(std::move(prefix)) {}

  [[noreturn]] void fail(std::string_view key, std::string_view what) const {
    throw Error(fmt::format("{}: key \"{}\": {}", prefix_, key, what));
  }
  [[noreturn]] void fail(std::string_view what) const { throw Error(fmt::format("{}: {}", prefix_, what)); }

  bool has(std::string_view key) const { return obj_.contains(key); }
  const json& at(std::string_view key) const {
    auto it = obj_.find(key);
    if (it == obj_.end()) fail(key, "missing (required)");
    return *it;
  }

  void only(std::initializer_list<std::string_view> allowed, bool free_keys) const {
    for (auto it = obj_.begin(); it != obj_.end(); ++it) {
      bool ok = false;
      for (std::string_view a : allowed) ok = ok || it.key() == a;
      if (free_keys)
        for (std::string_view a : kFreeKeys) ok = ok || it.key() == a;
      if (!ok)
        fail(it.key(), fmt::format("unknown key; allowed keys are {}{}", join(allowed),
                                   free_keys ? ", " + join(kFreeKeys) : std::string()));
    }
  }

  double number(std::string_view key, const json& v) const {
    if (!v.is_number())
      fail(key, fmt::format("expected a number, got {}", type_name(v)));
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(key, fmt::format("expected a finite number, got {}", d));
    return d;
  }
  double number(std::string_view key) const { return number(key, at(key)); }
  double number_or(std::string_view key, double def) const { return has(key) ? number(key) : def; }

  int integer(std::string_view key) const {
    const json& v = at(key);
    if (v.is_number_integer() || v.is_number_unsigned()) {
      if (v.is_number_unsigned() ? v.get<std::uint64_t>() > static_cast<std::uint64_t>(std::numeric_limits<int>::max())
                                 : (v.get<std::int64_t>() > std::numeric_limits<int>::max() ||
                                    v.get<std::int64_t>() < std::numeric_limits<int>::min()))
        fail(key, fmt::format("expected an integer, got {} (out of range)", v.dump()));
      return static_cast<int>(v.get<std::int64_t>());
    }
    if (v.is_number_float()) {
      const double d = v.get<double>();
      if (std::isfinite(d) && d == std::floor(d) && std::abs(d) <= 1e9) return static_cast<int>(d);
      fail(key, fmt::format("expected an integer, got {}", v.dump()));
    }
    fail(key, fmt::format("expected an integer, got {}", type_name(v)));
  }

  std::string string(std::string_view key) const {
    const json& v = at(key);
    if (!v.is_string()) fail(key, fmt::format("expected a string, got {}", type_name(v)));
    return v.get<std::string>();
  }

  // Array of finite numbers; `expected_size` < 0 means any length.
  std::vector<double> numbers(std::string_view key, long expected_size = -1) const {
    const json& v = at(key);
    if (!v.is_array()) fail(key, fmt::format("expected an array of numbers, got {}", type_name(v)));
    if (expected_size >= 0 && v.size() != static_cast<std::size_t>(expected_size))
      fail(key, fmt::format("expected an array of {} numbers, got {}", expected_size, v.size()));
    std::vector<double> out;
    out.reserve(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(number(fmt::format("{}[{}]", key, i), v[i]));
    return out;
  }

  Limits limits() const {
    Limits l;
    if (!has("input_limits")) return l;
    const json& v = at("input_limits");
    if (!v.is_array() || v.size() != 2)
      fail("input_limits", fmt::format("expected an array [lo, hi] of 2 numbers (null = unbounded), got {}",
                                       v.is_array() ? fmt::format("{} entries", v.size()) : type_name(v)));
    if (!v[0].is_null()) l.lo = number("input_limits[0]", v[0]);
    if (!v[1].is_null()) l.hi = number("input_limits[1]", v[1]);
    return l;
  }

  Envelope envelope(std::string_view kind_key, std::string_view c_key, EnvelopeKind def) const {
    Envelope e;
    e.kind = def;
    if (has(kind_key)) {
      const std::string name = string(kind_key);
      try {
        e.kind = envelope_kind_from_name(name, fmt::format("{}: key \"{}\"", prefix_, kind_key));
      } catch (const Error&) {
        fail(kind_key, fmt::format("expected \"tanh\", \"atan\", \"affine\" or \"identity\", got \"{}\"", name));
      }
    }
    const std::size_t nc = envelope_num_coefficients(e.kind);
    e.c = {1.0, 0.0, 0.0, 0.0};
    if (nc == 0) {
      if (has(c_key) && !(at(c_key).is_array() && at(c_key).empty()))
        fail(c_key, fmt::format("envelope \"{}\" has no coefficients; omit \"{}\" or give []",
                                envelope_name(e.kind), c_key));
      return e;
    }
    const std::vector<double> c = numbers(c_key, static_cast<long>(nc));
    e.c = {0.0, 0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < nc; ++i) e.c[i] = c[i];
    return e;
  }

  const std::string& prefix() const { return prefix_; }

 private:
  const json& obj_;
  std::string prefix_;
};

Envelope sub_envelope(const Reader& parent, const json& j, std::string_view key) {
  if (!j.is_object()) parent.fail(key, fmt::format("expected an object {{\"envelope\": ..., \"c\": [...]}}, got {}", type_name(j)));
  Reader r(j, fmt::format("{}: key \"{}\"", parent.prefix(), key));
  r.only({"envelope", "c"}, false);
  if (!r.has("envelope")) r.fail("envelope", "missing (required)");
  return r.envelope("envelope", "c", EnvelopeKind::identity);
}

json number_array(const std::vector<double>& v) {
  json a = json::array();
  for (double d : v) a.push_back(d);
  return a;
}

json envelope_coefficients(const Envelope& e) {
  json a = json::array();
  for (std::size_t i = 0; i < envelope_num_coefficients(e.kind); ++i) a.push_back(e.c[i]);
  return a;
}

json envelope_object(const Envelope& e) {
  json o = json::object();
  o["envelope"] = std::string(envelope_name(e.kind));
  o["c"] = envelope_coefficients(e);
  return o;
}

void put_limits(json& j, const Limits& l) {
  if (l == Limits{}) return;
  json a = json::array();
  if (std::isfinite(l.lo)) a.push_back(l.lo); else a.push_back(nullptr);
  if (std::isfinite(l.hi)) a.push_back(l.hi); else a.push_back(nullptr);
  j["input_limits"] = a;
}

UnitsMap units_of(const Reader& r) {
  UnitsMap u;
  u.input_origin = r.number_or("input_origin", 0.0);
  u.input_scale = r.number_or("input_scale", 1.0);
  u.output_offset = r.number_or("output_offset", 0.0);
  u.output_gain = r.number_or("output_gain", 1.0);
  if (u.input_scale == 0.0)
    r.fail("input_scale", "expected a non-zero number (< 0 mirrors the input; 0 would divide by zero)");
  if (u.output_gain == 0.0) r.fail("output_gain", "expected a non-zero number (0 makes the output constant)");
  return u;
}

// The units map (models.hpp): four optional numbers, written only when not the identity.
void put_units(json& j, const UnitsMap& u) {
  if (u.input_origin != 0.0) j["input_origin"] = u.input_origin;
  if (u.input_scale != 1.0) j["input_scale"] = u.input_scale;
  if (u.output_offset != 0.0) j["output_offset"] = u.output_offset;
  if (u.output_gain != 1.0) j["output_gain"] = u.output_gain;
}

struct ToJson {
  json operator()(const PiParams& m) const {
    json j;
    j["q"] = m.q;
    j["r"] = number_array(m.r);
    j["p"] = number_array(m.p);
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const GpiParams& m) const {
    json j;
    j["envelope"] = std::string(envelope_name(m.envelope.kind));
    if (m.envelope.kind != EnvelopeKind::identity) j["c"] = envelope_coefficients(m.envelope);
    j["q"] = m.q;
    if (!m.r.empty()) {
      j["r"] = number_array(m.r);
      j["p"] = number_array(m.p);
    } else {
      j["n"] = m.n;
      j["rho"] = m.rho;
      j["tau"] = m.tau;
      j["alpha"] = m.alpha;
    }
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const MpiDeadzoneParams& m) const {
    json j;
    j["q"] = m.q;
    j["r"] = number_array(m.r);
    j["p"] = number_array(m.p);
    j["g0"] = m.g0;
    j["z"] = number_array(m.z);
    j["g"] = number_array(m.g);
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const MpiAsymParams& m) const {
    json j;
    j["q"] = m.q;
    j["r"] = number_array(m.r);
    j["p"] = number_array(m.p);
    j["ascending"] = envelope_object(m.ascending);
    j["descending"] = envelope_object(m.descending);
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const PreisachParams& m) const { return grid(m); }
  json operator()(const KpParams& m) const { return grid(m); }
  json grid(const PreisachGrid& m) const {
    json j;
    j["q"] = m.q;
    j["lo"] = m.lo;
    j["hi"] = m.hi;
    j["levels"] = m.levels;
    j["w"] = number_array(m.w);
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const BoucWenParams& m) const {
    json j;
    j["kx"] = m.kx;
    j["kw"] = m.kw;
    j["rho"] = m.rho;
    j["sigma"] = m.sigma;
    j["n"] = m.n;
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const MaxwellSlipParams& m) const {
    json j;
    j["k0"] = m.k0;
    j["k"] = number_array(m.k);
    j["delta"] = number_array(m.delta);
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
  json operator()(const RatePiParams& m) const {
    json j;
    j["q"] = m.q;
    j["r"] = number_array(m.r);
    j["p"] = number_array(m.p);
    j["c"] = m.c;
    j["tau"] = m.tau;
    j["dt"] = m.dt;
    put_limits(j, m.input_limits);
    put_units(j, m.units);
    return j;
  }
};

}  // namespace

std::string read_text_file(const std::string& path, std::string_view what, std::size_t max_bytes) {
  // O_NONBLOCK: opening a FIFO without a writer returns at once (then reads see EOF) instead of hanging.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error(fmt::format("{}: cannot open {}: {}", path, what, std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(fmt::format("{}: cannot read {}: {}", path, what, std::strerror(errno)));
  if (S_ISDIR(st.st_mode)) throw Error(fmt::format("{}: cannot read {}: it is a directory", path, what));
  const auto too_large = [&](const std::string& size) {
    return Error(fmt::format("{}: the {} is {}, more than the {} bytes any valid one needs: not read", path, what, size,
                             max_bytes));
  };
  if (S_ISREG(st.st_mode) && static_cast<std::uintmax_t>(st.st_size) > max_bytes)
    throw too_large(fmt::format("{} bytes", st.st_size));
  if (const int flags = ::fcntl(fd, F_GETFL); flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  std::string text;
  char buf[65536];
  for (;;) {
    const ssize_t got = ::read(fd, buf, sizeof buf);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw Error(fmt::format("{}: read error: {}", path, std::strerror(errno)));
    }
    if (got == 0) break;
    if (text.size() + static_cast<std::size_t>(got) > max_bytes) throw too_large("larger (a device or a pipe?)");
    text.append(buf, static_cast<std::size_t>(got));
  }
  return text;
}

json parse_json(std::string_view text, std::string_view where) {
  if (const auto nul = text.find('\0'); nul != std::string_view::npos)
    throw Error(fmt::format("{}: not valid JSON: a NUL byte at offset {} (of {} bytes)", where, nul, text.size()));
  // One set of keys per open object; the JSON pointer of the object for the message.
  std::vector<std::unordered_set<std::string>> keys;
  std::vector<std::string> path;
  std::string last_key;
  auto callback = [&](int depth, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
        keys.emplace_back();
        path.push_back(depth > 0 ? last_key : std::string());
        break;
      case json::parse_event_t::object_end:
        keys.pop_back();
        path.pop_back();
        break;
      case json::parse_event_t::array_start: last_key.clear(); break;
      case json::parse_event_t::key: {
        last_key = parsed.get<std::string>();
        if (!keys.back().insert(last_key).second) {
          std::string at;
          for (std::size_t i = 1; i < path.size(); ++i) {
            at += '/';
            at += path[i].empty() ? std::string_view("[]") : std::string_view(path[i]);
          }
          throw Error(fmt::format("{}: not valid here: key \"{}\" appears twice in the object at {}", where, last_key,
                                  at.empty() ? std::string("the top level") : at));
        }
        break;
      }
      default: break;
    }
    return true;
  };
  try {
    return json::parse(text, callback);
  } catch (const json::exception& e) {
    // e.what() is "[json.exception.parse_error.101] parse error at line 3, column 7: ..."
    std::string msg = e.what();
    const auto pos = msg.find("] ");
    if (pos != std::string::npos) msg = msg.substr(pos + 2);
    throw Error(fmt::format("{}: not valid JSON: {}", where, msg));
  }
}

ModelParams model_from_json(const nlohmann::json& j, std::string_view where) {
  if (!j.is_object())
    throw Error(fmt::format("{}: expected a JSON object {{\"model\": ...}}, got {}", where, type_name(j)));
  Reader top(j, std::string(where));
  if (top.has("schema")) {
    const json& s = j["schema"];
    if (!s.is_number_integer() && !s.is_number_unsigned())
      top.fail("schema", fmt::format("expected the integer {}, got {}", model_schema_version, s.dump()));
    if (s.get<std::int64_t>() != model_schema_version)
      top.fail("schema", fmt::format("unsupported schema version {}; this hysteron reads version {}",
                                     s.get<std::int64_t>(), model_schema_version));
  }
  const std::string model = top.string("model");
  Reader r(j, fmt::format("{}: {}", where, model));
  ModelParams params;
  if (model == "pi") {
    r.only({"schema", "model", "q", "r", "p", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    PiParams m;
    m.q = r.number_or("q", 0.0);
    m.r = r.numbers("r");
    m.p = r.numbers("p", static_cast<long>(m.r.size()));
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "gpi") {
    GpiParams m;
    if (r.has("r") || r.has("p")) {
      r.only({"schema", "model", "envelope", "c", "q", "r", "p", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
      m.r = r.numbers("r");
      if (m.r.empty()) r.fail("r", "expected a non-empty array (or give n, rho, tau, alpha instead of r, p)");
      m.p = r.numbers("p", static_cast<long>(m.r.size()));
    } else {
      r.only({"schema", "model", "envelope", "c", "q", "n", "rho", "tau", "alpha", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
      m.n = r.integer("n");
      m.rho = r.number("rho");
      m.tau = r.number("tau");
      m.alpha = r.number("alpha");
    }
    m.envelope = r.envelope("envelope", "c", EnvelopeKind::tanh);
    m.q = r.number_or("q", 1.0);
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "mpi-deadzone") {
    r.only({"schema", "model", "q", "r", "p", "g0", "z", "g", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    MpiDeadzoneParams m;
    m.q = r.number_or("q", 1.0);
    m.r = r.numbers("r");
    m.p = r.numbers("p", static_cast<long>(m.r.size()));
    m.g0 = r.number_or("g0", 1.0);
    m.z = r.numbers("z");
    for (std::size_t i = 0; i < m.z.size(); ++i)  // docs/model-files.md: z_k != 0
      if (m.z[i] == 0.0)
        r.fail(fmt::format("z[{}]", i), "a dead-zone threshold must be non-zero (a zone at 0 is the linear term: add "
                                        "its weight to g0)");
    m.g = r.numbers("g", static_cast<long>(m.z.size()));
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "mpi-asym") {
    r.only({"schema", "model", "q", "r", "p", "ascending", "descending", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    MpiAsymParams m;
    m.q = r.number_or("q", 1.0);
    m.r = r.numbers("r");
    m.p = r.numbers("p", static_cast<long>(m.r.size()));
    m.ascending = sub_envelope(r, r.at("ascending"), "ascending");
    m.descending = sub_envelope(r, r.at("descending"), "descending");
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "preisach" || model == "kp") {
    r.only({"schema", "model", "q", "lo", "hi", "levels", "w", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    PreisachGrid g;
    g.q = r.number_or("q", 0.0);
    g.lo = r.number("lo");
    g.hi = r.number("hi");
    g.levels = r.integer("levels");
    if (g.levels < 1 || g.levels > max_preisach_levels)
      r.fail("levels", fmt::format("expected an integer in 1..{}, got {}", max_preisach_levels, g.levels));
    g.w = r.numbers("w", static_cast<long>(g.levels) * (g.levels + 1) / 2);
    g.input_limits = r.limits();
    g.units = units_of(r);
    if (model == "kp") params = KpParams{g}; else params = PreisachParams{g};
  } else if (model == "bouc-wen") {
    r.only({"schema", "model", "kx", "kw", "rho", "sigma", "n", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    BoucWenParams m;
    m.kx = r.number("kx");
    m.kw = r.number("kw");
    m.rho = r.number("rho");
    m.sigma = r.number("sigma");
    m.n = r.number("n");
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "maxwell-slip") {
    r.only({"schema", "model", "k0", "k", "delta", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    MaxwellSlipParams m;
    m.k0 = r.number("k0");
    m.k = r.numbers("k");
    m.delta = r.numbers("delta", static_cast<long>(m.k.size()));
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else if (model == "rate-pi") {
    r.only({"schema", "model", "q", "r", "p", "c", "tau", "dt", "input_limits", "input_origin", "input_scale", "output_offset", "output_gain"}, true);
    RatePiParams m;
    m.q = r.number("q");
    m.r = r.numbers("r");
    m.p = r.numbers("p", static_cast<long>(m.r.size()));
    m.c = r.number("c");
    m.tau = r.number("tau");
    m.dt = r.number("dt");
    m.input_limits = r.limits();
    m.units = units_of(r);
    params = std::move(m);
  } else {
    top.fail("model", fmt::format("expected one of \"pi\", \"gpi\", \"mpi-deadzone\", \"mpi-asym\", \"preisach\", "
                                  "\"kp\", \"bouc-wen\", \"maxwell-slip\", \"rate-pi\", got \"{}\"", model));
  }
  check_model_extra(model_extra(j), where);
  try {
    Model check(params);  // the model's own validation (names the key)
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", where, e.what()));
  }
  return params;
}

void check_model_extra(const nlohmann::json& extra, std::string_view where) {
  if (extra.is_null()) return;
  if (!extra.is_object())
    throw Error(fmt::format("{}: the free-form model-file keys must be a JSON object ({}), got {}", where,
                            join(kFreeKeys), type_name(extra)));
  Reader top(extra, std::string(where));
  for (auto it = extra.begin(); it != extra.end(); ++it)
    if (std::find(kFreeKeys.begin(), kFreeKeys.end(), it.key()) == kFreeKeys.end())
      top.fail(it.key(), fmt::format("not a free-form key of a model file; allowed: {}", join(kFreeKeys)));
  if (extra.contains("units")) {
    const json& u = extra["units"];
    if (!u.is_object()) top.fail("units", fmt::format("expected an object {{\"input\": \"...\", \"output\": \"...\"}}, got {}", type_name(u)));
    for (auto it = u.begin(); it != u.end(); ++it)
      if (!it.value().is_string())
        top.fail(fmt::format("units.{}", it.key()), fmt::format("expected a string, got {}", type_name(it.value())));
  }
  if (extra.contains("note") && !extra["note"].is_string())
    top.fail("note", fmt::format("expected a string, got {}", type_name(extra["note"])));
  if (extra.contains("training")) {
    const json& t = extra["training"];
    const char* expected = "expected an object {\"rms\": ..., \"r2\": ..., \"samples\": N} (the training fit's error)";
    if (!t.is_object()) top.fail("training", fmt::format("{}, got {}", expected, type_name(t)));
    for (auto it = t.begin(); it != t.end(); ++it)
      if (it.key() != "rms" && it.key() != "r2" && it.key() != "samples")
        top.fail(fmt::format("training.{}", it.key()), "not a key of \"training\"; allowed: rms, r2, samples");
    for (const char* k : {"rms", "r2", "samples"}) {
      const std::string key = fmt::format("training.{}", k);
      if (!t.contains(k)) top.fail("training", fmt::format("{}: \"{}\" is missing", expected, k));
      const json& v = t[k];
      if (!v.is_number()) top.fail(key, fmt::format("expected a number, got {}", type_name(v)));
      const double x = v.get<double>();
      if (!std::isfinite(x)) top.fail(key, "expected a finite number");
      if (std::string_view(k) == "rms" && !(x >= 0.0)) top.fail(key, fmt::format("expected >= 0, got {}", x));
      if (std::string_view(k) == "r2" && !(x <= 1.0)) top.fail(key, fmt::format("expected <= 1, got {}", x));
      // a whole number (MATLAB's structs hold it as a double)
      if (std::string_view(k) == "samples" && !(x >= 0.0 && x == std::floor(x) && x < 9007199254740992.0))
        top.fail(key, fmt::format("expected a whole number >= 0, got {}", v.dump()));
    }
  }
}

nlohmann::json training_to_json(const TrainingMetrics& t) {
  return {{"rms", t.rms}, {"r2", t.r2}, {"samples", t.samples}};
}

std::optional<TrainingMetrics> ModelDocument::training() const {
  if (!extra.is_object()) return std::nullopt;
  const auto t = extra.find("training");
  if (t == extra.end() || !t->is_object()) return std::nullopt;
  check_model_extra(json{{"training", *t}}, "model document");
  return TrainingMetrics{(*t)["rms"].get<double>(), (*t)["r2"].get<double>(),
                         static_cast<std::size_t>((*t)["samples"].get<double>())};
}

std::string ModelDocument::unit(std::string_view which) const {
  if (!extra.is_object()) return {};
  const auto u = extra.find("units");
  if (u == extra.end() || !u->is_object()) return {};
  const auto it = u->find(which);
  return it != u->end() && it->is_string() ? it->get<std::string>() : std::string();
}

ModelDocument model_document_from_json(const nlohmann::json& j, std::string_view where) {
  ModelDocument doc;
  doc.params = model_from_json(j, where);
  doc.extra = model_extra(j);
  return doc;
}

nlohmann::json model_extra(const nlohmann::json& j) {
  json out = json::object();
  if (!j.is_object()) return out;
  for (std::string_view k : kFreeKeys)
    if (j.contains(k)) out[std::string(k)] = j.at(std::string(k));
  return out;
}

nlohmann::json model_to_json(const ModelParams& params) {
  json body = std::visit(ToJson{}, params);
  json j = json::object();
  j["schema"] = model_schema_version;
  j["model"] = std::string(model_name(params));
  for (auto it = body.begin(); it != body.end(); ++it) j[it.key()] = it.value();
  return j;
}

nlohmann::json model_to_json(const ModelDocument& doc) {
  check_model_extra(doc.extra, "model document");
  json j = model_to_json(doc.params);
  if (doc.extra.is_object())
    for (auto it = doc.extra.begin(); it != doc.extra.end(); ++it) j[it.key()] = it.value();
  return j;
}

ModelDocument read_model_document(const std::string& path) {
  if (path != "-") return model_document_from_json(parse_json(read_text_file(path, "model file", max_model_file_bytes), path), path);
  // standard input: at most max_model_file_bytes, as a file
  std::string text;
  char buf[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof buf, stdin)) > 0) {
    text.append(buf, got);
    if (text.size() > max_model_file_bytes)
      throw Error(fmt::format("<stdin>: the model file is more than the {} bytes any valid one needs",
                              max_model_file_bytes));
  }
  if (std::ferror(stdin)) throw Error(fmt::format("<stdin>: read error: {}", std::strerror(errno)));
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw Error("<stdin>: standard input is empty (expected a model file's JSON)");
  return model_document_from_json(parse_json(text, "<stdin>"), "<stdin>");
}

ModelParams read_model_file(const std::string& path) { return read_model_document(path).params; }

void write_model_file(const std::string& path, const ModelDocument& doc) {
  write_model_file(path, doc.params, doc.extra);
}

void write_model_file(const std::string& path, const ModelParams& params, const nlohmann::json& extra) {
  try {
    Model check(params);
    if (const auto* dz = std::get_if<MpiDeadzoneParams>(&params))
      for (std::size_t i = 0; i < dz->z.size(); ++i)
        if (dz->z[i] == 0.0) throw Error(fmt::format("mpi-deadzone: z[{}] = 0 (a dead-zone threshold must be non-zero)", i));
  } catch (const Error& e) {
    throw Error(fmt::format("{}: refusing to write an invalid model: {}", path, e.what()));
  }
  check_model_extra(extra, path);
  json j = model_to_json(params);
  if (extra.is_object())
    for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  const std::string text = j.dump(2) + "\n";
  write_text_file(path, text);
}

}  // namespace hysteron::io
