// Round trips of the one serialization layer (hysteron/io/results.hpp): every result
// type is written to JSON text, parsed back, read with from_json and compared field by
// field with what was written.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

constexpr double nan_v = std::numeric_limits<double>::quiet_NaN();
constexpr double inf_v = std::numeric_limits<double>::infinity();

// to_json -> text -> parse -> from_json.
template <class T>
T round_trip(const T& value) {
  const std::string text = io::to_json(value).dump(2);
  return io::from_json<T>(nlohmann::json::parse(text), "test");
}

// Equal, with NaN == NaN (a NaN is written as null and read back as NaN).
void expect_same(double a, double b, const char* what) {
  if (std::isnan(a)) {
    EXPECT_TRUE(std::isnan(b)) << what << ": " << b;
  } else {
    EXPECT_EQ(a, b) << what;  // exact: doubles are written with round-trip precision
  }
}

void expect_same(const FitMetrics& a, const FitMetrics& b) {
  expect_same(a.rms, b.rms, "rms");
  expect_same(a.max, b.max, "max");
  expect_same(a.mae, b.mae, "mae");
  expect_same(a.rms_percent_span, b.rms_percent_span, "rms_percent_span");
  expect_same(a.r2, b.r2, "r2");
  EXPECT_EQ(a.n, b.n);
}

void expect_same(const ModelParams& a, const ModelParams& b) {
  EXPECT_EQ(io::model_to_json(a), io::model_to_json(b));
}

void expect_same(const FitParameter& a, const FitParameter& b) {
  EXPECT_EQ(a.name, b.name);
  expect_same(a.value, b.value, "value");
  expect_same(a.std_error, b.std_error, "std_error");
  EXPECT_EQ(a.held, b.held);
  EXPECT_EQ(a.at_bound, b.at_bound);
}

void expect_same(const InverseCheck& a, const InverseCheck& b) {
  EXPECT_EQ(a.max_slope, b.max_slope);
  expect_same(a.max_jump, b.max_jump, "max_jump");
  expect_same(a.max_input_step, b.max_input_step, "max_input_step");
  EXPECT_EQ(a.increasing, b.increasing);
  EXPECT_EQ(a.no_inverse, b.no_inverse);
}

void expect_same(const FitCandidate& a, const FitCandidate& b) {
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.message, b.message);
  expect_same(a.train, b.train);
  expect_same(a.holdout, b.holdout);
  expect_same(a.holdout_score, b.holdout_score, "holdout_score");
  expect_same(a.time_s, b.time_s, "time_s");
  EXPECT_EQ(a.chosen, b.chosen);
  expect_same(a.model, b.model);
}

void expect_same(const FitReport& a, const FitReport& b) {
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.message, b.message);
  EXPECT_EQ(a.model_kind, b.model_kind);
  expect_same(a.initial_cost, b.initial_cost, "initial_cost");
  expect_same(a.final_cost, b.final_cost, "final_cost");
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.total_iterations, b.total_iterations);
  EXPECT_EQ(a.num_starts, b.num_starts);
  expect_same(a.time_s, b.time_s, "time_s");
  expect_same(a.model, b.model);
  ASSERT_EQ(a.parameters.size(), b.parameters.size());
  for (std::size_t i = 0; i < a.parameters.size(); ++i) expect_same(a.parameters[i], b.parameters[i]);
  EXPECT_EQ(a.covariance_note, b.covariance_note);
  expect_same(a.train, b.train);
  expect_same(a.reference, b.reference);
  expect_same(a.inverse, b.inverse);
  EXPECT_EQ(a.warnings, b.warnings);
  ASSERT_EQ(a.fault_runs.size(), b.fault_runs.size());
  for (std::size_t i = 0; i < a.fault_runs.size(); ++i) {
    EXPECT_EQ(a.fault_runs[i].rows.begin, b.fault_runs[i].rows.begin);
    EXPECT_EQ(a.fault_runs[i].rows.end, b.fault_runs[i].rows.end);
    EXPECT_EQ(a.fault_runs[i].input, b.fault_runs[i].input);
  }
  ASSERT_EQ(a.fault_free_train.has_value(), b.fault_free_train.has_value());
  if (a.fault_free_train) {
    EXPECT_EQ(a.fault_free_train->begin, b.fault_free_train->begin);
    EXPECT_EQ(a.fault_free_train->end, b.fault_free_train->end);
  }
  ASSERT_EQ(a.candidates.size(), b.candidates.size());
  for (std::size_t i = 0; i < a.candidates.size(); ++i) expect_same(a.candidates[i], b.candidates[i]);
}

FitMetrics metrics(double rms, std::size_t n) {
  FitMetrics m;
  m.rms = rms;
  m.max = 3.25 * rms;
  m.mae = 0.7 * rms + 1e-17;
  m.rms_percent_span = 100.0 * rms / 7.0;
  m.r2 = 1.0 - rms / 3.0;
  m.n = n;
  return m;
}

GpiParams test_gpi() {
  GpiParams g;
  g.envelope = Envelope::tanh(1.2, 0.8, 0.0, 0.1);
  g.units = {0.1, 0.5, 2.0, -3.0};  // a decreasing model in raw units
  g.q = 0.5;
  g.n = 10;
  g.rho = 0.3;
  g.tau = 1.5;
  g.alpha = 0.05;
  return g;
}

