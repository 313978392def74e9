// Plant variants (sweep.hpp): the override parser, the documented set, grid files,
// and one small sweep run serially and in parallel (bit-for-bit equal, a failing
// variant recorded, a heavier load changing the errors).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <cstring>
#include <mutex>
#include <optional>
#include <set>
#include <algorithm>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/error.hpp"
#include "hysteron/sweep.hpp"

using namespace hysteron;

namespace {

// The message of the hysteron::Error thrown by f ("" if none is thrown).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Splits one CSV line (double quotes, "" inside quotes).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') out.back() += '"', ++i;
      else if (c == '"') quoted = false;
      else out.back() += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

// ---- overrides ---------------------------------------------------------------------

TEST(SweepOverride, ParsesPathsAbsoluteAndPercentValues) {
  ParameterOverride o = parse_override("load.mass=35", "test");
  EXPECT_EQ(o.path, "load.mass");
  EXPECT_EQ(o.value, 35.0);
  EXPECT_FALSE(o.percent);
  o = parse_override(" hysteresis.pressure_band = 2.5e4 ", "test");
  EXPECT_EQ(o.path, "hysteresis.pressure_band");
  EXPECT_EQ(o.value, 25000.0);
  o = parse_override("muscle.force_620=-15%", "test");
  EXPECT_EQ(o.path, "muscle.force_620");
  EXPECT_EQ(o.value, -15.0);
  EXPECT_TRUE(o.percent);
  EXPECT_EQ(to_string(o), "muscle.force_620=-15%");
  EXPECT_EQ(to_string(parse_override("muscle.force_620=+15%", "test")), "muscle.force_620=+15%");
  EXPECT_EQ(to_string(parse_override("regulator.dead_time=0.012", "test")), "regulator.dead_time=0.012");
}

TEST(SweepOverride, EveryRigParameterHasAPath) {
  const std::vector<std::string> paths = rig_parameter_paths();
  const std::set<std::string> unique(paths.begin(), paths.end());
  EXPECT_EQ(unique.size(), paths.size());
  // the parameters docs/plant.md lists, one per section at least
  for (const char* p : {"muscle.force_620", "hysteresis.pressure_band", "air.supply_pressure",
                        "regulator.time_constant", "regulator.dead_time", "valves.pwm_frequency", "load.mass",
                        "load.damping", "sensors.pressure_bits", "simulation.max_substeps"})
    EXPECT_TRUE(unique.count(p)) << p;
  for (const auto& p : paths) EXPECT_NO_THROW(check_parameter_path(p, "test")) << p;
}

TEST(SweepOverride, UnknownPathNamesItAndTheClosestNames) {
  std::string m = error_of([] { parse_override("load.mas=35", "--vary load.mas=35"); });
  EXPECT_TRUE(contains(m, "--vary load.mas=35")) << m;
  EXPECT_TRUE(contains(m, "unknown rig parameter 'load.mas'")) << m;
  EXPECT_TRUE(contains(m, "did you mean load.mass")) << m;
  // a bare key: the full path with that key is suggested
  m = error_of([] { parse_override("mass=35", "x"); });
  EXPECT_TRUE(contains(m, "'mass'")) << m;
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  // the section exists: its keys are listed
  m = error_of([] { parse_override("regulator.tau=0.1", "x"); });
  EXPECT_TRUE(contains(m, "time_constant")) << m;
  EXPECT_TRUE(contains(m, "dead_time")) << m;
  // an unknown section: the sections are listed
  m = error_of([] { parse_override("motor.mass=1", "x"); });
  EXPECT_TRUE(contains(m, "'motor.mass'")) << m;
  EXPECT_TRUE(contains(m, "hysteresis")) << m;
  // a section is not a parameter
  EXPECT_FALSE(error_of([] { parse_override("load=3", "x"); }).empty());
  EXPECT_FALSE(error_of([] { parse_override("load.mass.x=3", "x"); }).empty());
}

TEST(SweepOverride, BadValuesAreErrorsNamingThePath) {
  for (const char* text : {"load.mass=", "load.mass=abc", "load.mass=12kg", "load.mass=nan", "load.mass=NaN",
                           "load.mass=-nan", "load.mass=inf", "load.mass=-infinity", "load.mass=1e999",
                           "load.mass=%", "load.mass=10%%", "load.mass=-100%", "load.mass=-150%", "load.mass 35",
                           "=35"}) {
    const std::string m = error_of([&] { parse_override(text, "where"); });
    EXPECT_FALSE(m.empty()) << text;
    EXPECT_TRUE(contains(m, "where")) << m;
    if (std::string(text).starts_with("load.mass")) {
      EXPECT_TRUE(contains(m, "load.mass")) << m;
    }
  }
}

TEST(SweepOverride, ApplyChangesOnlyTheNamedParameters) {
  const PamRigParams base;
  PamRigParams r = apply_overrides(base, {parse_override("load.mass=35", "t")}, "t");
  EXPECT_EQ(r.load.mass, 35.0);
  r.load.mass = base.load.mass;
  EXPECT_EQ(rig_params_to_json(r), rig_params_to_json(base));
  // percent of the base value: docs/plant.md's 1326 N force map, -15 % and +15 %
  r = apply_overrides(base, {parse_override("muscle.force_620=-15%", "t")}, "t");
  EXPECT_NEAR(r.muscle.force_620, 1326.0 * 0.85, 1e-9);
  r = apply_overrides(base, {parse_override("muscle.force_620=+15%", "t")}, "t");
  EXPECT_NEAR(r.muscle.force_620, 1326.0 * 1.15, 1e-9);
  // percent of a base that is not the nominal rig
  PamRigParams heavy;
  heavy.load.mass = 30.0;
  EXPECT_NEAR(apply_overrides(heavy, {parse_override("load.mass=+10%", "t")}, "t").load.mass, 33.0, 1e-12);
  // an integer field takes an integral value
  r = apply_overrides(base, {parse_override("sensors.pressure_bits=10", "t")}, "t");
  EXPECT_EQ(r.sensors.pressure_bits, 10);
  // two overrides of one variant, in order
  r = apply_overrides(base, {parse_override("regulator.time_constant=0.1", "t"),
                             parse_override("regulator.dead_time=0.012", "t")}, "t");
  EXPECT_EQ(r.regulator.time_constant, 0.1);
  EXPECT_EQ(r.regulator.dead_time, 0.012);
}

TEST(SweepOverride, ValuesTheRigRefusesAreErrorsNamingTheVariantAndKey) {
  const PamRigParams base;
  std::string m = error_of([&] { apply_overrides(base, {parse_override("load.mass=-5", "t")}, "variant 'light'"); });
  EXPECT_TRUE(contains(m, "variant 'light'")) << m;
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  m = error_of([&] { apply_overrides(base, {parse_override("sensors.pressure_bits=12.5", "t")}, "v"); });
  EXPECT_TRUE(contains(m, "sensors.pressure_bits")) << m;
  m = error_of([&] { apply_overrides(base, {parse_override("hysteresis.beta=1.5", "t")}, "v"); });
  EXPECT_TRUE(contains(m, "hysteresis.beta")) << m;
  // a relation between fields: the on-delay must stay below the 5 ms PWM period
  m = error_of([&] { apply_overrides(base, {parse_override("valves.on_delay=0.01", "t")}, "v"); });
  EXPECT_TRUE(contains(m, "valves.on_delay")) << m;
}

TEST(SweepVary, OneVariantPerValueAndPairsVariedTogether) {
  auto v = parse_vary("load.mass=10,20,35");
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0].name, "load.mass=10");
  EXPECT_EQ(v[2].name, "load.mass=35");
  for (const auto& x : v) {
    EXPECT_EQ(x.group, "load.mass");
    ASSERT_EQ(x.overrides.size(), 1u);
  }
  EXPECT_EQ(v[1].overrides[0].value, 20.0);
  v = parse_vary("regulator.time_constant/regulator.dead_time=0.03/0.005,0.1/0.012");
  ASSERT_EQ(v.size(), 2u);
  ASSERT_EQ(v[1].overrides.size(), 2u);
  EXPECT_EQ(v[1].overrides[0].path, "regulator.time_constant");
  EXPECT_EQ(v[1].overrides[0].value, 0.1);
  EXPECT_EQ(v[1].overrides[1].path, "regulator.dead_time");
  EXPECT_EQ(v[1].overrides[1].value, 0.012);
  v = parse_vary("muscle.force_620=-15%,+15%");
  ASSERT_EQ(v.size(), 2u);
  EXPECT_TRUE(v[0].overrides[0].percent);
  for (const char* bad : {"load.mass", "load.mass=10,,35", "load.mass=10,", "load.mas=10",
                          "regulator.time_constant/regulator.dead_time=0.03", "load.mass=10/20", "load.mass=x"})
    EXPECT_TRUE(contains(error_of([&] { parse_vary(bad); }), "--vary")) << bad;
}

