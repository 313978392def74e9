// Plant variants (sweep.hpp): overrides of rig parameters by dotted path, the
// documented set of issue 11, and the parallel sweep of experiments over them.
#include "hysteron/sweep.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "detail.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/io/numbers.hpp"

namespace hysteron {

namespace {

// The variant kinds that use the gain trial's choice (ExperimentResult::gain_trials).
bool uses_gain_trial(std::string_view kind) { return kind == "compensated" || kind == "adaptive"; }

using nlohmann::json;
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t p = s.find(sep, start);
    out.push_back(s.substr(start, p == std::string_view::npos ? std::string_view::npos : p - start));
    if (p == std::string_view::npos) break;
    start = p + 1;
  }
  return out;
}

std::string last_component(std::string_view path) {
  const auto p = path.rfind('.');
  return std::string(p == std::string_view::npos ? path : path.substr(p + 1));
}

void collect_paths(const json& j, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& [key, value] : j.items()) {
    const std::string p = prefix.empty() ? key : prefix + "." + key;
    if (value.is_object()) collect_paths(value, p, out);
    else out.push_back(p);
  }
}

// The JSON leaf at a dotted path (nullptr if there is none).
json* find_leaf(json& j, std::string_view path) {
  json* node = &j;
  for (std::string_view part : split(path, '.')) {
    if (!node->is_object()) return nullptr;
    auto it = node->find(std::string(part));
    if (it == node->end()) return nullptr;
    node = &*it;
  }
  return node->is_object() ? nullptr : node;
}

// A finite number, the whole of `text` (io/numbers.hpp).
bool parse_number(std::string_view text, double& value) {
  return io::parse_number(text, value) == io::NumberParse::ok;
}

std::string number_text(double v) { return fmt::format("{}", v); }

std::string variant_name(const std::vector<ParameterOverride>& overrides) {
  std::string s;
  for (const auto& o : overrides) { s += (s.empty() ? "" : " "); s += to_string(o); }
  return s;
}

// The value of an override given as a JSON value (grid files): a number, or "+15%" text.
ParameterOverride override_from_json(const std::string& path, const json& v, const std::string& where) {
  check_parameter_path(path, where);
  if (v.is_number()) {
    const double d = v.get<double>();
    if (!std::isfinite(d)) throw Error(fmt::format("{}: {} = {}: must be a finite number", where, path, v.dump()));
    return {path, d, false};
  }
  if (v.is_string()) return parse_override(path + "=" + v.get<std::string>(), where);
  throw Error(fmt::format("{}: {}: expected a number or a change in percent such as \"-15%\", got {}", where, path,
                          v.type_name()));
}

std::string csv_field(std::string_view s) {
  if (s.find_first_of(",\"\n\r") == std::string_view::npos) return std::string(s);
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += "\"\"";
    else if (c == '\n' || c == '\r') out += ' ';
    else out += c;
  }
  return out + "\"";
}

std::string csv_number(double v) { return std::isfinite(v) ? fmt::format("{:.17g}", v) : std::string(); }

double ratio(double a, double b) { return std::isfinite(a) && std::isfinite(b) && b > 0.0 ? a / b : nan; }

// The kinds in order of first appearance over every run.
std::vector<std::string> kinds_of(const SweepResult& r) {
  std::vector<std::string> kinds;
  for (const auto& run : r.runs)
    for (const auto& e : run.runs)
      if (std::find(kinds.begin(), kinds.end(), e.kind) == kinds.end()) kinds.push_back(e.kind);
  return kinds;
}

// The references of one experiment in order of first appearance.
std::vector<std::string> references_of(const SweepResult& r, std::size_t experiment) {
  std::vector<std::string> refs;
  for (std::size_t v = 0; v < r.variants.size(); ++v)
    for (const auto& e : r.run(experiment, v).runs)
      if (std::find(refs.begin(), refs.end(), e.reference) == refs.end()) refs.push_back(e.reference);
  return refs;
}

}  // namespace

// ---- overrides ---------------------------------------------------------------------

std::vector<std::string> rig_parameter_paths() {
  std::vector<std::string> out;
  collect_paths(rig_params_to_json(PamRigParams{}), "", out);
  return out;
}

void check_parameter_path(std::string_view path, std::string_view where) {
  static const std::vector<std::string> paths = rig_parameter_paths();
  if (std::find(paths.begin(), paths.end(), path) != paths.end()) return;
  // the closest names: within a third of the length, or the same last component
  std::vector<std::pair<std::size_t, std::string>> close;
  const std::size_t limit = std::max<std::size_t>(2, path.size() / 3);
  const std::string leaf = last_component(path);
  for (const auto& p : paths) {
    const std::size_t d = io::edit_distance(path, p);
    if (d <= limit || last_component(p) == leaf) close.emplace_back(d, p);
  }
  std::sort(close.begin(), close.end());
  if (close.size() > 4) close.resize(4);
  std::string hint;
  if (!close.empty()) {
    hint = " (did you mean ";
    for (std::size_t i = 0; i < close.size(); ++i)
      { hint += (i == 0 ? "" : i + 1 == close.size() ? " or " : ", "); hint += close[i].second; }
    hint += "?)";
  }
  // the keys of the section, if the section exists, else the sections
  const auto dot = path.find('.');
  const std::string section(path.substr(0, dot));
  std::vector<std::string> keys, sections;
  for (const auto& p : paths) {
    const std::string s = p.substr(0, p.find('.'));
    if (sections.empty() || sections.back() != s) sections.push_back(s);
    if (s == section) keys.push_back(p.substr(p.find('.') + 1));
  }
  std::string listing;
  if (!keys.empty()) {
    listing = fmt::format("; the parameters of {} are", section);
    for (std::size_t i = 0; i < keys.size(); ++i) { listing += (i ? ", " : " "); listing += keys[i]; }
  } else {
    listing = "; a path is SECTION.KEY with SECTION one of";
    for (std::size_t i = 0; i < sections.size(); ++i) { listing += (i ? ", " : " "); listing += sections[i]; }
    listing += " (docs/plant.md, Parameters)";
  }
  throw Error(fmt::format("{}: unknown rig parameter '{}'{}{}", where, path, hint, listing));
}