PiParams test_pi() {
  PiParams p;
  p.q = 0.7;
  p.r = {0.1, 0.2, 0.30000000000000004};
  p.p = {0.25, 0.125, 1.0 / 3.0};
  return p;
}

FitReport test_report() {
  FitReport r;
  r.status = FitStatus::poor_fit;
  r.message = "worse than the reference PI: \"rms\" 1.2 > 1.05 x 1.1";
  r.model_kind = FitModel::pi;
  r.initial_cost = 123.456789012345678;
  r.final_cost = 0.1 + 0.2;
  r.iterations = 17;
  r.total_iterations = 40;
  r.num_starts = 3;
  r.time_s = 0.0123;
  r.model = test_pi();
  r.parameters = {{"q", 0.7, 0.01, false, false}, {"p1", 0.25, nan_v, false, true}, {"p2", 0.125, 0.0, true, false}};
  r.covariance_note = "singular J^T J";
  r.train = metrics(0.031, 1200);
  r.reference = metrics(0.029, 1200);
  r.inverse = {inf_v, 0.062, 0.004, false, "its least slope over its input limits is 0"};
  r.warnings = {"q + p1 on its lower bound", "tau at bound"};
  r.fault_runs = {{{60, 130}, false}, {{1500, 1600}, true}};
  r.fault_free_train = IndexRange{130, 1500};
  FitCandidate c1;
  c1.kind = FitModel::gpi;
  c1.status = FitStatus::converged;
  c1.message = "ok";
  c1.train = metrics(0.02, 960);
  c1.holdout = metrics(0.05, 240);
  c1.holdout_score = 1.25;
  c1.time_s = 0.5;
  c1.chosen = true;
  c1.model = test_gpi();
  FitCandidate c2;
  c2.kind = FitModel::mpi_deadzone;
  c2.status = FitStatus::failed;  // no model: written as null, read back as the default
  c2.message = "cost became non-finite";
  c2.train = metrics(nan_v, 960);
  c2.holdout = metrics(nan_v, 240);
  c2.time_s = 0.25;
  r.candidates = {c1, c2};
  return r;
}

}  // namespace

TEST(Results, MetricsParameterInverseRoundTrip) {
  expect_same(round_trip(metrics(0.1234567890123456789, 42)), metrics(0.1234567890123456789, 42));
  FitMetrics with_nan = metrics(0.5, 7);
  with_nan.r2 = nan_v;
  expect_same(round_trip(with_nan), with_nan);
  const FitParameter p{"asc.c0", -1.5e-300, nan_v, false, true};
  expect_same(round_trip(p), p);
  const InverseCheck finite{12.5, 0.03, 0.004, true, {}};
  expect_same(round_trip(finite), finite);
  const InverseCheck not_invertible{inf_v, 1.0, 0.004, false, "Inverse refuses it"};
  expect_same(round_trip(not_invertible), not_invertible);  // null max_slope reads back as +inf
  // the JSON is plain: NaN and infinity are written as null
  EXPECT_TRUE(io::to_json(p)["std_error"].is_null());
  EXPECT_TRUE(io::to_json(not_invertible)["max_slope"].is_null());
}

TEST(Results, CandidateAndFitReportRoundTrip) {
  const FitReport r = test_report();
  for (const auto& c : r.candidates) expect_same(round_trip(c), c);
  const FitReport back = round_trip(r);
  expect_same(back, r);
  // names, not numbers, for the enums
  const nlohmann::json j = io::to_json(r);
  EXPECT_EQ(j["status"], "poor_fit");
  EXPECT_EQ(j["model_kind"], "pi");
  EXPECT_EQ(j["candidates"][1]["kind"], "mpi-deadzone");
  EXPECT_TRUE(j["candidates"][1]["model"].is_null());
  EXPECT_EQ(j["fault_free_train"], nlohmann::json::array({130, 1500}));
  EXPECT_EQ(j["fault_runs"], nlohmann::json::parse(R"([{"rows": [60, 130], "column": "output"},
                                                         {"rows": [1500, 1600], "column": "input"}])"));
  FitReport none = r;  // none: null, read back as none
  none.fault_free_train.reset();
  EXPECT_TRUE(io::to_json(none)["fault_free_train"].is_null());
  expect_same(round_trip(none), none);
  for (const char* bad : {"[1500, 130]", "[130, null]", "[7, 7]"}) {  // a range no fit writes: refused, named
    nlohmann::json jb = j;
    jb["fault_free_train"] = nlohmann::json::parse(bad);
    nlohmann::json jr = j;
    jr["fault_runs"][1]["rows"] = nlohmann::json::parse(bad);
    for (const auto& [doc, key] : {std::pair{jb, "r.json.fault_free_train"}, std::pair{jr, "r.json.fault_runs[1]"}}) {
      FitReport got;
      try {
        io::from_json(doc, got, "r.json");
        ADD_FAILURE() << bad << " was read";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      }
    }
  }
  nlohmann::json jc = j;  // a column other than input and output
  jc["fault_runs"][0]["column"] = "pressure";
  FitReport got;
  EXPECT_THROW(io::from_json(jc, got, "r.json"), Error);
  // every status name reads back
  for (FitStatus s : {FitStatus::not_run, FitStatus::converged, FitStatus::no_convergence, FitStatus::failed,
                      FitStatus::poor_fit, FitStatus::invalid_input})
    EXPECT_EQ(io::fit_status_from_name(fit_status_name(s), "test"), s);
}