TEST(SweepGrid, ExplicitVariantsAndStrictKeys) {
  const auto j = nlohmann::json::parse(R"({"variants": [
      {"name": "heavy", "set": {"load.mass": 35}},
      {"set": {"load.mass": 35, "muscle.force_620": "-15%"}, "rms_ratio_limit": 2}]})");
  const auto v = variant_grid_from_json(j, "grid.json");
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0].name, "heavy");
  EXPECT_EQ(v[0].group, "load.mass");
  EXPECT_EQ(v[0].rms_ratio_limit, 1.5);
  EXPECT_EQ(v[1].group, "");
  EXPECT_EQ(v[1].rms_ratio_limit, 2.0);
  ASSERT_EQ(v[1].overrides.size(), 2u);
  EXPECT_TRUE(v[1].overrides[1].percent);
  EXPECT_FALSE(v[1].name.empty());

  auto err = [](const char* text) { return error_of([&] { variant_grid_from_json(nlohmann::json::parse(text), "g.json"); }); };
  std::string m = err(R"({"variants": [{"set": {"load.mass": 35}}, {"set": {"load.mas": 35}}]})");
  EXPECT_TRUE(contains(m, "g.json.variants[1]")) << m;
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  m = err(R"({"variants": [{"set": {"load.mass": 35}, "nmae": "x"}]})");
  EXPECT_TRUE(contains(m, "unknown key 'nmae'")) << m;
  m = err(R"({"variant": []})");
  EXPECT_TRUE(contains(m, "g.json")) << m;
  m = err(R"({"variants": [{"set": {"load.mass": "heavy"}}]})");
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  m = err(R"({"variants": [{"set": {"load.mass": null}}]})");
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  EXPECT_FALSE(err(R"({"variants": [{"name": "x"}]})").empty());
  EXPECT_FALSE(err(R"({"variants": []})").empty());
  EXPECT_FALSE(err(R"([1, 2])").empty());
  EXPECT_FALSE(error_of([] { read_variant_grid("/nonexistent/grid.json"); }).empty());
}

// The list of issue 11, item 4 (values from the issue, not from the code).
TEST(SweepDocumented, IsTheIssuesListAndItsWorstCombination) {
  const PamRigParams nominal;
  std::set<double> mass, band, force, damping;
  std::set<std::pair<double, double>> regulator;
  const PlantVariant* worst = nullptr;
  const auto variants = documented_variants();
  std::set<std::string> names;
  for (const auto& v : variants) {
    EXPECT_TRUE(names.insert(v.name).second) << v.name;
    if (v.group.empty()) {
      worst = &v;
      continue;
    }
    const PamRigParams r = apply_overrides(nominal, v.overrides, v.name);
    if (v.group == "load.mass") mass.insert(r.load.mass);
    else if (v.group == "hysteresis.pressure_band") band.insert(r.hysteresis.pressure_band);
    else if (v.group == "muscle.force_620") force.insert(std::round(r.muscle.force_620 / 1326.0 * 100.0));
    else if (v.group == "load.damping") damping.insert(r.load.damping);
    else if (v.group == "regulator.time_constant/regulator.dead_time")
      regulator.insert({r.regulator.time_constant, r.regulator.dead_time});
    else
      ADD_FAILURE() << "unexpected group " << v.group;
  }
  // the nominal values (20 kg, 15 kPa, 100 %, 50 ms / 7 ms, 400 N s/m) are the nominal rig
  EXPECT_EQ(mass, (std::set<double>{10.0, 35.0}));
  EXPECT_EQ(band, (std::set<double>{10e3, 25e3}));
  EXPECT_EQ(force, (std::set<double>{85.0, 115.0}));
  EXPECT_EQ(regulator, (std::set<std::pair<double, double>>{{0.03, 0.005}, {0.1, 0.012}}));
  EXPECT_EQ(damping, (std::set<double>{200.0, 800.0}));
  EXPECT_EQ(nominal.load.mass, 20.0);
  EXPECT_EQ(nominal.hysteresis.pressure_band, 15e3);
  EXPECT_EQ(nominal.regulator.time_constant, 0.05);
  EXPECT_EQ(nominal.regulator.dead_time, 0.007);
  EXPECT_EQ(nominal.load.damping, 400.0);
  // worst: heaviest load, widest band, weakest force map, slowest regulator, lowest damping
  ASSERT_NE(worst, nullptr);
  EXPECT_EQ(worst->rms_ratio_limit, 2.0);
  const PamRigParams w = apply_overrides(nominal, worst->overrides, "worst");
  EXPECT_EQ(w.load.mass, 35.0);
  EXPECT_EQ(w.hysteresis.pressure_band, 25e3);
  EXPECT_NEAR(w.muscle.force_620, 1326.0 * 0.85, 1e-9);
  EXPECT_EQ(w.regulator.time_constant, 0.1);
  EXPECT_EQ(w.regulator.dead_time, 0.012);
  EXPECT_EQ(w.load.damping, 200.0);
  EXPECT_EQ(variants.size(), 11u);
}

// A cheap stand-in for run_experiment: errors that depend on the rig and the experiment,
// kinds beyond the papers' (any name must be handled), a finish order unlike the start
// order, and failures (a hysteron::Error and another exception).
ExperimentResult fake_experiment(const ExperimentOptions& o) {
  const double m = o.rig.load.mass, c = o.rig.load.damping;
  if (m > 100.0) throw std::runtime_error(fmt::format("fake: mass {} too heavy", m));
  if (c == 0.0) throw Error("fake: no damping");
  std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int>(m * 37) % 3000));
  ExperimentResult r;
  r.name = o.name;
  for (const char* ref : {"sine", "triangle"})
    for (const char* kind : {"faithful", "compensated", "adaptive", "future-kind", "baseline"}) {
      TrackingRun t;
      t.reference = ref;
      t.variant = kind;
      const double k = static_cast<double>(std::strlen(kind)) + (ref[0] == 's' ? 0.5 : 0.0) + static_cast<double>(o.name.size());
      t.errors.rms_error_mm = 0.01 * k * m + 1e-4 * c;
      t.errors.max_error_mm = 3.0 * t.errors.rms_error_mm;
      t.errors.mae_mm = 0.8 * t.errors.rms_error_mm;
      t.pressure_command_mpa = {0.1, 0.001 * m, 0.05};
      r.runs.push_back(std::move(t));
    }
  return r;
}

TEST(SweepRun, StopsStartingRunsWhenAStopIsRequested) {
  SweepOptions o;
  o.experiments = {"gpi-pid", "mpi-pwm"};
  o.variants = parse_vary("load.mass=5,10,15,25,30,40,45,50,55,60");
  o.runner = fake_experiment;
  for (unsigned jobs : {1u, 3u}) {
    o.jobs = jobs;
    std::atomic<std::size_t> started{0}, asked{0};
    o.runner = [&](const ExperimentOptions& eo) {
      ++started;
      return fake_experiment(eo);
    };
    // stop once 4 runs have started: the runs under way end, no other starts
    o.stop_requested = [&] {
      ++asked;
      return started.load() >= 4;
    };
    try {
      (void)run_sweep(o);
      FAIL() << "a stopped sweep returned a result";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("sweep stopped after"), std::string::npos) << what;
      EXPECT_NE(what.find("of 22 runs"), std::string::npos) << what;
    }
    EXPECT_GE(started.load(), 4u);
    EXPECT_LE(started.load(), 3u + jobs);  // at most one more per thread, asked before it
    EXPECT_GE(asked.load(), started.load());
  }
  // never asked to stop: the whole sweep
  o.jobs = 2;
  o.runner = fake_experiment;
  o.stop_requested = [] { return false; };
  EXPECT_EQ(run_sweep(o).runs.size(), 22u);
}