ParameterOverride parse_override(std::string_view text, std::string_view where) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos)
    throw Error(fmt::format("{}: '{}': expected PATH=VALUE, e.g. load.mass=35 or muscle.force_620=-15%", where, text));
  ParameterOverride o;
  o.path = std::string(trim(text.substr(0, eq)));
  if (o.path.empty()) throw Error(fmt::format("{}: '{}': the parameter path is empty", where, text));
  check_parameter_path(o.path, where);
  std::string_view v = trim(text.substr(eq + 1));
  if (!v.empty() && v.back() == '%') {
    o.percent = true;
    v.remove_suffix(1);
  }
  if (!parse_number(v, o.value))
    throw Error(fmt::format("{}: {}: '{}' is not a finite number{}", where, o.path, trim(text.substr(eq + 1)),
                            o.percent ? " followed by %" : " (or a change in percent such as -15%)"));
  if (o.percent && o.value <= -100.0)
    throw Error(fmt::format("{}: {}: a change of {}% would make the parameter zero or negative", where, o.path,
                            number_text(o.value)));
  return o;
}

std::string to_string(const ParameterOverride& o) {
  if (o.percent) return fmt::format("{}={}{}%", o.path, o.value > 0 ? "+" : "", number_text(o.value));
  return fmt::format("{}={}", o.path, number_text(o.value));
}

PamRigParams apply_overrides(const PamRigParams& base, const std::vector<ParameterOverride>& overrides,
                             std::string_view where) {
  json j = rig_params_to_json(base);
  for (const auto& o : overrides) {
    check_parameter_path(o.path, where);
    json* leaf = find_leaf(j, o.path);
    if (!leaf || !leaf->is_number())
      throw Error(fmt::format("{}: rig parameter '{}' is not a number in the rig's JSON form", where, o.path));
    const double value = o.percent ? leaf->get<double>() * (1.0 + o.value / 100.0) : o.value;
    if (!std::isfinite(value)) throw Error(fmt::format("{}: {}: the value is not finite", where, to_string(o)));
    // integer fields (e.g. sensors.pressure_bits) take integral values as JSON integers;
    // anything else is left to the rig loader, which says what it expects
    if (leaf->is_number_integer() && value == std::floor(value) && std::abs(value) < 1e15)
      *leaf = static_cast<std::int64_t>(value);
    else
      *leaf = value;
  }
  try {
    return rig_params_from_json(j, "rig");
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", where, e.what()));
  }
}

std::vector<PlantVariant> parse_vary(std::string_view spec) {
  const std::string where = fmt::format("--vary {}", spec);
  const auto eq = spec.find('=');
  if (eq == std::string_view::npos)
    throw Error(fmt::format("{}: expected PATH=V1,V2,... (e.g. load.mass=10,20,35) or P1/P2=A1/A2,B1/B2", where));
  const std::string_view lhs = trim(spec.substr(0, eq));
  const auto paths = split(lhs, '/');
  for (auto p : paths) check_parameter_path(trim(p), where);
  std::vector<PlantVariant> out;
  for (std::string_view value : split(spec.substr(eq + 1), ',')) {
    value = trim(value);
    if (value.empty()) throw Error(fmt::format("{}: an empty value in the list", where));
    const auto values = split(value, '/');
    if (values.size() != paths.size())
      throw Error(fmt::format("{}: '{}' gives {} value(s) for {} parameter(s) (separate them with '/')", where, value,
                              values.size(), paths.size()));
    PlantVariant v;
    v.group = std::string(lhs);
    for (std::size_t i = 0; i < paths.size(); ++i)
      v.overrides.push_back(parse_override(fmt::format("{}={}", trim(paths[i]), trim(values[i])), where));
    v.name = variant_name(v.overrides);
    out.push_back(std::move(v));
  }
  return out;
}