TEST(Results, FitDocumentRoundTrip) {
  io::FitDocument d;
  d.fit = test_report();
  d.data.input_file = "rig.csv";
  d.data.input_column = "pressure_kpa";
  d.data.output_file = "rig.csv";
  d.data.output_column = "force";
  d.data.time_column = "t_ms";
  d.data.time_unit = "ms";
  d.data.input_label = "Pressure";
  d.data.input_unit = "kPa";
  d.data.output_label = "Force";
  d.data.output_unit = "N";
  d.data.initial_state = InitialState::relaxed;
  d.data.train = {10, 1200};
  d.data.censored = false;
  d.validation = {{"", {1200, 1800}, metrics(0.04, 600), 0, 0, {}},
                  {"other.csv", {0, 900}, metrics(0.05, 900), 37, 0, {-0.98, 12.5, -7.5, 0.99, 420.0, 13.1, 380.0}}};
  d.candidate_validation = {{metrics(0.041, 600), metrics(0.051, 900)}, {metrics(nan_v, 600), metrics(nan_v, 900)}};
  d.model_written = true;
  d.model_file = "model.json";
  const io::FitDocument back = round_trip(d);
  expect_same(back.fit, d.fit);
  EXPECT_EQ(back.data.input_file, d.data.input_file);
  EXPECT_EQ(back.data.input_column, d.data.input_column);
  EXPECT_EQ(back.data.output_file, d.data.output_file);
  EXPECT_EQ(back.data.output_column, d.data.output_column);
  EXPECT_EQ(back.data.time_column, d.data.time_column);
  EXPECT_EQ(back.data.time_unit, "ms");
  EXPECT_EQ(back.data.input_label, d.data.input_label);
  EXPECT_EQ(back.data.input_unit, d.data.input_unit);
  EXPECT_EQ(back.data.output_label, d.data.output_label);
  EXPECT_EQ(back.data.output_unit, d.data.output_unit);
  EXPECT_EQ(back.data.initial_state, d.data.initial_state);
  EXPECT_EQ(back.data.train.begin, d.data.train.begin);
  EXPECT_EQ(back.data.train.end, d.data.train.end);
  EXPECT_FALSE(back.data.censored);
  ASSERT_EQ(back.validation.size(), d.validation.size());
  for (std::size_t i = 0; i < d.validation.size(); ++i) {
    EXPECT_EQ(back.validation[i].file, d.validation[i].file);
    EXPECT_EQ(back.validation[i].censored, d.validation[i].censored);
    EXPECT_EQ(back.validation[i].range.begin, d.validation[i].range.begin);
    EXPECT_EQ(back.validation[i].range.end, d.validation[i].range.end);
    expect_same(back.validation[i].metrics, d.validation[i].metrics);
    const auto map_fields = [](const OutputMap& m) {
      return std::vector<double>{m.gain, m.offset, m.r2, m.r2_mapped, m.rms, m.rms_mapped, m.span};
    };
    if (i == 0) {  // no map: NaN, written as null, read back as NaN
      for (double v : map_fields(back.validation[i].output_map)) EXPECT_TRUE(std::isnan(v));
    } else {
      EXPECT_EQ(map_fields(back.validation[i].output_map), map_fields(d.validation[i].output_map));
    }
  }
  ASSERT_EQ(back.candidate_validation.size(), d.candidate_validation.size());
  for (std::size_t i = 0; i < d.candidate_validation.size(); ++i) {
    ASSERT_EQ(back.candidate_validation[i].size(), d.candidate_validation[i].size());
    for (std::size_t k = 0; k < d.candidate_validation[i].size(); ++k)
      expect_same(back.candidate_validation[i][k], d.candidate_validation[i][k]);
  }
  EXPECT_EQ(back.model_written, d.model_written);
  EXPECT_EQ(back.model_file, d.model_file);
  // an open range (end = to the end) survives as null
  io::FitDocument open = d;
  open.data.train = {5, IndexRange::npos};
  EXPECT_EQ(round_trip(open).data.train.end, IndexRange::npos);
  // documents of older versions have no "censored": scored as censored (the default); a
  // non-boolean is refused, naming the key
  nlohmann::json old_doc = io::to_json(d);
  old_doc["data"].erase("censored");
  old_doc["validate_files"][1].erase("censored_samples");
  const io::FitDocument from_old = io::from_json<io::FitDocument>(old_doc, "old.json");
  EXPECT_TRUE(from_old.data.censored);
  EXPECT_EQ(from_old.validation.at(1).censored, 0u);
  old_doc["data"]["censored"] = "yes";
  try {
    (void)io::from_json<io::FitDocument>(old_doc, "old.json");
    FAIL() << "censored = \"yes\" accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("censored"), std::string::npos) << e.what();
  }
  // the document says what it is; another schema is refused, naming where
  const nlohmann::json j = io::to_json(d);
  EXPECT_EQ(j["format"], "hysteron-fit-report");
  EXPECT_EQ(j["validate"]["n"], 600u);
  nlohmann::json bad = j;
  bad["schema"] = 9;
  try {
    (void)io::from_json<io::FitDocument>(bad, "fit.json");
    FAIL() << "schema 9 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fit.json: unsupported fit report schema 9"), std::string::npos) << e.what();
  }
}