// The stop reaches into the runs under way (their ExperimentOptions::stop_requested): a run that
// would go on until asked to stop is abandoned, and the sweep throws, whether the stop comes
// while other runs are still to start or during the last one.
TEST(SweepRun, AStopAbandonsTheRunsUnderWay) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=10,35,50");  // 4 runs with the base rig
  for (const unsigned jobs : {1u, 2u})
    for (const std::size_t stop_in_run : {1u, 4u}) {
      o.jobs = jobs;
      std::atomic<std::size_t> started{0}, abandoned{0};
      std::atomic<bool> stop{false};
      o.stop_requested = [&] { return stop.load(); };
      o.runner = [&](const ExperimentOptions& eo) {
        const std::size_t n = ++started;
        if (n < stop_in_run) return fake_experiment(eo);
        stop.store(true);  // Ctrl-C during this run: it would go on for ever unless told
        for (long k = 0; k < 100000000L; ++k)
          if (eo.stop_requested && eo.stop_requested()) {
            ++abandoned;
            throw Stopped("experiment stopped (stop requested)");
          }
        ADD_FAILURE() << "the run under way was never told to stop";
        return fake_experiment(eo);
      };
      try {
        (void)run_sweep(o);
        ADD_FAILURE() << "a stopped sweep returned a result (jobs " << jobs << ", stop in run " << stop_in_run << ")";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("sweep stopped after"), std::string::npos) << e.what();
      }
      EXPECT_GE(abandoned.load(), 1u) << "jobs " << jobs << ", stop in run " << stop_in_run;
    }
}

TEST(SweepRun, EachRunFitsOnOneThread) {
  // the runs are the sweep's threads: a run's fits on usable_cpus() threads more would multiply them
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=10,20");
  o.jobs = 2;
  std::atomic<int> runs{0}, one{0};
  o.runner = [&](const ExperimentOptions& eo) {
    ++runs;
    if (eo.fit_threads == 1) ++one;
    ExperimentOptions ok = eo;
    ok.rig.load.damping = 1.0;
    return fake_experiment(ok);
  };
  (void)run_sweep(o);
  EXPECT_GE(runs.load(), 2);
  EXPECT_EQ(one.load(), runs.load());
  EXPECT_EQ(ExperimentOptions{}.fit_threads, 0);  // alone, a run's fits use every usable CPU
}

TEST(SweepRun, ThreadPoolResultsDoNotDependOnTheNumberOfThreads) {
  SweepOptions o;
  o.experiments = {"gpi-pid", "mpi-pwm"};
  o.variants = parse_vary("load.mass=5,10,15,25,30,40,45,50,150,55,60");
  for (auto& v : parse_vary("load.damping=0,100,700")) o.variants.push_back(v);
  o.runner = fake_experiment;
  std::vector<SweepResult> results;
  for (unsigned jobs : {1u, 2u, 3u, 8u}) {
    o.jobs = jobs;
    std::size_t calls = 0, last = 0;
    o.progress = [&](const SweepProgress& p) {
      ++calls;
      EXPECT_EQ(p.done, last + 1);
      last = p.done;
      EXPECT_EQ(p.total, 2u * 15u);
    };
    results.push_back(run_sweep(o));
    EXPECT_EQ(calls, 30u);
    EXPECT_EQ(results.back().jobs, jobs);
  }
  const SweepResult& a = results[0];
  ASSERT_EQ(a.variants.size(), 15u);
  ASSERT_EQ(a.runs.size(), 30u);
  for (const auto& b : results) {
    for (std::size_t k = 0; k < a.runs.size(); ++k) {
      EXPECT_EQ(a.runs[k].experiment, b.runs[k].experiment);
      EXPECT_EQ(a.runs[k].variant, b.runs[k].variant);
      EXPECT_EQ(a.runs[k].ok, b.runs[k].ok);
      EXPECT_EQ(a.runs[k].error, b.runs[k].error);
      ASSERT_EQ(a.runs[k].runs.size(), b.runs[k].runs.size());
      for (std::size_t i = 0; i < a.runs[k].runs.size(); ++i)
        EXPECT_TRUE(same_bits(a.runs[k].runs[i].errors.rms_error_mm, b.runs[k].runs[i].errors.rms_error_mm));
    }
  }
  // slots: experiment-major, variants in order, each with its own rig
  for (std::size_t e = 0; e < 2; ++e)
    for (std::size_t v = 0; v < a.variants.size(); ++v) {
      const SweepRun& run = a.run(e, v);
      EXPECT_EQ(run.experiment, o.experiments[e]);
      EXPECT_EQ(run.variant, v);
      const double m = a.variants[v].rig.load.mass, c = a.variants[v].rig.load.damping;
      EXPECT_EQ(run.ok, m <= 100.0 && c != 0.0) << a.variants[v].variant.name;
      if (!run.ok) continue;
      const SweepRunErrors* x = a.find(e, v, "sine", "future-kind");
      ASSERT_NE(x, nullptr);
      EXPECT_NEAR(x->errors.rms_error_mm, 0.01 * (11.0 + 0.5 + o.experiments[e].size()) * m + 1e-4 * c, 1e-12);
      EXPECT_EQ(x->min_command_mpa, std::min(0.05, 0.001 * m));
      EXPECT_EQ(x->max_command_mpa, std::max(0.1, 0.001 * m));
    }
  // the failures and their messages, whatever the exception type
  EXPECT_EQ(a.failures(), 4u);
  EXPECT_TRUE(contains(a.run(0, 9).error, "fake: mass 150 too heavy")) << a.run(0, 9).error;
  EXPECT_TRUE(contains(a.run(1, 12).error, "fake: no damping")) << a.run(1, 12).error;
  // every kind reaches the table, the text and the JSON
  const std::string csv = a.csv(), text = a.text();
  for (const char* kind : {"adaptive", "future-kind"}) {
    EXPECT_TRUE(contains(csv, std::string(",") + kind + ",")) << kind;
    EXPECT_TRUE(contains(text, kind)) << kind;
  }
  // ratios: 40 kg against the nominal 20 kg (the fake's error grows with the mass)
  const SweepRunErrors* heavy = a.find(0, 6, "triangle", "compensated");
  const SweepRunErrors* nominal = a.find(0, 0, "triangle", "compensated");
  ASSERT_NE(heavy, nullptr);
  ASSERT_NE(nominal, nullptr);
  const double ratio = heavy->errors.rms_error_mm / nominal->errors.rms_error_mm;
  EXPECT_GT(ratio, 1.9);
  bool listed = false;
  for (const auto& m : a.target_misses()) listed = listed || contains(m, "gpi-pid load.mass=40 triangle compensated");
  EXPECT_TRUE(listed);
  const auto j = a.to_json();
  EXPECT_EQ(j.at("runs").size(), 30u);
  EXPECT_NEAR(j.at("runs").at(6).at("tracking").at(6).at("rms_vs_nominal").get<double>(), ratio, 1e-12);
}

// compensated 0.1 mm x mass / 20 kg; learning that x mass / 30 kg: below the compensated loop up
// to 30 kg, equal at 30 kg, above beyond
ExperimentResult fake_learning(const ExperimentOptions& o) {
  const double m = o.rig.load.mass;
  ExperimentResult r;
  r.name = o.name;
  for (const char* kind : {"compensated", "learning"}) {
    TrackingRun t;
    t.reference = "sine";
    t.variant = kind;
    t.errors.rms_error_mm = 0.1 * m / 20.0 * (kind[0] == 'l' ? m / 30.0 : 1.0);
    t.errors.max_error_mm = 3.0 * t.errors.rms_error_mm;
    r.runs.push_back(std::move(t));
  }
  return r;
}