std::vector<PlantVariant> variant_grid_from_json(const json& j, std::string_view where_) {
  const std::string where(where_);
  if (!j.is_object() || !j.contains("variants"))
    throw Error(fmt::format("{}: expected a JSON object {{\"variants\": [{{\"name\": ..., \"set\": {{\"load.mass\": 35}}}}, "
                            "...]}}",
                            where));
  for (const auto& [key, value] : j.items())
    if (key != "variants") throw Error(fmt::format("{}: unknown key '{}' (expected variants)", where, key));
  const json& list = j.at("variants");
  if (!list.is_array() || list.empty())
    throw Error(fmt::format("{}.variants: expected a non-empty array of variants", where));
  std::vector<PlantVariant> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string w = fmt::format("{}.variants[{}]", where, i);
    const json& e = list[i];
    if (!e.is_object()) throw Error(fmt::format("{}: expected an object, got {}", w, e.type_name()));
    PlantVariant v;
    bool has_set = false;
    for (const auto& [key, value] : e.items()) {
      if (key == "name") {
        if (!value.is_string() || value.get<std::string>().empty())
          throw Error(fmt::format("{}.name: expected a non-empty string", w));
        v.name = value.get<std::string>();
      } else if (key == "rms_ratio_limit") {
        if (!value.is_number() || !(value.get<double>() > 0.0) || !std::isfinite(value.get<double>()))
          throw Error(fmt::format("{}.rms_ratio_limit: expected a finite number > 0", w));
        v.rms_ratio_limit = value.get<double>();
      } else if (key == "set") {
        if (!value.is_object() || value.empty())
          throw Error(fmt::format("{}.set: expected a non-empty object {{\"section.key\": value, ...}}", w));
        has_set = true;
        for (const auto& [path, x] : value.items()) v.overrides.push_back(override_from_json(path, x, w + ".set"));
      } else {
        throw Error(fmt::format("{}: unknown key '{}' (expected name, set, rms_ratio_limit)", w, key));
      }
    }
    if (!has_set) throw Error(fmt::format("{}: missing \"set\" (the parameters this variant changes)", w));
    if (v.name.empty()) v.name = variant_name(v.overrides);
    if (v.overrides.size() == 1) v.group = v.overrides[0].path;
    out.push_back(std::move(v));
  }
  return out;
}

std::vector<PlantVariant> read_variant_grid(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open for reading", path));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(fmt::format("{}: read error", path));
  return variant_grid_from_json(io::parse_json(text.str(), path), path);
}

std::vector<PlantVariant> variant_set(std::string_view name, std::string_view where) {
  if (name != documented_set_name)
    throw Error(fmt::format("{} {}: unknown set (the one built-in set is '{}')", where, name, documented_set_name));
  return documented_variants();
}

std::vector<std::string> sweep_experiments(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& e : names) {
    if (e == "all") {
      for (const auto& n : experiment_names()) out.push_back(n);
    } else {
      out.push_back(e);
    }
  }
  return out;
}

std::vector<PlantVariant> documented_variants() {
  auto one = [](std::string name, std::string group, std::vector<ParameterOverride> o) {
    PlantVariant v;
    v.overrides = std::move(o);
    v.name = std::move(name);
    v.group = std::move(group);
    return v;
  };
  const std::string reg = "regulator.time_constant/regulator.dead_time";
  std::vector<PlantVariant> out = {
      one("load 10 kg", "load.mass", {{"load.mass", 10.0, false}}),
      one("load 35 kg", "load.mass", {{"load.mass", 35.0, false}}),
      one("band 10 kPa", "hysteresis.pressure_band", {{"hysteresis.pressure_band", 10e3, false}}),
      one("band 25 kPa", "hysteresis.pressure_band", {{"hysteresis.pressure_band", 25e3, false}}),
      one("force map -15%", "muscle.force_620", {{"muscle.force_620", -15.0, true}}),
      one("force map +15%", "muscle.force_620", {{"muscle.force_620", 15.0, true}}),
      one("regulator 30/5 ms", reg, {{"regulator.time_constant", 0.03, false}, {"regulator.dead_time", 0.005, false}}),
      one("regulator 100/12 ms", reg, {{"regulator.time_constant", 0.1, false}, {"regulator.dead_time", 0.012, false}}),
      one("damping 200 N s/m", "load.damping", {{"load.damping", 200.0, false}}),
      one("damping 800 N s/m", "load.damping", {{"load.damping", 800.0, false}}),
  };
  PlantVariant worst = one("worst", "", {{"load.mass", 35.0, false},
                                         {"hysteresis.pressure_band", 25e3, false},
                                         {"muscle.force_620", -15.0, true},
                                         {"regulator.time_constant", 0.1, false},
                                         {"regulator.dead_time", 0.012, false},
                                         {"load.damping", 200.0, false}});
  worst.name = "worst";
  worst.rms_ratio_limit = 2.0;
  out.push_back(std::move(worst));
  return out;
}

// ---- the sweep -----------------------------------------------------------------------