TEST(Results, EvaluationDocumentRoundTrip) {
  io::EvaluationDocument d;
  d.model_file = "gpi.json";
  d.model = test_gpi();
  d.data.input_file = d.data.output_file = "today.csv";
  d.data.input_column = "p";
  d.data.output_column = "y";
  d.data.train = {100, 900};
  d.result = {"today.csv", {100, 900}, metrics(0.07, 800), 0, 0, {1.0, 0.5, 0.9, 0.95, 2.0, 1.5, 30.0}};
  const io::EvaluationDocument back = round_trip(d);
  EXPECT_EQ(back.model_file, d.model_file);
  expect_same(back.model, d.model);
  EXPECT_EQ(back.data.input_file, d.data.input_file);
  EXPECT_EQ(back.data.input_column, d.data.input_column);
  EXPECT_EQ(back.data.output_column, d.data.output_column);
  EXPECT_EQ(back.data.train.begin, 100u);
  EXPECT_EQ(back.data.train.end, 900u);
  EXPECT_EQ(back.result.file, d.result.file);
  EXPECT_EQ(back.result.range.begin, 100u);
  EXPECT_EQ(back.result.range.end, 900u);
  expect_same(back.result.metrics, d.result.metrics);
  EXPECT_EQ(back.result.output_map.gain, 1.0);
  EXPECT_EQ(back.result.output_map.offset, 0.5);
  EXPECT_EQ(back.result.output_map.span, 30.0);
}