TEST(SweepRun, ListsTheLearningRunsNotBelowTheirCompensatedLoop) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=10,30,40");
  o.runner = fake_learning;
  o.jobs = 1;
  const SweepResult r = run_sweep(o);
  ASSERT_EQ(r.variants.size(), 4u);
  ASSERT_EQ(r.variants[0].rig.load.mass, 20.0);  // the fake's numbers assume the nominal 20 kg
  const auto above = r.learning_not_below_compensated();
  ASSERT_EQ(above.size(), 2u);
  EXPECT_TRUE(contains(above[0], "gpi-pid load.mass=30 sine learning: RMS 0.150 mm, not below the compensated "
                                 "loop's 0.150 mm (1.00x)")) << above[0];
  EXPECT_TRUE(contains(above[1], "gpi-pid load.mass=40 sine learning: RMS 0.267 mm, not below the compensated "
                                 "loop's 0.200 mm (1.33x)")) << above[1];
  const std::string text = r.text();
  EXPECT_TRUE(contains(text, "Learning runs not below their compensated loop (2):")) << text;
  EXPECT_TRUE(contains(text, above[1])) << text;
  const auto j = r.to_json();
  ASSERT_EQ(j.at("learning_not_below_compensated").size(), 2u);
  EXPECT_EQ(j.at("learning_not_below_compensated").at(0).get<std::string>(), above[0]);
  const std::string html = report::sweep_report_html(r, "hysteron sweep gpi-pid --vary load.mass=10,30,40");
  EXPECT_TRUE(contains(html, "2 learning run(s) not below their compensated loop")) << html.substr(0, 2000);
  EXPECT_TRUE(contains(html, "gpi-pid load.mass=40 sine learning: RMS 0.267 mm"));
  // a sweep where every learning run is below lists none, and the text has no such section
  o.variants = parse_vary("load.mass=10,25");
  const SweepResult below = run_sweep(o);
  EXPECT_TRUE(below.learning_not_below_compensated().empty());
  EXPECT_FALSE(contains(below.text(), "Learning runs not below"));
  EXPECT_TRUE(below.to_json().at("learning_not_below_compensated").empty());
}

// fake_learning with a baseline of 0.25 mm: the learning run is not below it from 30 kg on (0.267 mm
// at 40 kg), the compensated one never (0.2 mm). Before, a sweep's run records had no status and
// its target misses checked the compensated run alone: a learning or adaptive run at or above the
// baseline, where `hysteron experiment` exits 3, was listed nowhere.
ExperimentResult fake_learning_with_baseline(const ExperimentOptions& o) {
  ExperimentResult r = fake_learning(o);
  TrackingRun b;
  b.reference = "sine";
  b.variant = "baseline";
  b.errors.rms_error_mm = 0.25;
  b.errors.max_error_mm = 0.75;
  r.runs.push_back(std::move(b));
  return r;
}

TEST(SweepRun, CarriesTheExperimentsNotBelowBaselineIntoEveryRecord) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=10,40");
  o.runner = fake_learning_with_baseline;
  o.jobs = 1;
  const SweepResult r = run_sweep(o);
  ASSERT_EQ(r.variants.size(), 3u);
  const SweepRunErrors* heavy = r.find(0, 2, "sine", "learning");
  const SweepRunErrors* light = r.find(0, 1, "sine", "learning");
  ASSERT_NE(heavy, nullptr);
  ASSERT_NE(light, nullptr);
  EXPECT_TRUE(heavy->not_below_baseline);
  EXPECT_FALSE(light->not_below_baseline);
  EXPECT_FALSE(r.find(0, 2, "sine", "compensated")->not_below_baseline);
  EXPECT_EQ(r.run(0, 2).not_below_baseline, std::vector<std::string>{"learning (sine)"});
  const auto listed = r.not_below_baseline();
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_TRUE(contains(listed[0], "gpi-pid load.mass=40 sine learning: RMS 0.267 mm, not below the baseline's "
                                  "0.250 mm (1.07x)")) << listed[0];
  // the CSV's last column: 1 | 0 for hysteron's loops, empty for the baseline
  const std::string csv = r.csv();
  EXPECT_TRUE(contains(csv.substr(0, csv.find('\n')), ",control_period_s,not_below_baseline")) << csv;
  std::size_t ones = 0, zeros = 0, empty = 0;
  for (std::size_t s = csv.find('\n') + 1, e; s < csv.size(); s = e + 1) {
    e = csv.find('\n', s);
    const auto f = csv_fields(csv.substr(s, e - s));
    ASSERT_EQ(f.size(), 22u);
    const std::string& last = f.back();
    if (last == "1") {
      ++ones;
      EXPECT_EQ(f[2], "load.mass=40");
      EXPECT_EQ(f[4], "learning");
    } else if (last == "0") {
      ++zeros;
    } else {
      ++empty;
      EXPECT_EQ(f[4], "baseline");
    }
  }
  EXPECT_EQ(ones, 1u);
  EXPECT_EQ(zeros, 5u);
  EXPECT_EQ(empty, 3u);
  // the JSON: each run's status as the experiment's result.json, each tracking run's flag, the list
  const auto j = r.to_json();
  EXPECT_EQ(j.at("runs").at(2).at("status").get<std::string>(), "not_below_baseline");
  EXPECT_EQ(j.at("runs").at(2).at("not_below_baseline").at(0).get<std::string>(), "learning (sine)");
  EXPECT_EQ(j.at("runs").at(1).at("status").get<std::string>(), "ok");
  EXPECT_TRUE(j.at("runs").at(2).at("tracking").at(1).at("not_below_baseline").get<bool>());
  EXPECT_FALSE(j.at("runs").at(2).at("tracking").at(2).contains("not_below_baseline"));  // the baseline
  ASSERT_EQ(j.at("not_below_baseline").size(), 1u);
  EXPECT_EQ(j.at("not_below_baseline").at(0).get<std::string>(), listed[0]);
  // the text and the page
  EXPECT_TRUE(contains(r.text(), "Runs of hysteron's loops not below their baseline (1;")) << r.text();
  EXPECT_TRUE(contains(r.text(), listed[0]));
  const std::string html = report::sweep_report_html(r, "hysteron sweep gpi-pid --vary load.mass=10,40");
  EXPECT_TRUE(contains(html, "1 run(s) of hysteron's loops not below their baseline"));
  EXPECT_TRUE(contains(html, "gpi-pid load.mass=40 sine learning: RMS 0.267 mm, not below the baseline"));
  // a sweep where every loop is below lists none
  o.variants = parse_vary("load.mass=10,25");
  const SweepResult below = run_sweep(o);
  EXPECT_TRUE(below.not_below_baseline().empty());
  EXPECT_FALSE(contains(below.text(), "not below their baseline"));
  EXPECT_EQ(below.to_json().at("runs").at(0).at("status").get<std::string>(), "ok");
}

// compensated runs whose guard cut the gains above 30 kg (twice, to x0.40), none below
ExperimentResult fake_guard(const ExperimentOptions& o) {
  ExperimentResult r = fake_learning(o);
  if (o.rig.load.mass > 30.0) {
    r.runs[0].controller.guard_cuts = 2;
    r.runs[0].controller.guard_final_scale = 0.3969;
  }
  return r;
}