SweepResult run_sweep(const SweepOptions& options) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  SweepResult r;
  r.seed = options.seed;
  r.model = options.model;
  r.fit_references = options.fit_references;
  r.identify_on_base = options.identify_on_base;
  r.control_period = options.control_period;
  if (options.experiments.empty()) throw Error("sweep: no experiment given");
  const std::vector<std::string> known = experiment_names();
  for (const auto& name : options.experiments) {
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      std::string list;
      for (const auto& k : known) { list += (list.empty() ? "" : ", "); list += k; }
      const std::string_view close = io::closest_name(name, known);
      const std::string hint = close.empty() ? std::string() : fmt::format(" (did you mean {}?)", close);
      throw Error(fmt::format("sweep: unknown experiment '{}'{}; experiments: {}", name, hint, list));
    }
    if (std::find(r.experiments.begin(), r.experiments.end(), name) != r.experiments.end())
      throw Error(fmt::format("sweep: experiment '{}' given twice", name));
    r.experiments.push_back(name);
  }
  {
    ExperimentOptions eo;
    eo.learning_periods = options.learning_periods;
    eo.model = options.model;
    try {
      eo.validate();
    } catch (const Error& e) {
      throw Error(fmt::format("sweep: {}", e.what()));
    }
  }
  try {
    validate(options.base, "base rig");
  } catch (const Error& e) {
    throw Error(fmt::format("sweep: {}", e.what()));
  }
  // the period as run_experiment checks it (ExperimentOptions::validate)
  check_control_period(options.control_period, options.base.simulation.dt, "sweep", "base rig");
  try {
    experiment::check_user_references(options.references, options.control_period);
  } catch (const Error& e) {
    throw Error(fmt::format("sweep: {}", e.what()));
  }

  // the variants' rigs, all checked before anything runs
  const json base_json = rig_params_to_json(options.base);
  SweepVariant nominal;
  nominal.variant.name = "nominal";
  nominal.rig = options.base;
  r.variants.push_back(std::move(nominal));
  std::set<std::string> names = {"nominal"};
  std::vector<json> rigs;  // of r.variants[1...]
  for (const auto& v : options.variants) {
    const std::string where = fmt::format("variant '{}'", v.name);
    if (v.name.empty()) throw Error("sweep: a variant without a name");
    if (!names.insert(v.name).second) throw Error(fmt::format("sweep: two variants are named '{}'", v.name));
    if (!(v.rms_ratio_limit > 0.0) || !std::isfinite(v.rms_ratio_limit))
      throw Error(fmt::format("{}: rms_ratio_limit must be a finite number > 0", where));
    SweepVariant sv;
    sv.variant = v;
    sv.rig = apply_overrides(options.base, v.overrides, where);
    check_control_period(options.control_period, sv.rig.simulation.dt, where, "rig");  // as the runs will check
    json j = rig_params_to_json(sv.rig);
    for (const auto& o : v.overrides) sv.values.push_back(find_leaf(j, o.path)->get<double>());
    if (j == base_json) {
      r.notes.push_back(fmt::format("variant '{}' is the nominal rig: its results are the nominal row", v.name));
      continue;
    }
    const auto same = std::find(rigs.begin(), rigs.end(), j);
    if (same != rigs.end()) {
      r.notes.push_back(fmt::format("variant '{}' is the rig of variant '{}': not run twice", v.name,
                                    r.variants[static_cast<std::size_t>(same - rigs.begin()) + 1].variant.name));
      continue;
    }
    rigs.push_back(std::move(j));
    r.variants.push_back(std::move(sv));
  }

  // the jobs: experiment-major, each result in its own slot (the order never depends on threads)
  const std::size_t nv = r.variants.size(), slots = r.experiments.size() * nv;
  r.runs.resize(slots);
  // A variant whose rig the experiment drives as it drives an earlier variant's (they differ
  // only in parameters its actuator never reads: a valve experiment and the regulator's lag) is
  // not run again: its slot gets that run's results (same_as[k] = the slot it copies).
  std::vector<std::size_t> same_as(slots);
  for (std::size_t k = 0; k < slots; ++k) same_as[k] = k;
  for (std::size_t e = 0; e < r.experiments.size(); ++e) {
    const experiment::Spec* spec = experiment::find_spec(r.experiments[e]);
    const Actuation mode = spec && spec->valves ? Actuation::switching_valves : Actuation::regulator;
    // each rig as the experiment reads it: the parameters it does not read set to the base's
    std::vector<json> read(nv);
    for (std::size_t v = 0; v < nv; ++v)
      read[v] = rig_params_to_json(with_unread_parameters_of(r.variants[v].rig, mode, options.base));
    for (std::size_t v = 1; v < nv; ++v)
      for (std::size_t u = 0; u < v; ++u) {  // the first equal one is run (no earlier one equals it)
        if (read[u] != read[v]) continue;
        same_as[e * nv + v] = e * nv + u;
        r.notes.push_back(fmt::format(
            "{} on variant '{}': the rig of variant '{}' as this experiment drives it ({}; the parameters they differ "
            "in act only {}): not run twice, its results are those of '{}'",
            r.experiments[e], r.variants[v].variant.name, r.variants[u].variant.name,
            mode == Actuation::switching_valves ? "through its switching valves" : "through its regulator",
            mode == Actuation::switching_valves ? "on the regulator" : "on the switching valves",
            r.variants[u].variant.name));
        break;
      }
  }
  std::size_t total = 0;
  for (std::size_t k = 0; k < slots; ++k) total += same_as[k] == k;
  unsigned jobs = options.jobs ? options.jobs : usable_cpus();
  jobs = static_cast<unsigned>(std::min<std::size_t>(jobs, total));
  r.jobs = jobs;
  // Execution order (not the slots' order): experiments with more references first, so that
  // the shortest runs fill the end and the threads finish together.
  std::vector<std::size_t> order;
  order.reserve(total);
  {
    std::vector<std::size_t> cost(r.experiments.size(), 1);
    for (std::size_t e = 0; e < cost.size(); ++e)
      if (const experiment::Spec* spec = experiment::find_spec(r.experiments[e]); spec && spec->references)
        cost[e] = spec->references(options.control_period).size();
    std::vector<std::size_t> ex(r.experiments.size());
    for (std::size_t e = 0; e < ex.size(); ++e) ex[e] = e;
    std::stable_sort(ex.begin(), ex.end(), [&](std::size_t a, std::size_t b) { return cost[a] > cost[b]; });
    for (std::size_t e : ex)
      for (std::size_t v = 0; v < nv; ++v)
        if (same_as[e * nv + v] == e * nv + v) order.push_back(e * nv + v);
  }
  std::atomic<std::size_t> next{0};
  std::mutex progress_mutex;
  std::size_t done = 0;
  std::atomic<bool> stopped{false};
  // asked before each run and, through ExperimentOptions::stop_requested, inside it: a stop ends
  // the runs under way too (within a fraction of a second) instead of waiting for them
  const auto stop_now = [&]() -> bool {
    if (stopped.load()) return true;
    if (!options.stop_requested) return false;
    bool stop = true;  // a stop hook that throws asks for a stop (an exception must not end a worker thread)
    try {
      stop = options.stop_requested();
    } catch (...) {
    }
    if (stop) stopped.store(true);
    return stop;
  };
  auto worker = [&] {
    for (;;) {
      if (stop_now()) return;
      const std::size_t i = next.fetch_add(1);
      if (i >= total) return;
      const std::size_t k = order[i];
      SweepRun& run = r.runs[k];
      run.experiment = r.experiments[k / nv];
      run.variant = k % nv;
      const auto t0 = clock::now();
      try {
        ExperimentOptions eo;
        eo.name = run.experiment;
        eo.rig = r.variants[run.variant].rig;
        if (options.identify_on_base && run.variant > 0) {  // identified on the base rig, tracking on the variant's
          eo.tracking_rig = eo.rig;
          eo.rig = options.base;
        }
        eo.seed = options.seed;
        eo.learning_periods = options.learning_periods;
        eo.control_period = options.control_period;
        eo.model = options.model;
        eo.fit_references = options.fit_references;
        eo.references = options.references;
        eo.complete_gain_trials = false;       // the sweep reports the trial's choice, not its curve
        eo.fit_ineligible_candidates = false;  // ... and the model auto chose, not the others
        eo.fit_threads = 1;  // the runs are the sweep's threads (the fits' results do not depend on it)
        if (options.stop_requested) eo.stop_requested = stop_now;
        const experiment::Spec* spec = experiment::find_spec(run.experiment);
        run.command_limit_mpa = spec ? experiment::run_pressure_limit(eo, spec->valves) : nan;
        const ExperimentResult er = options.runner ? options.runner(eo) : run_experiment(eo);
        run.not_below_baseline = er.not_below_baseline();
        for (const auto& tr : er.runs) {
          SweepRunErrors e;
          e.reference = tr.reference;
          e.kind = tr.variant;
          e.errors = tr.errors;
          e.saturated = tr.saturated;
          e.guard_cuts = tr.controller.guard_cuts;
          e.guard_final_scale = tr.controller.guard_final_scale;
          e.not_below_baseline = er.not_below_baseline(tr);
          for (const auto& rr : er.reference_ranges)
            if (rr.reference == tr.reference) {
              const double span = rr.paper_max_mm - rr.paper_min_mm;
              e.reference_scale = span > 0.0 ? (rr.max_mm - rr.min_mm) / span : 1.0;
              e.reachable = rr.reachable;
            }
          if (uses_gain_trial(tr.variant))
            for (const auto& g : er.gain_trials)
              if (g.reference == tr.reference) e.gain_scale = g.scale, e.shaped = g.shaped;
          if (tr.pressure_command_mpa.empty()) {
            e.min_command_mpa = e.max_command_mpa = nan;
          } else {
            const auto [lo, hi] = std::minmax_element(tr.pressure_command_mpa.begin(), tr.pressure_command_mpa.end());
            e.min_command_mpa = *lo;
            e.max_command_mpa = *hi;
          }
          run.runs.push_back(std::move(e));
        }
        run.model = std::string(fit_model_name(er.best_fit.model_kind));
        run.model_reason = er.model_reason;
        run.ok = true;
      } catch (const Stopped&) {
        stopped.store(true);  // abandoned: no row, not counted as done, and the sweep has no result
        return;
      } catch (const std::exception& e) {
        run.ok = false;
        run.runs.clear();
        run.model.clear();
        run.not_below_baseline.clear();
        run.error = e.what();
      } catch (...) {
        run.ok = false;
        run.runs.clear();
        run.not_below_baseline.clear();
        run.error = "unknown exception";
      }
      run.wall_time_s = std::chrono::duration<double>(clock::now() - t0).count();
      std::lock_guard<std::mutex> lock(progress_mutex);
      ++done;
      if (options.progress) {
        try {
          options.progress({done, total, run.experiment, r.variants[run.variant].variant.name, run.ok, run.wall_time_s});
        } catch (...) {
          // a progress display must never stop the sweep
        }
      }
    }
  };
  if (jobs <= 1) {
    worker();
  } else {
    std::vector<std::thread> threads;
    threads.reserve(jobs);
    for (unsigned i = 0; i < jobs; ++i) threads.emplace_back(worker);
    for (auto& t : threads) t.join();
  }
  if (stopped.load() && done < total)  // a stop seen after the last run keeps the complete sweep
    throw Error(fmt::format("sweep stopped after {} of {} runs (stop requested)", done, total));
  for (std::size_t k = 0; k < slots; ++k)
    if (same_as[k] != k) {
      r.runs[k] = r.runs[same_as[k]];
      r.runs[k].variant = k % nv;
      r.runs[k].wall_time_s = 0.0;  // not run
    }
  r.wall_time_s = std::chrono::duration<double>(clock::now() - start).count();
  return r;
}