TEST(Results, ExperimentResultRoundTrip) {
  ExperimentResult r;
  r.name = "mpi-openloop";
  r.title = "test \"experiment\"";
  r.seed = 18446744073709551615ull;
  r.id_train_end = 5000;
  r.fit.model_kind = FitModel::mpi_asym;
  r.fit.status = FitStatus::no_convergence;
  r.fit.message = "iteration limit";
  r.fit.train = metrics(0.3, 5000);
  r.fit.time_s = 1.25;
  r.fit.model = test_pi();
  r.validation = metrics(0.5, 10000);
  r.best_fit.model_kind = FitModel::gpi;
  r.best_fit.status = FitStatus::converged;
  r.best_fit.model = test_gpi();
  r.best_validation = metrics(0.4, 15000);
  r.baseline_model = test_pi();
  r.lead_s = 0.057;
  r.model_id_top_mpa = 0.354;
  r.dynamics = {0.021, 0.056, 1.97e-4, 0.69, 152.5, 0.012, 13.02, 0.239, 0.1, 3.1e-5, 4.05, 0.7, 0.3, 0.3};
  r.wall_time_s = 12.5;
  r.published = {"paper, Results", {{"triangle", 1.29, nan_v, nan_v}, {"sine", 1.38, nan_v, nan_v}}};
  r.reach_min_mm = -0.0125;
  r.reach_max_mm = 84.75;
  r.reach_top_mm = 64.875;
  r.reach_top_pressure_mpa = 0.38;
  r.reach_pressure_max_mpa = 0.4;
  r.reference_ranges = {{"triangle", 0.0, 40.0, 0.0, 40.0, false, true},
                        {"sine", 5.0, 95.0, 5.0, 80.5, true, true},
                        {"step", 0.0, 99.0, 0.0, 99.0, false, false}};
  for (const char* variant : {"compensated", "faithful", "baseline"})
    for (const char* ref : {"triangle", "sine"}) {
      TrackingRun run;
      run.variant = variant;
      run.reference = ref;
      run.description = std::string(variant) + " on " + ref;
      run.errors = {1.5 + run.description.size(), 0.25, 0.5};
      run.saturated = run.description.size();
      r.runs.push_back(run);
    }
  const ExperimentResult back = round_trip(r);
  EXPECT_EQ(back.name, r.name);
  EXPECT_EQ(back.title, r.title);
  EXPECT_EQ(back.seed, r.seed);
  EXPECT_EQ(back.id_train_end, r.id_train_end);
  EXPECT_EQ(back.fit.model_kind, r.fit.model_kind);
  EXPECT_EQ(back.fit.status, r.fit.status);
  EXPECT_EQ(back.fit.message, r.fit.message);
  expect_same(back.fit.train, r.fit.train);
  EXPECT_EQ(back.fit.time_s, r.fit.time_s);
  expect_same(back.fit.model, r.fit.model);
  expect_same(back.validation, r.validation);
  EXPECT_EQ(back.best_fit.model_kind, r.best_fit.model_kind);
  EXPECT_EQ(back.best_fit.status, r.best_fit.status);
  expect_same(back.best_fit.model, r.best_fit.model);
  expect_same(back.best_validation, r.best_validation);
  expect_same(back.baseline_model, r.baseline_model);
  EXPECT_EQ(back.lead_s, r.lead_s);
  // every identified quantity the table prints (the mode and the relay's amplitude too)
  const auto fields = [](const RigDynamics& d) {
    return std::vector<double>{d.dead_time_s, d.lag_s, d.gain_m_per_mpa, d.rms_mm, d.relay_gain, d.relay_period_s,
                               d.position_relay_gain, d.position_relay_period_s, d.position_relay_amplitude_mpa,
                               d.position_relay_hysteresis_m, d.position_relay_level_mpa, d.relay_level_mpa,
                               d.relay_duty, d.mode_frequency_hz, d.mode_damping};
  };
  EXPECT_EQ(fields(back.dynamics), fields(r.dynamics));
  {  // a file from before the relays' levels were written: both ran at 0.3 MPa where they ran
    nlohmann::json j = io::to_json(r);
    j["dynamics"].erase("position_relay_level_mpa");
    j["dynamics"].erase("pressure_relay_level_mpa");
    j["dynamics"].erase("pressure_relay_duty");
    ExperimentResult old = io::from_json<ExperimentResult>(j, "old");
    EXPECT_EQ(old.dynamics.position_relay_level_mpa, 0.3);
    EXPECT_EQ(old.dynamics.relay_level_mpa, 0.3);
    EXPECT_EQ(old.dynamics.relay_duty, r.dynamics.relay_gain > 0.0 ? 0.5 : 0.0);
    j["dynamics"]["pressure_relay_gain_per_mpa"] = 0.0;  // a regulator rig: no pressure relay
    old = io::from_json<ExperimentResult>(j, "old");
    EXPECT_EQ(old.dynamics.relay_level_mpa, 0.0);
    // a capped rig's levels come back and the table names them
    ExperimentResult capped = r;
    capped.dynamics.position_relay_level_mpa = 0.15;
    capped.dynamics.relay_level_mpa = 0.151;
    capped.dynamics.relay_duty = 1.0;
    const ExperimentResult cb = round_trip(capped);
    EXPECT_EQ(cb.dynamics.relay_duty, 1.0);
    EXPECT_NE(cb.table().find("pressure relay (at 0.151 MPa) (duty +-1: the valves did not open at +-0.5)"),
              std::string::npos) << cb.table();
    EXPECT_EQ(cb.dynamics.position_relay_level_mpa, 0.15);
    EXPECT_EQ(cb.dynamics.relay_level_mpa, 0.151);
    EXPECT_NE(cb.table().find("position relay (at 0.150 +-0.1 MPa)"), std::string::npos) << cb.table();
    EXPECT_NE(cb.table().find("pressure relay (at 0.151 MPa)"), std::string::npos) << cb.table();
  }
  const std::string table = back.table();  // `hysteron report` prints the table from the file
  EXPECT_NE(table.find("position relay (+-0.1 MPa) K_u = 13 MPa/m, T_u = 239 ms, mode 4.05 Hz (damping 0.70)"),
            std::string::npos) << table;
  EXPECT_EQ(back.wall_time_s, r.wall_time_s);
  EXPECT_EQ(back.reach_min_mm, r.reach_min_mm);
  EXPECT_EQ(back.reach_max_mm, r.reach_max_mm);
  EXPECT_EQ(back.reach_top_mm, r.reach_top_mm);
  EXPECT_EQ(back.model_id_top_mpa, r.model_id_top_mpa);
  EXPECT_EQ(back.reach_top_pressure_mpa, r.reach_top_pressure_mpa);
  EXPECT_EQ(back.reach_pressure_max_mpa, r.reach_pressure_max_mpa);
  EXPECT_EQ(back.reference_ranges, r.reference_ranges);
  EXPECT_EQ(back.published.source, r.published.source);
  ASSERT_EQ(back.published.errors.size(), 2u);
  for (const auto& e : r.published.errors) {
    const PublishedErrors* b = back.published.find(e.reference);
    ASSERT_NE(b, nullptr) << e.reference;
    expect_same(b->max_error_mm, e.max_error_mm, "max_error_mm");
    expect_same(b->mae_mm, e.mae_mm, "mae_mm");
    expect_same(b->rms_error_mm, e.rms_error_mm, "rms_error_mm");
  }
  // runs are grouped by variant in the JSON: match them by (variant, reference)
  ASSERT_EQ(back.runs.size(), r.runs.size());
  for (const auto& run : r.runs) {
    bool found = false;
    for (const auto& b : back.runs) {
      if (b.variant != run.variant || b.reference != run.reference) continue;
      found = true;
      EXPECT_EQ(b.description, run.description);
      EXPECT_EQ(b.errors.max_error_mm, run.errors.max_error_mm);
      EXPECT_EQ(b.errors.mae_mm, run.errors.mae_mm);
      EXPECT_EQ(b.errors.rms_error_mm, run.errors.rms_error_mm);
      EXPECT_EQ(b.saturated, run.saturated);
    }
    EXPECT_TRUE(found) << run.variant << " " << run.reference;
  }
  // one reference: the published figures and the runs are flat objects (the CLI's --json shape)
  ExperimentResult one = r;
  one.published = {"Table 5", {{"", 2.659, 0.7358, 0.8701}}};
  one.runs.resize(1);
  const nlohmann::json j = io::to_json(one);
  EXPECT_EQ(j["published"]["rms_error_mm"], 0.8701);
  EXPECT_EQ(j["compensated"]["reference"], "triangle");
  const ExperimentResult one_back = round_trip(one);
  ASSERT_EQ(one_back.published.errors.size(), 1u);
  EXPECT_EQ(one_back.published.errors[0].mae_mm, 0.7358);
  ASSERT_EQ(one_back.runs.size(), 1u);
  EXPECT_EQ(one_back.runs[0].reference, "triangle");
  // no published figures: null
  ExperimentResult none = r;
  none.published = {};
  EXPECT_TRUE(io::to_json(none)["published"].is_null());
  EXPECT_TRUE(round_trip(none).published.empty());
  // the member function is the same writer
  EXPECT_EQ(r.to_json(), io::to_json(r));
}