TEST(SweepRun, ListsTheRunsWhoseLimitCycleGuardActed) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=10,40");
  o.runner = fake_guard;
  o.jobs = 1;
  const SweepResult r = run_sweep(o);
  const auto cut = r.guard_acted();
  ASSERT_EQ(cut.size(), 1u);
  EXPECT_TRUE(contains(cut[0], "gpi-pid load.mass=40 sine compensated: gains cut 2 time(s), to x0.40 of the tuned "
                               "ones (RMS 0.200 mm)")) << cut[0];
  EXPECT_TRUE(contains(r.text(), "Runs whose limit-cycle guard cut the PID's gains (1;")) << r.text();
  const auto j = r.to_json();
  EXPECT_EQ(j.at("guard_acted").at(0).get<std::string>(), cut[0]);
  EXPECT_EQ(j.at("runs").at(2).at("tracking").at(0).at("guard_cuts").get<std::size_t>(), 2u);
  EXPECT_EQ(j.at("runs").at(1).at("tracking").at(0).at("guard_cuts").get<std::size_t>(), 0u);
  // the CSV's guard columns (before the limit, the control period and not_below_baseline, the last): the cut
  // run's, and an untouched run's
  const std::string csv = r.csv();
  EXPECT_TRUE(contains(csv.substr(0, csv.find('\n')), ",wall_time_s,guard_cuts,guard_final_scale,command_limit_mpa"))
      << csv;
  std::size_t cut_rows = 0, rows = 0;
  for (std::size_t a = csv.find('\n') + 1; a < csv.size(); a = csv.find('\n', a) + 1) {
    const std::string row = csv.substr(a, csv.find('\n', a) - a);
    ++rows;
    if (contains(row, "load.mass=40,sine,compensated,")) {
      EXPECT_TRUE(row.ends_with(",2,0.39689999999999998,0.59999999999999998,0.001,0")) << row;
      ++cut_rows;
    } else {
      EXPECT_TRUE(row.ends_with(",0,1,0.59999999999999998,0.001,0")) << row;
    }
  }
  EXPECT_EQ(cut_rows, 1u);
  EXPECT_GT(rows, 3u);
  const std::string html = report::sweep_report_html(r, "hysteron sweep gpi-pid --vary load.mass=10,40");
  EXPECT_TRUE(contains(html, "1 run(s) whose limit-cycle guard cut the PID's gains"));
  o.variants = parse_vary("load.mass=10");
  const SweepResult none = run_sweep(o);
  EXPECT_TRUE(none.guard_acted().empty());
  EXPECT_FALSE(contains(none.text(), "limit-cycle guard"));
}

// The CLI's and Python's names: "all" is every registered experiment; "documented" the one set.
TEST(SweepNames, AllIsEveryExperimentAndDocumentedTheOneSet) {
  const std::vector<std::string> every = experiment_names();
  ASSERT_EQ(every.size(), 3u);
  EXPECT_EQ(sweep_experiments({"all"}), every);
  std::vector<std::string> mixed = {"mpi-pwm"};
  for (const auto& n : every) mixed.push_back(n);
  EXPECT_EQ(sweep_experiments({"mpi-pwm", "all"}), mixed);  // run_sweep then refuses the repeat
  EXPECT_EQ(sweep_experiments({"gpi-pd"}), std::vector<std::string>{"gpi-pd"});  // checked by run_sweep
  EXPECT_EQ(variant_set("documented", "--set").size(), documented_variants().size());
  try {
    variant_set("worst", "--set");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--set worst: unknown set (the one built-in set is 'documented')");
  }
}

// --identify-on-base: every variant's run is identified and tuned on the base rig and tracks on
// the variant's rig (ExperimentOptions::tracking_rig); the nominal run has no tracking rig. The
// rigs are deduplicated as before, and the text, JSON and page say how the runs were made.
TEST(SweepRun, IdentifiedOnTheBaseRigTracksOnTheVariants) {
  SweepOptions o;
  o.experiments = {"gpi-pid", "mpi-pwm"};
  o.base.hysteresis.pressure_band = 20e3;  // a base rig other than the nominal one
  o.variants = variant_grid_from_json(nlohmann::json::parse(R"({"variants": [
      {"name": "heavy", "set": {"load.mass": 35}},
      {"name": "slow regulator", "set": {"regulator.time_constant": 0.1}}]})"), "grid");
  o.identify_on_base = true;
  o.jobs = 2;
  std::mutex m;
  struct Call {
    std::string name;
    PamRigParams rig;
    std::optional<PamRigParams> tracking;
  };
  std::vector<Call> calls;
  o.runner = [&](const ExperimentOptions& eo) {
    {
      std::lock_guard<std::mutex> lock(m);
      calls.push_back({eo.name, eo.rig, eo.tracking_rig});
    }
    ExperimentResult r = fake_experiment(eo.tracking_rig ? [&] {
      ExperimentOptions t = eo;
      t.rig = *eo.tracking_rig;  // the fake's errors follow the rig tracked on
      return t;
    }() : eo);
    return r;
  };
  const SweepResult r = run_sweep(o);
  EXPECT_TRUE(r.identify_on_base);
  // gpi-pid: nominal, heavy, slow regulator; mpi-pwm (valves): the slow regulator is its nominal rig
  ASSERT_EQ(calls.size(), 5u);
  const nlohmann::json base = rig_params_to_json(o.base);
  std::size_t tracked_on_variant = 0;
  for (const Call& c : calls) {
    EXPECT_EQ(rig_params_to_json(c.rig), base) << c.name << ": not identified on the base rig";
    if (!c.tracking) continue;
    ++tracked_on_variant;
    const nlohmann::json t = rig_params_to_json(*c.tracking);
    EXPECT_NE(t, base);
    EXPECT_TRUE(c.tracking->load.mass == 35.0 || c.tracking->regulator.time_constant == 0.1) << t.dump();
    EXPECT_EQ(c.tracking->hysteresis.pressure_band, 20e3) << "the variant is not the base rig with its overrides";
  }
  EXPECT_EQ(tracked_on_variant, 3u);  // every run but the two nominal ones
  // the errors are those of the rig tracked on
  EXPECT_EQ(r.run(0, 1).runs.at(0).errors.rms_error_mm, fake_experiment([&] {
    ExperimentOptions t;
    t.name = "gpi-pid";
    t.rig = r.variants[1].rig;
    return t;
  }()).runs.at(0).errors.rms_error_mm);
  EXPECT_TRUE(contains(r.text(), "identified on the base rig")) << r.text();
  ASSERT_FALSE(r.target_misses().empty());  // 35 kg: the fake's RMS is 1.75x nominal
  EXPECT_TRUE(contains(r.text(), "targets were set for rigs identified and tuned as they are")) << r.text();
  EXPECT_EQ(r.to_json().at("identification_note").get<std::string>(), r.identification_note());
  EXPECT_TRUE(r.to_json().at("identify_on_base").get<bool>());
  const std::string page = report::sweep_report_html(r, "hysteron sweep --identify-on-base");
  EXPECT_TRUE(contains(page, "every run was identified and tuned on the base rig (the row"));
  EXPECT_TRUE(contains(page, "targets were set for rigs identified and tuned as they are"));
  EXPECT_FALSE(contains(report::sweep_report_html(run_sweep([&] {
                                                   SweepOptions d = o;
                                                   d.identify_on_base = false;
                                                   return d;
                                                 }()),
                                                 "hysteron sweep"),
                        "identified and tuned on the base rig"));
  // by default each variant is identified on its own rig, and nothing says otherwise
  o.identify_on_base = false;
  calls.clear();
  const SweepResult own = run_sweep(o);
  for (const Call& c : calls) EXPECT_FALSE(c.tracking.has_value()) << c.name;
  EXPECT_FALSE(contains(own.text(), "identified on the base rig"));
  EXPECT_FALSE(contains(own.text(), "targets were set for rigs"));
  EXPECT_TRUE(own.identification_note().empty());
  EXPECT_FALSE(own.to_json().at("identify_on_base").get<bool>());
}

TEST(SweepRun, ARigIsRunOnce) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.runner = fake_experiment;
  o.variants = variant_grid_from_json(nlohmann::json::parse(R"({"variants": [
      {"name": "heavy", "set": {"load.mass": 35}},
      {"name": "heavy again", "set": {"load.mass": 35}},
      {"name": "nominal again", "set": {"load.damping": 400}},
      {"name": "heavy by percent", "set": {"load.mass": "+75%"}}]})"), "grid");
  const SweepResult r = run_sweep(o);
  ASSERT_EQ(r.variants.size(), 2u);
  EXPECT_EQ(r.variants[1].variant.name, "heavy");
  ASSERT_EQ(r.notes.size(), 3u);
  EXPECT_TRUE(contains(r.notes[0], "'heavy again' is the rig of variant 'heavy'")) << r.notes[0];
  EXPECT_TRUE(contains(r.notes[1], "'nominal again' is the nominal rig")) << r.notes[1];
  EXPECT_TRUE(contains(r.notes[2], "'heavy by percent' is the rig of variant 'heavy'")) << r.notes[2];
  EXPECT_EQ(r.runs.size(), 2u);
}