// ---- results ---------------------------------------------------------------------------

std::size_t SweepResult::failures() const noexcept {
  return static_cast<std::size_t>(std::count_if(runs.begin(), runs.end(), [](const SweepRun& r) { return !r.ok; }));
}

const SweepRunErrors* SweepResult::find(std::size_t experiment, std::size_t variant, std::string_view reference,
                                        std::string_view kind) const noexcept {
  const std::size_t k = experiment * variants.size() + variant;
  if (experiment >= experiments.size() || variant >= variants.size() || k >= runs.size() || !runs[k].ok) return nullptr;
  for (const auto& e : runs[k].runs)
    if (e.reference == reference && e.kind == kind) return &e;
  return nullptr;
}

std::string SweepResult::csv() const {
  std::string out =
      "experiment,variant,overrides,reference,kind,max_mm,mae_mm,rms_mm,rms_vs_nominal,rms_vs_baseline,"
      "min_command_mpa,max_command_mpa,saturated,reference_scale,status,error,wall_time_s,guard_cuts,"
      "guard_final_scale,command_limit_mpa,control_period_s,not_below_baseline\n";
  for (std::size_t e = 0; e < experiments.size(); ++e)
    for (std::size_t v = 0; v < variants.size(); ++v) {
      const SweepRun& run = this->run(e, v);
      std::string overrides;
      for (const auto& o : variants[v].variant.overrides) { overrides += (overrides.empty() ? "" : " "); overrides += to_string(o); }
      const std::string head = fmt::format("{},{},{},", csv_field(experiments[e]), csv_field(variants[v].variant.name),
                                           csv_field(overrides));
      if (!run.ok) {
        out += head + fmt::format(",,,,,,,,,,,failed,{},{},,,{},{},\n", csv_field(run.error), csv_number(run.wall_time_s),
                                  csv_number(run.command_limit_mpa), csv_number(control_period));
        continue;
      }
      for (const auto& x : run.runs) {
        const SweepRunErrors* nom = find(e, 0, x.reference, x.kind);
        const SweepRunErrors* base = find(e, v, x.reference, "baseline");
        out += head + fmt::format("{},{},{},{},{},{},{},{},{},{},{},ok,,{},{},{},{},{},{}\n", csv_field(x.reference),
                                  csv_field(x.kind), csv_number(x.errors.max_error_mm), csv_number(x.errors.mae_mm),
                                  csv_number(x.errors.rms_error_mm),
                                  csv_number(nom ? ratio(x.errors.rms_error_mm, nom->errors.rms_error_mm) : nan),
                                  csv_number(base ? ratio(x.errors.rms_error_mm, base->errors.rms_error_mm) : nan),
                                  csv_number(x.min_command_mpa), csv_number(x.max_command_mpa), x.saturated,
                                  csv_number(x.reference_scale), csv_number(run.wall_time_s), x.guard_cuts,
                                  csv_number(x.guard_final_scale), csv_number(run.command_limit_mpa),
                                  csv_number(control_period),
                                  is_hysterons_loop(x.kind) ? (x.not_below_baseline ? "1" : "0") : "");
      }
    }
  return out;
}