// The control period comes back, the table and a file from before it say it: read from the
// runs' controllers (the sample time every loop ran at), else the 1 ms of then; a bad one is named.
TEST(Results, ExperimentControlPeriod) {
  ExperimentResult r;
  r.name = "gpi-pid";
  r.title = "t";
  r.seed = 3;
  r.control_period_s = 5e-4;
  for (const char* variant : {"compensated", "baseline"}) {
    TrackingRun run;
    run.variant = variant;
    run.reference = "sine";
    run.errors = {1.0, 0.25, 0.5};
    run.controller.sample_time = 5e-4;
    r.runs.push_back(run);
  }
  nlohmann::json j = io::to_json(r);
  EXPECT_EQ(j["control_period_s"], 5e-4);
  const ExperimentResult back = round_trip(r);
  EXPECT_EQ(back.control_period_s, 5e-4);
  EXPECT_NE(back.table().find("control period 0.5 ms, rig noise seed 3\n"), std::string::npos) << back.table();
  j.erase("control_period_s");
  EXPECT_EQ(io::from_json<ExperimentResult>(j, "old").control_period_s, 5e-4);
  for (const char* v : {"compensated", "baseline"}) j[v].erase("controller");
  EXPECT_EQ(io::from_json<ExperimentResult>(j, "older").control_period_s, 1e-3);
  for (const nlohmann::json& bad : {nlohmann::json(0.0), nlohmann::json(-1e-3), nlohmann::json(nullptr)}) {
    j["control_period_s"] = bad;
    try {
      (void)io::from_json<ExperimentResult>(j, "f.json");
      ADD_FAILURE() << "control_period_s " << bad.dump() << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("f.json: key \"control_period_s\""), std::string::npos) << e.what();
    }
  }
}