// A variant that differs only in what an experiment's actuator never reads
// (with_unread_parameters_of) is run once for that experiment and still run for the others.
TEST(SweepRun, AVariantTheExperimentCannotTellApartIsRunOnce) {
  SweepOptions o;
  o.experiments = {"gpi-pid", "mpi-pwm"};  // the regulator; the switching valves
  o.variants = variant_grid_from_json(nlohmann::json::parse(R"({"variants": [
      {"name": "slow regulator", "set": {"regulator.time_constant": 0.1, "regulator.dead_time": 0.012}},
      {"name": "slow valves", "set": {"valves.on_delay": 0.002}},
      {"name": "heavy", "set": {"load.mass": 35}},
      {"name": "heavy, slow regulator", "set": {"load.mass": 35, "regulator.time_constant": 0.1}}]})"), "grid");
  std::mutex m;
  std::vector<std::pair<std::string, PamRigParams>> called;
  o.runner = [&](const ExperimentOptions& eo) {
    {
      std::lock_guard<std::mutex> lock(m);
      called.emplace_back(eo.name, eo.rig);
    }
    ExperimentResult r = fake_experiment(eo);
    // the rig's regulator and valve timing in the errors: a copied slot shows whose run it is
    for (auto& t : r.runs) t.errors.mae_mm = eo.rig.regulator.time_constant + eo.rig.valves.on_delay;
    return r;
  };
  std::size_t progress_total = 0;
  o.progress = [&](const SweepProgress& p) { progress_total = p.total; };
  o.jobs = 2;
  const SweepResult r = run_sweep(o);
  ASSERT_EQ(r.variants.size(), 5u);
  ASSERT_EQ(r.runs.size(), 10u);
  auto runs_of = [&](const std::string& e, double tau, double on_delay, double mass) {
    return std::count_if(called.begin(), called.end(), [&](const auto& c) {
      return c.first == e && c.second.regulator.time_constant == tau && c.second.valves.on_delay == on_delay &&
             c.second.load.mass == mass;
    });
  };
  const PamRigParams nominal{};
  const double tau0 = nominal.regulator.time_constant, d0 = nominal.valves.on_delay, m0 = nominal.load.mass;
  // gpi-pid (regulator): every variant but the valves' timing; mpi-pwm (valves): every one but
  // the regulator's lag, and the heavy rig's slow-regulator twin
  EXPECT_EQ(called.size(), 7u);
  EXPECT_EQ(progress_total, 7u);
  EXPECT_EQ(runs_of("gpi-pid", tau0, d0, m0), 1);
  EXPECT_EQ(runs_of("gpi-pid", 0.1, d0, m0), 1);
  EXPECT_EQ(runs_of("gpi-pid", tau0, 0.002, m0), 0);
  EXPECT_EQ(runs_of("gpi-pid", tau0, d0, 35.0), 1);
  EXPECT_EQ(runs_of("gpi-pid", 0.1, d0, 35.0), 1);
  EXPECT_EQ(runs_of("mpi-pwm", tau0, d0, m0), 1);
  EXPECT_EQ(runs_of("mpi-pwm", 0.1, d0, m0), 0);
  EXPECT_EQ(runs_of("mpi-pwm", tau0, 0.002, m0), 1);
  EXPECT_EQ(runs_of("mpi-pwm", tau0, d0, 35.0), 1);
  EXPECT_EQ(runs_of("mpi-pwm", 0.1, d0, 35.0), 0);
  // every slot is filled, with its own variant index; a copied slot has the run it copies
  auto mae = [&](std::size_t e, std::size_t v) { return r.run(e, v).runs.at(0).errors.mae_mm; };
  for (std::size_t e = 0; e < 2; ++e)
    for (std::size_t v = 0; v < 5; ++v) {
      EXPECT_TRUE(r.run(e, v).ok) << e << " " << v;
      EXPECT_EQ(r.run(e, v).variant, v);
      EXPECT_EQ(r.run(e, v).experiment, o.experiments[e]);
    }
  EXPECT_EQ(mae(0, 2), tau0 + d0);  // gpi-pid, slow valves: the nominal run
  EXPECT_EQ(mae(1, 1), tau0 + d0);  // mpi-pwm, slow regulator: the nominal run
  EXPECT_EQ(mae(1, 4), tau0 + d0);  // mpi-pwm, heavy and slow regulator: the heavy run
  EXPECT_EQ(r.run(1, 4).runs.at(0).errors.rms_error_mm, r.run(1, 3).runs.at(0).errors.rms_error_mm);
  EXPECT_EQ(mae(0, 1), 0.1 + d0);
  EXPECT_EQ(mae(1, 2), tau0 + 0.002);
  EXPECT_EQ(r.run(1, 1).wall_time_s, 0.0);
  std::size_t said = 0;
  for (const auto& n : r.notes)
    said += contains(n, "mpi-pwm on variant 'slow regulator': the rig of variant 'nominal'") ||
            contains(n, "mpi-pwm on variant 'heavy, slow regulator': the rig of variant 'heavy'") ||
            contains(n, "gpi-pid on variant 'slow valves': the rig of variant 'nominal'");
  EXPECT_EQ(said, 3u);
  EXPECT_EQ(r.notes.size(), 3u);
}

TEST(SweepRun, InvalidOptionsThrowBeforeRunning) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = parse_vary("load.mass=35");
  int calls = 0;
  o.progress = [&](const SweepProgress&) { ++calls; };
  SweepOptions bad = o;
  bad.experiments = {"gpi-pd"};
  std::string m = error_of([&] { run_sweep(bad); });
  EXPECT_TRUE(contains(m, "gpi-pd")) << m;
  EXPECT_TRUE(contains(m, "gpi-pid")) << m;
  bad = o;
  bad.experiments = {};
  EXPECT_FALSE(error_of([&] { run_sweep(bad); }).empty());
  bad = o;
  bad.experiments = {"gpi-pid", "gpi-pid"};
  EXPECT_FALSE(error_of([&] { run_sweep(bad); }).empty());
  bad = o;
  bad.variants.push_back(bad.variants[0]);  // the same name twice
  EXPECT_TRUE(contains(error_of([&] { run_sweep(bad); }), "load.mass=35"));
  bad = o;
  bad.variants[0].name = "nominal";
  EXPECT_TRUE(contains(error_of([&] { run_sweep(bad); }), "nominal"));
  bad = o;
  bad.variants.push_back({"light", {parse_override("load.mass=-1", "t")}, "", 1.5});
  m = error_of([&] { run_sweep(bad); });
  EXPECT_TRUE(contains(m, "light")) << m;
  EXPECT_TRUE(contains(m, "load.mass")) << m;
  EXPECT_EQ(calls, 0);
}