std::vector<std::string> SweepResult::target_misses() const {
  std::vector<std::string> out;
  for (std::size_t e = 0; e < experiments.size(); ++e)
    for (std::size_t v = 0; v < variants.size(); ++v) {
      const SweepRun& run = this->run(e, v);
      const std::string& vn = variants[v].variant.name;
      if (!run.ok) {
        out.push_back(fmt::format("{} {}: failed: {}", experiments[e], vn, run.error));
        continue;
      }
      for (const auto& x : run.runs) {
        const std::string what = fmt::format("{} {} {} {}", experiments[e], vn, x.reference, x.kind);
        // (a limit that is not finite: an unknown experiment, whose runs failed)
        if (std::isfinite(x.min_command_mpa) &&
            (x.min_command_mpa < 0.0 || !(x.max_command_mpa <= run.command_limit_mpa)))
          out.push_back(fmt::format("{}: pressure command {:.4f}..{:.4f} MPa leaves 0..{:g} MPa", what,
                                    x.min_command_mpa, x.max_command_mpa, run.command_limit_mpa));
        if (x.kind != "compensated") continue;
        if (!x.reachable)
          out.push_back(fmt::format("{}: the reference leaves the rig's reach (--paper-references; the error "
                                    "beyond it is the actuator's limit)",
                                    what));
        const SweepRunErrors* nom = find(e, 0, x.reference, x.kind);
        const SweepRunErrors* base = find(e, v, x.reference, "baseline");
        const double limit = variants[v].variant.rms_ratio_limit;
        if (v > 0 && nom && x.errors.rms_error_mm > limit * nom->errors.rms_error_mm)
          out.push_back(fmt::format("{}: RMS {:.3f} mm = {:.2f}x nominal {:.3f} mm (target <= {}x)", what,
                                    x.errors.rms_error_mm, x.errors.rms_error_mm / nom->errors.rms_error_mm,
                                    nom->errors.rms_error_mm, limit));
        if (base && !(x.errors.rms_error_mm < base->errors.rms_error_mm))
          out.push_back(fmt::format("{}: RMS {:.3f} mm not below the baseline's {:.3f} mm", what,
                                    x.errors.rms_error_mm, base->errors.rms_error_mm));
      }
    }
  return out;
}

namespace {
// f(e, v, x) for every tracking run x of every finished (experiment e, variant v) run.
template <class F>
void each_tracking_run(const SweepResult& r, F&& f) {
  for (std::size_t e = 0; e < r.experiments.size(); ++e)
    for (std::size_t v = 0; v < r.variants.size(); ++v) {
      const SweepRun& run = r.run(e, v);
      if (!run.ok) continue;
      for (const auto& x : run.runs) f(e, v, x);
    }
}
}  // namespace