// A run's "controller": every field back as written (unbounded limits and an unsupervised
// learning's infinities as null), absent parts absent, and a bad value named with its path.
TEST(Results, LoopDesignRoundTripAndErrors) {
  const double inf = std::numeric_limits<double>::infinity();
  LoopDesign d;
  PidParams pid;
  pid.kp = 9.81;
  pid.ki = 82.0;
  pid.kd = 0.293;
  pid.sample_time = 2e-3;
  pid.derivative_filter = 0.008;
  pid.out_min = -inf;
  pid.out_max = 0.6;
  pid.anti_windup = AntiWindup::back_calculation;
  pid.tracking_time = 0.05;
  pid.setpoint_weight_p = 0.7;
  pid.setpoint_weight_d = 0.1;
  pid.guard = PidGuard{.period = 0.239, .amplitude = 1.8e-3, .count = 4.0, .memory = 6.0, .factor = 0.5,
                       .min_scale = 0.3};
  d.pid = pid;
  d.guard_final_scale = 0.25;
  d.guard_cuts = 2;
  PidParams pressure;
  pressure.kp = 47.6;
  pressure.ki = 1040.0;
  pressure.anti_windup = AntiWindup::none;
  d.pressure_pid = pressure;
  d.pressure_gain = 0.5;
  d.feedforward_lead = 76;
  d.sample_time = 2e-3;
  d.shaper = LoopDesign::Shaper{0.955, 0.045, 172, 8};
  d.kind = LoopDesign::Kind::cascade_pwm;
  d.feedforward.pressure_limits = {0.05, 0.55};
  d.feedforward.model_scale = 1.0;
  d.feedforward.lag_time_constant = 0.03;
  d.pwm = PwmParams{2.5, 0.01, 0.1, 0.9, 0.02};
  LoopDesign::Learning l;
  l.params = LearningParams{.period = 5000, .gain = 0.3, .lead = 38, .half_width = 2011, .lookahead = 76};
  l.params.hold_after_cuts = 3;
  l.params.max_gain = 0.5;
  l.contraction_bound = 0.696;
  l.final_gain = 0.075;
  l.gain_raises = 1;
  l.gain_cuts = 2;
  l.held = true;
  d.learning = l;
  const nlohmann::json j = io::to_json(d);
  EXPECT_TRUE(j["pid"]["out_min_mpa"].is_null());
  EXPECT_TRUE(j["learning"]["rise_tolerance"].is_null());
  EXPECT_EQ(j["pid"]["anti_windup"], "back_calculation");
  const LoopDesign b = io::from_json<LoopDesign>(j, "controller");
  ASSERT_TRUE(b.pid && b.pressure_pid && b.shaper && b.learning);
  const auto pid_fields = [](const PidParams& p) {
    return std::vector<double>{p.kp, p.ki, p.kd, p.sample_time, p.derivative_filter, p.out_min, p.out_max,
                               static_cast<double>(p.anti_windup), p.tracking_time, p.setpoint_weight_p,
                               p.setpoint_weight_d, p.guard.period, p.guard.amplitude, p.guard.count,
                               p.guard.memory, p.guard.factor, p.guard.min_scale};
  };
  EXPECT_EQ(pid_fields(*b.pid), pid_fields(pid));
  EXPECT_EQ(pid_fields(*b.pressure_pid), pid_fields(pressure));
  EXPECT_FALSE(j["pressure_pid"].contains("guard"));  // off: not written
  EXPECT_EQ(b.guard_final_scale, 0.25);
  EXPECT_EQ(b.guard_cuts, 2u);
  EXPECT_EQ(b.pressure_gain, 0.5);
  EXPECT_EQ(b.feedforward_lead, 76u);
  EXPECT_EQ(b.sample_time, 2e-3);
  EXPECT_EQ(b.shaper->a1, 0.955);
  EXPECT_EQ(b.shaper->a2, 0.045);
  EXPECT_EQ(b.shaper->delay, 172u);
  EXPECT_EQ(b.shaper->advance, 8u);
  EXPECT_EQ(j["loop"], "cascade_pwm");
  EXPECT_EQ(b.kind, LoopDesign::Kind::cascade_pwm);
  EXPECT_EQ(b.feedforward.pressure_limits.lo, 0.05);
  EXPECT_EQ(b.feedforward.pressure_limits.hi, 0.55);
  EXPECT_EQ(b.feedforward.model_scale, 1.0);
  EXPECT_EQ(b.feedforward.lag_time_constant, 0.03);
  EXPECT_EQ(b.feedforward_params().sample_time, 2e-3);  // the loop's sample time, kept once
  ASSERT_TRUE(b.pwm);
  EXPECT_EQ((std::vector<double>{b.pwm->gain, b.pwm->deadband, b.pwm->min_duty, b.pwm->max_duty, b.pwm->resolution}),
            (std::vector<double>{2.5, 0.01, 0.1, 0.9, 0.02}));
  const LearningParams& p = b.learning->params;
  EXPECT_EQ(p.period, 5000u);
  EXPECT_EQ(p.gain, 0.3);
  EXPECT_EQ(p.lead, 38u);
  EXPECT_EQ(p.half_width, 2011u);
  EXPECT_EQ(p.lookahead, 76u);
  EXPECT_EQ(p.max_correction, inf);
  EXPECT_EQ(p.rise_tolerance, inf);
  EXPECT_EQ(p.hold_after_cuts, 3u);
  EXPECT_EQ(p.max_gain, 0.5);
  EXPECT_EQ(b.learning->contraction_bound, 0.696);
  EXPECT_EQ(b.learning->final_gain, 0.075);
  EXPECT_EQ(b.learning->gain_raises, 1u);
  EXPECT_EQ(b.learning->gain_cuts, 2u);
  EXPECT_TRUE(b.learning->held);
  EXPECT_EQ(io::to_json(b), j);
  // a loop without a PID, pressure loop, shaper or learning: none of them
  const nlohmann::json bare = io::to_json(LoopDesign{});
  EXPECT_FALSE(bare.contains("pid") || bare.contains("pressure_pid") || bare.contains("pressure_gain") ||
               bare.contains("shaper") || bare.contains("learning") || bare.contains("guard_cuts"));
  // written before the limit-cycle guard: the PID has none
  nlohmann::json unguarded = j;
  unguarded["pid"].erase("guard");
  unguarded.erase("guard_cuts");
  unguarded.erase("guard_final_scale");
  const LoopDesign ub = io::from_json<LoopDesign>(unguarded, "controller");
  EXPECT_FALSE(ub.pid->guard.enabled());
  EXPECT_EQ(ub.guard_cuts, 0u);
  const LoopDesign bare_back = io::from_json<LoopDesign>(bare, "controller");
  EXPECT_FALSE(bare_back.pid || bare_back.pressure_pid || bare_back.shaper || bare_back.learning);
  EXPECT_EQ(bare["loop"], "feedforward_pid");
  EXPECT_FALSE(bare.contains("pwm"));
  // written before "loop": the structure from the pressure loops, the default feedforward and PWM
  for (const auto& [pressure_pid, gain, kind] :
       {std::tuple{true, 0.0, LoopDesign::Kind::cascade_pwm}, std::tuple{false, 0.5, LoopDesign::Kind::open_loop},
        std::tuple{false, 0.0, LoopDesign::Kind::feedforward_pid}}) {
    nlohmann::json old = j;
    for (const char* k : {"loop", "feedforward", "pwm", "pressure_pid", "pressure_gain"}) old.erase(k);
    if (pressure_pid) old["pressure_pid"] = j["pressure_pid"];
    if (gain > 0.0) old["pressure_gain"] = gain;
    const LoopDesign o = io::from_json<LoopDesign>(old, "controller");
    EXPECT_EQ(o.kind, kind);
    EXPECT_EQ(o.feedforward.pressure_limits, (Limits{0.0, 0.6}));  // the default of the time, not today's (unset)
    EXPECT_EQ(o.feedforward.model_scale, FeedforwardParams{}.model_scale);
    EXPECT_EQ(o.pwm.has_value(), pressure_pid);
  }
  // errors name the path
  nlohmann::json bad = j;
  bad["loop"] = "bang_bang";
  try {
    (void)io::from_json<LoopDesign>(bad, "result.json.compensated.sine.controller");
    FAIL() << "an unknown loop accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("result.json.compensated.sine.controller: key \"loop\": unknown loop "
                                         "\"bang_bang\""),
              std::string::npos)
        << e.what();
  }
  bad = j;
  bad.erase("pwm");
  EXPECT_THROW((void)io::from_json<LoopDesign>(bad, "controller"), Error);  // a cascade needs its PWM
  bad = j;
  bad["feedforward"].erase("model_scale_per_m");
  try {
    (void)io::from_json<LoopDesign>(bad, "controller");
    FAIL() << "a feedforward without its scale accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "controller.feedforward: missing key \"model_scale_per_m\"");
  }
  bad = j;
  bad["pid"]["anti_windup"] = "sometimes";
  try {
    (void)io::from_json<LoopDesign>(bad, "result.json.learning.sine.controller");
    FAIL() << "an unknown anti-windup accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("result.json.learning.sine.controller.pid: key \"anti_windup\""),
              std::string::npos)
        << e.what();
  }
  bad = j;
  bad["learning"]["half_width"] = -3;
  EXPECT_THROW((void)io::from_json<LoopDesign>(bad, "controller"), Error);
  bad = j;
  bad["shaper"].erase("delay_samples");
  try {
    (void)io::from_json<LoopDesign>(bad, "controller");
    FAIL() << "a shaper without its delay accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "controller.shaper: missing key \"delay_samples\"");
  }
}