// One small real sweep: gpi-pid on a base rig allowed one sub-step (the nominal rig needs
// one): the nominal rig alone on one thread; then, on two threads, the nominal rig, 35 kg,
// a repeat of the nominal value (dropped) and a regulator whose air dynamics need more
// sub-steps (its run throws at once). Three experiment runs in all; one test (ctest runs
// each test in its own process), the checks are the functions below.
namespace {
void check_NominalRepeatDroppedAndVariantsInOrder(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  const SweepResult& r = *parallel_;
  ASSERT_EQ(r.variants.size(), 3u);
  EXPECT_EQ(r.variants[0].variant.name, "nominal");
  EXPECT_EQ(r.variants[1].variant.name, "load.mass=35");
  EXPECT_EQ(r.variants[1].rig.load.mass, 35.0);
  ASSERT_EQ(r.variants[1].values.size(), 1u);
  EXPECT_EQ(r.variants[1].values[0], 35.0);
  EXPECT_EQ(r.variants[2].variant.name, "regulator.sonic_conductance=1e-05");
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_TRUE(contains(r.notes[0], "load.mass=20")) << r.notes[0];
  EXPECT_EQ(r.runs.size(), 3u);
  EXPECT_EQ(r.jobs, 2u);
}

void check_ParallelEqualsSerialBitForBit(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  // the nominal run, alone on one thread and beside the 35 kg run on another
  const SweepResult &a = *serial_, &b = *parallel_;
  ASSERT_EQ(a.runs.size(), 1u);
  EXPECT_EQ(a.jobs, 1u);
  for (std::size_t k = 0; k < a.runs.size(); ++k) {
    const SweepRun &x = a.runs[k], &y = b.runs[k];
    EXPECT_EQ(x.experiment, y.experiment);
    EXPECT_EQ(x.variant, y.variant);
    EXPECT_EQ(x.ok, y.ok);
    EXPECT_EQ(x.error, y.error);
    ASSERT_EQ(x.runs.size(), y.runs.size());
    for (std::size_t i = 0; i < x.runs.size(); ++i) {
      const SweepRunErrors &p = x.runs[i], &q = y.runs[i];
      EXPECT_EQ(p.reference, q.reference);
      EXPECT_EQ(p.kind, q.kind);
      EXPECT_TRUE(same_bits(p.errors.max_error_mm, q.errors.max_error_mm));
      EXPECT_TRUE(same_bits(p.errors.mae_mm, q.errors.mae_mm));
      EXPECT_TRUE(same_bits(p.errors.rms_error_mm, q.errors.rms_error_mm)) << p.kind;
      EXPECT_TRUE(same_bits(p.min_command_mpa, q.min_command_mpa));
      EXPECT_TRUE(same_bits(p.max_command_mpa, q.max_command_mpa));
      EXPECT_EQ(p.saturated, q.saturated);
    }
  }
}

// The compensated and adaptive rows carry their rig's gain-trial choice (a scale 2^(k/3),
// k = -4..2, and whether the feedforward is shaped), in the JSON too; the other kinds do not.
void check_GainTrialChoiceInTheRows(const SweepResult* serial_, const SweepResult* parallel_,
                                    const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)progress_;
  const SweepResult& r = *parallel_;
  const nlohmann::json j = r.to_json();
  std::size_t compensated = 0, chosen_other = 0;
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    if (!r.runs[i].ok) continue;
    for (std::size_t t = 0; t < r.runs[i].runs.size(); ++t) {
      const SweepRunErrors& x = r.runs[i].runs[t];
      const nlohmann::json& row = j["runs"][i]["tracking"][t];
      if (x.kind == "compensated" || x.kind == "adaptive") {
        compensated += x.kind == "compensated";
        chosen_other += x.gain_scale != 1.0 || x.shaped;
        const double k = 3.0 * std::log2(x.gain_scale);
        EXPECT_NEAR(k, std::round(k), 1e-9) << x.gain_scale;
        EXPECT_GE(std::round(k), -4.0);
        EXPECT_LE(std::round(k), 2.0);
        EXPECT_EQ(row["gain_scale"].get<double>(), x.gain_scale);
        EXPECT_EQ(row["shaped"].get<bool>(), x.shaped);
      } else {
        EXPECT_FALSE(row.contains("gain_scale")) << x.kind;
      }
    }
  }
  EXPECT_GT(compensated, 0u);
  EXPECT_GT(chosen_other, 0u);  // the nominal gpi-pid rig chooses 1.26 with the shaper (docs/control.md)
}

void check_HeavierLoadChangesTheErrors(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  const SweepResult& r = *parallel_;
  ASSERT_TRUE(r.run(0, 0).ok) << r.run(0, 0).error;
  ASSERT_TRUE(r.run(0, 1).ok) << r.run(0, 1).error;
  ASSERT_FALSE(r.run(0, 0).runs.empty());
  ASSERT_EQ(r.run(0, 0).runs.size(), r.run(0, 1).runs.size());
  std::set<std::string> kinds;
  for (const auto& n : r.run(0, 0).runs) {
    kinds.insert(n.kind);
    const SweepRunErrors* h = r.find(0, 1, n.reference, n.kind);
    ASSERT_NE(h, nullptr) << n.kind;
    EXPECT_NE(h->errors.rms_error_mm, n.errors.rms_error_mm) << n.kind;
    EXPECT_GT(n.errors.rms_error_mm, 0.0);
  }
  EXPECT_TRUE(kinds.count("compensated"));
  EXPECT_TRUE(kinds.count("baseline"));
  // 35 kg needs more pressure for the same contraction: the straight-line inverse of the
  // baseline, fitted on the heavier rig, cannot hide it and tracks worse
  EXPECT_GT(r.find(0, 1, "sine", "baseline")->errors.rms_error_mm,
            r.find(0, 0, "sine", "baseline")->errors.rms_error_mm);
  EXPECT_GT(r.find(0, 1, "sine", "compensated")->max_command_mpa,
            r.find(0, 0, "sine", "compensated")->max_command_mpa);
}

void check_AFailingRunIsRecordedNotThrown(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  const SweepResult& r = *parallel_;
  const SweepRun& f = r.run(0, 2);
  EXPECT_FALSE(f.ok);
  EXPECT_TRUE(contains(f.error, "max_substeps")) << f.error;
  EXPECT_TRUE(f.runs.empty());
  EXPECT_EQ(r.failures(), 1u);
  EXPECT_EQ(r.find(0, 2, "sine", "compensated"), nullptr);
  bool listed = false;
  for (const auto& m : r.target_misses()) listed = listed || (contains(m, "failed") && contains(m, "sonic_conductance"));
  EXPECT_TRUE(listed);
  EXPECT_TRUE(contains(r.text(), "FAILED"));
  const auto j = r.to_json();
  EXPECT_EQ(j.at("failures").get<std::size_t>(), 1u);
  EXPECT_FALSE(j.at("runs").at(2).at("ok").get<bool>());
}

void check_ProgressOncePerRun(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  ASSERT_EQ(progress_.size(), 3u);
  std::set<std::string> variants;
  for (std::size_t i = 0; i < progress_.size(); ++i) {
    EXPECT_EQ(progress_[i].done, i + 1);
    EXPECT_EQ(progress_[i].total, 3u);
    EXPECT_EQ(progress_[i].experiment, "gpi-pid");
    variants.insert(progress_[i].variant);
  }
  EXPECT_EQ(variants.size(), 3u);
}