std::vector<std::string> SweepResult::learning_not_below_compensated() const {
  std::vector<std::string> out;
  each_tracking_run(*this, [&](std::size_t e, std::size_t v, const SweepRunErrors& x) {
    if (x.kind != "learning") return;
    const SweepRunErrors* c = find(e, v, x.reference, "compensated");
    if (!c || x.errors.rms_error_mm < c->errors.rms_error_mm) return;
    out.push_back(fmt::format("{} {} {} learning: RMS {:.3f} mm, not below the compensated loop's {:.3f} mm ({:.2f}x)",
                              experiments[e], variants[v].variant.name, x.reference, x.errors.rms_error_mm,
                              c->errors.rms_error_mm, ratio(x.errors.rms_error_mm, c->errors.rms_error_mm)));
  });
  return out;
}

std::vector<std::string> SweepResult::not_below_baseline() const {
  std::vector<std::string> out;
  each_tracking_run(*this, [&](std::size_t e, std::size_t v, const SweepRunErrors& x) {
    if (!x.not_below_baseline) return;
    const SweepRunErrors* b = find(e, v, x.reference, "baseline");
    const double base = b ? b->errors.rms_error_mm : nan;
    out.push_back(fmt::format("{} {} {} {}: RMS {:.3f} mm, not below the baseline's {:.3f} mm ({:.2f}x)",
                              experiments[e], variants[v].variant.name, x.reference, x.kind, x.errors.rms_error_mm,
                              base, ratio(x.errors.rms_error_mm, base)));
  });
  return out;
}

std::vector<std::string> SweepResult::guard_acted() const {
  std::vector<std::string> out;
  each_tracking_run(*this, [&](std::size_t e, std::size_t v, const SweepRunErrors& x) {
    if (x.guard_cuts > 0)
      out.push_back(fmt::format("{} {} {} {}: gains cut {} time(s), to x{:.2f} of the tuned ones (RMS {:.3f} mm)",
                                experiments[e], variants[v].variant.name, x.reference, x.kind, x.guard_cuts,
                                x.guard_final_scale, x.errors.rms_error_mm));
  });
  return out;
}

std::string SweepResult::identification_note() const {
  if (!identify_on_base) return {};
  return "identified on the base rig: every run was identified and tuned on the base rig (the row 'nominal') and "
         "tracked on the variant's, a rig that changed after its identification, its loops not re-tuned; issue 11's "
         "targets were set for rigs identified and tuned as they are";
}

std::string SweepResult::text() const {
  const std::vector<std::string> kinds = kinds_of(*this);
  std::size_t wv = 7;
  for (const auto& v : variants) wv = std::max(wv, v.variant.name.size());
  std::string out = fmt::format("Sweep: {} experiment(s) x {} rig(s), seed {}, control period {:g} ms, {} thread(s), "
                                "{:.1f} s wall time\n",
                                experiments.size(), variants.size(), seed, control_period * 1e3, jobs, wall_time_s);
  out += "RMS tracking error [mm] per variant kind; comp/nom = compensated RMS / its nominal value;\n"
         "comp/base = compensated / baseline RMS; command = min..max pressure command over every kind [MPa];\n";
  out += "ref xS = the reference mapped into the rig's reach, its span scaled by S (docs/control.md, section 5);\n";
  out += "PID xS [shaped] = the gain trial's choice for the compensated and adaptive loops (the shaping also for\n"
         "the learning loop's feedforward, a scale below 1 also for its PID), where not x1.00 unshaped\n"
         "(docs/control.md, sections 2 and 3);\n";
  out += fmt::format("model = the kind of hysteron's model the compensated variants invert ({})\n",
                     model == FitModel::automatic ? std::string("auto: chosen by each run on its rig")
                                                  : fmt::format("--model {}", fit_model_name(model)));
  if (const std::string note = identification_note(); !note.empty()) out += note + "\n";
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    out += fmt::format("\n{}\n{:<{}}  {:<9}", experiments[e], "variant", wv, "reference");
    for (const auto& k : kinds) out += fmt::format(" {:>11}", k);
    out += fmt::format(" {:>9} {:>9} {:>13}  {}\n", "comp/nom", "comp/base", "command", "model");
    for (std::size_t v = 0; v < variants.size(); ++v) {
      const SweepRun& run = this->run(e, v);
      if (!run.ok) {
        out += fmt::format("{:<{}}  FAILED: {}\n", variants[v].variant.name, wv, run.error);
        continue;
      }
      for (const auto& ref : references_of(*this, e)) {
        out += fmt::format("{:<{}}  {:<9}", variants[v].variant.name, wv, ref);
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const auto& k : kinds) {
          const SweepRunErrors* x = find(e, v, ref, k);
          out += x ? fmt::format(" {:>11.3f}", x->errors.rms_error_mm) : fmt::format(" {:>11}", "-");
          if (x && std::isfinite(x->min_command_mpa)) lo = std::min(lo, x->min_command_mpa), hi = std::max(hi, x->max_command_mpa);
        }
        const SweepRunErrors* c = find(e, v, ref, "compensated");
        const SweepRunErrors* n = find(e, 0, ref, "compensated");
        const SweepRunErrors* b = find(e, v, ref, "baseline");
        const double rn = c && n ? ratio(c->errors.rms_error_mm, n->errors.rms_error_mm) : nan;
        const double rb = c && b ? ratio(c->errors.rms_error_mm, b->errors.rms_error_mm) : nan;
        out += std::isfinite(rn) ? fmt::format(" {:>9.2f}", rn) : fmt::format(" {:>9}", "-");
        out += std::isfinite(rb) ? fmt::format(" {:>9.2f}", rb) : fmt::format(" {:>9}", "-");
        out += std::isfinite(lo) ? fmt::format(" {:>6.3f}..{:<5.3f}", lo, hi) : fmt::format(" {:>13}", "-");
        out += fmt::format("  {}", run.model);
        if (c && (c->gain_scale != 1.0 || c->shaped))
          out += fmt::format("  PID x{:.2f}{}", c->gain_scale, c->shaped ? " shaped" : "");
        if (c && c->reference_scale != 1.0) out += fmt::format("  ref x{:.3f}", c->reference_scale);
        if (c && !c->reachable) out += "  ref out of reach";
        out += "\n";
      }
    }
  }
  for (const auto& n : notes) out += fmt::format("\nnote: {}", n);
  if (!notes.empty()) out += "\n";
  const auto misses = target_misses();
  out += misses.empty() ? std::string("\nEvery issue-11 target met (compensated RMS, baseline, command range).\n")
                        : fmt::format("\nIssue-11 targets missed ({}):\n", misses.size());
  for (const auto& m : misses) out += "  " + m + "\n";
  if (const auto above = learning_not_below_compensated(); !above.empty()) {
    out += fmt::format("\nLearning runs not below their compensated loop ({}):\n", above.size());
    for (const auto& m : above) out += "  " + m + "\n";
  }
  if (const auto useless = not_below_baseline(); !useless.empty()) {
    out += fmt::format("\nRuns of hysteron's loops not below their baseline ({}; `hysteron experiment` exits 3 on "
                       "such a rig, the sweep does not):\n",
                       useless.size());
    for (const auto& m : useless) out += "  " + m + "\n";
  }
  if (const auto cut = guard_acted(); !cut.empty()) {
    out += fmt::format("\nRuns whose limit-cycle guard cut the PID's gains ({}; they rang near the relay's period, "
                       "docs/control.md section 2):\n",
                       cut.size());
    for (const auto& m : cut) out += "  " + m + "\n";
  }
  return out;
}