// The zero-vibration shaper's weights (audit2 F4): a1 > 0, a2 >= 0, a1 + a2 = 1 within 1e-9. Weights that
// do not sum to 1 scaled the feedforward's preview, a negative one flipped an impulse, and every reader of a
// "controller" (C ABI, export --loop, controller_from) took them without a word.
TEST(Results, LoopDesignShaperWeightsAreChecked) {
  LoopDesign d;
  d.pid = PidParams{};
  d.shaper = LoopDesign::Shaper{0.955, 0.045, 172, 8};
  const nlohmann::json j = io::to_json(d);
  EXPECT_EQ(io::from_json<LoopDesign>(j, "controller").shaper->a2, 0.045);
  for (const auto& [a1, a2] : {std::pair{0.9, 0.2}, std::pair{1.2, -0.2}, std::pair{-0.5, 1.5}, std::pair{0.5, 0.4},
                               std::pair{0.0, 1.0}, std::pair{0.955, 0.045 + 1e-8}}) {
    nlohmann::json bad = j;
    bad["shaper"]["a1"] = a1;
    bad["shaper"]["a2"] = a2;
    const std::string said = test::error_of([&] { (void)io::from_json<LoopDesign>(bad, "result.json.compensated.controller"); });
    EXPECT_TRUE(test::has(said, fmt::format("result.json.compensated.controller.shaper: a1 = {}, a2 = {}", a1, a2)))
        << said;
    EXPECT_TRUE(test::has(said, "a1 > 0 and a2 >= 0 with a1 + a2 = 1")) << said;
  }
  // a2 = 0 (one impulse: the reference advanced) and a sum within rounding are accepted
  for (const auto& [a1, a2] : {std::pair{1.0, 0.0}, std::pair{0.955, 0.045 + 1e-12}}) {
    nlohmann::json ok = j;
    ok["shaper"]["a1"] = a1;
    ok["shaper"]["a2"] = a2;
    EXPECT_NO_THROW((void)io::from_json<LoopDesign>(ok, "controller")) << a1 << " " << a2;
  }
}

// The time column's unit: a document without it (before 2026-11-30) is in s; another is refused.
TEST(Results, DataTimeUnit) {
  io::DataDescription d;
  d.input_file = "rig.csv";
  d.time_column = "t";
  d.time_unit = "us";
  nlohmann::json j = io::to_json(d);
  EXPECT_EQ(j["time_unit"], "us");
  io::DataDescription back;
  io::from_json(j, back, "fit.json.data");
  EXPECT_EQ(back.time_unit, "us");
  j.erase("time_unit");
  io::from_json(j, back, "fit.json.data");
  EXPECT_EQ(back.time_unit, "s");
  j["time_unit"] = "min";
  try {
    io::from_json(j, back, "fit.json.data");
    FAIL() << "time unit min accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "fit.json.data.time_unit: unknown time unit \"min\" (expected s, ms or us)");
  }
  EXPECT_EQ(io::time_unit_seconds("s", "x"), 1.0);
  EXPECT_EQ(io::time_unit_seconds("ms", "x"), 1e-3);
  EXPECT_EQ(io::time_unit_seconds("us", "x"), 1e-6);
  // no time column: no unit written (the documents without a time axis are unchanged)
  d.time_column.clear();
  EXPECT_FALSE(io::to_json(d).contains("time_unit"));
}

TEST(Results, ErrorsNameWhereAndKey) {
  nlohmann::json j = io::to_json(test_report());
  j["train"].erase("rms");
  try {
    (void)io::from_json<FitReport>(j, "fit.json");
    FAIL() << "missing key accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "fit.json.train: missing key \"rms\"");
  }
  j = io::to_json(test_report());
  j["candidates"][0]["chosen"] = "yes";
  try {
    (void)io::from_json<FitReport>(j, "fit.json");
    FAIL() << "wrong type accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fit.json.candidates[0]: key \"chosen\": expected true or false"),
              std::string::npos)
        << e.what();
  }
  j = io::to_json(test_report());
  j["status"] = "great";
  EXPECT_THROW((void)io::from_json<FitReport>(j, "fit.json"), Error);
  EXPECT_THROW((void)io::parse_json("{\"a\": ", "x.json"), Error);
}