void check_CsvHasOneRowPerTrackingRunAndFailure(const SweepResult* serial_, const SweepResult* parallel_, const std::vector<SweepProgress>& progress_) {
  (void)serial_;
  (void)parallel_;
  (void)progress_;
  const SweepResult& r = *parallel_;
  const std::string csv = r.csv();
  std::vector<std::string> lines;
  for (std::size_t s = 0, e; s < csv.size(); s = e + 1) {
    e = csv.find('\n', s);
    ASSERT_NE(e, std::string::npos) << "the table must end with a newline";
    lines.push_back(csv.substr(s, e - s));
  }
  const auto header = csv_fields(lines.at(0));
  ASSERT_EQ(header.size(), 22u);
  EXPECT_EQ(header[0], "experiment");
  EXPECT_EQ(header[21], "not_below_baseline");
  EXPECT_EQ(header[17], "guard_cuts");
  EXPECT_EQ(header[18], "guard_final_scale");
  EXPECT_EQ(header[19], "command_limit_mpa");
  EXPECT_EQ(header[20], "control_period_s");
  EXPECT_EQ(header[7], "rms_mm");
  EXPECT_EQ(header[8], "rms_vs_nominal");
  EXPECT_EQ(header[13], "reference_scale");
  const std::size_t tracking = r.run(0, 0).runs.size() + r.run(0, 1).runs.size();
  ASSERT_EQ(lines.size(), 1 + tracking + 1);
  std::size_t failed = 0;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto f = csv_fields(lines[i]);
    ASSERT_EQ(f.size(), header.size()) << lines[i];
    EXPECT_EQ(std::stod(f[20]), r.control_period) << lines[i];  // failed rows too
    if (f[14] == "failed") {
      ++failed;
      EXPECT_TRUE(contains(f[15], "max_substeps")) << f[15];
      continue;
    }
    EXPECT_EQ(f[14], "ok");
    EXPECT_EQ(std::stod(f[19]), 0.6);  // the nominal muscle's rating (the regulator's range is above it)
    const SweepRunErrors* x = r.find(0, f[1] == "nominal" ? 0 : 1, f[3], f[4]);
    ASSERT_NE(x, nullptr) << lines[i];
    EXPECT_EQ(std::stoul(f[17]), x->guard_cuts);
    EXPECT_EQ(std::stod(f[18]), x->guard_final_scale);
    EXPECT_EQ(std::stod(f[7]), x->errors.rms_error_mm);  // %.17g reads back exactly
    EXPECT_EQ(std::stod(f[13]), x->reference_scale);
    // the 35 kg load cannot lift the paper's 95 mm top at 0.57 MPa: its reference is scaled
    if (f[1] == "nominal") { EXPECT_EQ(f[13], "1"); }
    if (f[1] == "load.mass=35") { EXPECT_LT(x->reference_scale, 0.95) << lines[i]; }
    if (f[1] == "nominal") {
      EXPECT_EQ(f[8], "1");
    }
  }
  EXPECT_EQ(failed, 1u);
}
}  // namespace

TEST(SweepRun, SmallSweepSerialAndParallel) {
  SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.base.simulation.max_substeps = 1;
  o.learning_periods = 0;  // the learning variant's periods would triple the time of a run
  o.jobs = 1;
  const SweepResult serial = run_sweep(o);  // the nominal rig alone, on this thread
  o.variants = parse_vary("load.mass=35,20");
  for (auto& v : parse_vary("regulator.sonic_conductance=1e-5")) o.variants.push_back(v);
  std::vector<SweepProgress> progress;
  o.jobs = 2;
  o.progress = [&](const SweepProgress& p) { progress.push_back(p); };
  const SweepResult parallel = run_sweep(o);
  {
    SCOPED_TRACE("NominalRepeatDroppedAndVariantsInOrder");
    check_NominalRepeatDroppedAndVariantsInOrder(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("ParallelEqualsSerialBitForBit");
    check_ParallelEqualsSerialBitForBit(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("HeavierLoadChangesTheErrors");
    check_HeavierLoadChangesTheErrors(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("GainTrialChoiceInTheRows");
    check_GainTrialChoiceInTheRows(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("AFailingRunIsRecordedNotThrown");
    check_AFailingRunIsRecordedNotThrown(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("ProgressOncePerRun");
    check_ProgressOncePerRun(&serial, &parallel, progress);
  }
  {
    SCOPED_TRACE("CsvHasOneRowPerTrackingRunAndFailure");
    check_CsvHasOneRowPerTrackingRunAndFailure(&serial, &parallel, progress);
  }
}

// The sweep checks each run's commands against that run's limit (the rig's muscle.max_pressure,
// and regulator.max_command for a regulator experiment), not a fixed 0.6 MPa, and writes it.
TEST(SweepRun, CommandsAreCheckedAgainstEachRigsLimit) {
  SweepOptions o;
  o.experiments = {"gpi-pid", "mpi-pwm"};
  o.variants = parse_vary("muscle.max_pressure=50000");
  for (auto& v : parse_vary("regulator.max_command=50000")) o.variants.push_back(v);
  o.runner = fake_experiment;  // commands up to 0.1 MPa
  o.jobs = 1;
  o.control_period = 5e-4;  // recorded in every row, the text and the page
  const SweepResult r = run_sweep(o);
  ASSERT_EQ(r.variants.size(), 3u);
  EXPECT_EQ(r.run(0, 0).command_limit_mpa, 0.6);
  EXPECT_EQ(r.run(0, 1).command_limit_mpa, 0.05);
  EXPECT_EQ(r.run(1, 1).command_limit_mpa, 0.05);
  EXPECT_EQ(r.run(0, 2).command_limit_mpa, 0.05);  // the regulator's range
  EXPECT_EQ(r.run(1, 2).command_limit_mpa, 0.6);   // the valves have none
  std::size_t over = 0;
  for (const auto& m : r.target_misses())
    if (contains(m, "leaves 0..0.05 MPa")) {
      ++over;
      EXPECT_FALSE(contains(m, "mpi-pwm regulator.max_command")) << m;
    }
  EXPECT_EQ(over, 3u * 10u);  // 3 runs x 10 tracking runs, each up to 0.1 MPa
  // the CSV's last columns: the limit, the control period (then not_below_baseline)
  const std::string csv = r.csv();
  EXPECT_TRUE(contains(csv.substr(0, csv.find('\n')), ",command_limit_mpa,control_period_s,not_below_baseline"));
  EXPECT_TRUE(contains(csv, ",0.050000000000000003,0.00050000000000000001,"));
  EXPECT_FALSE(contains(csv, ",0.001,"));
  EXPECT_TRUE(contains(r.text(), ", control period 0.5 ms,")) << r.text();
  EXPECT_TRUE(contains(report::sweep_report_html(r, "cmd"), "at a control period of 0.5 ms"));
  EXPECT_EQ(r.to_json()["runs"][1]["command_limit_mpa"].get<double>(), 0.05);
}

// target_misses on a sweep built by hand (mutation testing, 2026-12-01): a variant's compensated
// RMS error above rms_ratio_limit (1.5 by default) times the nominal rig's is a miss, at 1.4x none;
// a compensated run whose RMS error equals its baseline's is not below it (as
// ExperimentResult::not_below_baseline: equal is not below), one just below is fine; a pressure
// command below 0 MPa by any amount is a miss.
TEST(SweepResult, TargetMissesAtTheRatioLimitAndAtTheBaseline) {
  const auto sweep = [](double variant_rms, double variant_baseline, double least_command = 0.0) {
    SweepResult r;
    r.experiments = {"gpi-pid"};
    r.variants.resize(2);
    r.variants[0].variant.name = "nominal";
    r.variants[1].variant.name = "load.mass=35";
    for (std::size_t v = 0; v < 2; ++v) {
      SweepRun run;
      run.experiment = "gpi-pid";
      run.variant = v;
      run.ok = true;
      for (const auto& [kind, rms] : {std::pair<const char*, double>{"compensated", v ? variant_rms : 1.0},
                                      {"baseline", v ? variant_baseline : 10.0}}) {
        SweepRunErrors e;
        e.reference = "sine";
        e.kind = kind;
        e.errors.rms_error_mm = rms;
        e.min_command_mpa = v ? least_command : 0.0;
        e.max_command_mpa = 0.5;  // within the 0.6 MPa limit
        run.runs.push_back(e);
      }
      r.runs.push_back(run);
    }
    return r.target_misses();
  };
  EXPECT_TRUE(sweep(1.4, 10.0).empty());
  const auto over = sweep(1.6, 10.0);
  ASSERT_EQ(over.size(), 1u);
  EXPECT_EQ(over[0], "gpi-pid load.mass=35 sine compensated: RMS 1.600 mm = 1.60x nominal 1.000 mm (target <= 1.5x)");
  const auto equal = sweep(1.4, 1.4);
  ASSERT_EQ(equal.size(), 1u);
  EXPECT_EQ(equal[0], "gpi-pid load.mass=35 sine compensated: RMS 1.400 mm not below the baseline's 1.400 mm");
  EXPECT_TRUE(sweep(1.4, 1.41).empty());
  // a pressure command below 0 MPa, however little, leaves the actuator's range
  const auto negative = sweep(1.4, 10.0, -0.005);
  ASSERT_EQ(negative.size(), 2u);  // the compensated and the baseline run
  EXPECT_EQ(negative[0], "gpi-pid load.mass=35 sine compensated: pressure command -0.0050..0.5000 MPa leaves 0..0.6 MPa");
}