json SweepResult::to_json() const {
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["seed"] = seed;
  j["jobs"] = jobs;
  j["wall_time_s"] = wall_time_s;
  j["model_choice"] = std::string(fit_model_name(model));
  j["fit_references"] = fit_references;
  j["identify_on_base"] = identify_on_base;
  j["control_period_s"] = control_period;
  j["identification_note"] = identification_note();
  j["experiments"] = experiments;
  j["failures"] = failures();
  j["variants"] = json::array();
  for (const auto& v : variants) {
    json o;
    o["name"] = v.variant.name;
    o["group"] = v.variant.group;
    o["rms_ratio_limit"] = v.variant.rms_ratio_limit;
    o["overrides"] = json::array();
    for (std::size_t i = 0; i < v.variant.overrides.size(); ++i)
      o["overrides"].push_back({{"path", v.variant.overrides[i].path},
                                {"text", to_string(v.variant.overrides[i])},
                                {"value", number(v.values.at(i))}});
    j["variants"].push_back(std::move(o));
  }
  j["runs"] = json::array();
  for (const auto& run : runs) {
    json o;
    o["experiment"] = run.experiment;
    o["variant"] = variants.at(run.variant).variant.name;
    o["ok"] = run.ok;
    if (!run.ok) o["error"] = run.error;
    if (run.ok) o["model"] = run.model, o["model_reason"] = run.model_reason;
    // as the experiment's result.json: "ok", "not_below_baseline" (its runs listed), or "failed"
    o["status"] = !run.ok ? "failed" : run.not_below_baseline.empty() ? "ok" : "not_below_baseline";
    o["not_below_baseline"] = run.not_below_baseline;
    o["wall_time_s"] = run.wall_time_s;
    o["command_limit_mpa"] = number(run.command_limit_mpa);
    o["tracking"] = json::array();
    const std::size_t e = static_cast<std::size_t>(
        std::find(experiments.begin(), experiments.end(), run.experiment) - experiments.begin());
    for (const auto& x : run.runs) {
      const SweepRunErrors* nom = find(e, 0, x.reference, x.kind);
      const SweepRunErrors* base = find(e, run.variant, x.reference, "baseline");
      json t = {{"reference", x.reference},
                               {"kind", x.kind},
                               {"max_error_mm", number(x.errors.max_error_mm)},
                               {"mae_mm", number(x.errors.mae_mm)},
                               {"rms_error_mm", number(x.errors.rms_error_mm)},
                               {"rms_vs_nominal", number(nom ? ratio(x.errors.rms_error_mm, nom->errors.rms_error_mm) : nan)},
                               {"rms_vs_baseline", number(base ? ratio(x.errors.rms_error_mm, base->errors.rms_error_mm) : nan)},
                               {"min_command_mpa", number(x.min_command_mpa)},
                               {"max_command_mpa", number(x.max_command_mpa)},
                               {"saturated", x.saturated},
                               {"reference_scale", number(x.reference_scale)},
                               {"reachable", x.reachable}};
      if (uses_gain_trial(x.kind)) t["gain_scale"] = x.gain_scale, t["shaped"] = x.shaped;
      t["guard_cuts"] = x.guard_cuts;
      t["guard_final_scale"] = x.guard_final_scale;
      if (is_hysterons_loop(x.kind)) t["not_below_baseline"] = x.not_below_baseline;
      o["tracking"].push_back(std::move(t));
    }
    j["runs"].push_back(std::move(o));
  }
  j["target_misses"] = target_misses();
  j["learning_not_below_compensated"] = learning_not_below_compensated();
  j["not_below_baseline"] = not_below_baseline();
  j["guard_acted"] = guard_acted();
  j["notes"] = notes;
  return j;
}

}  // namespace hysteron
