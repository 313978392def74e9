// The model kind of the compensated variants (ExperimentOptions::model, issue 14 item 7):
// one kind pinned, auto over every kind (the chosen one has the least validation RMS of
// the reported candidates), errors for a kind that does not exist, the adaptive variant
// skipped with a note for a kind outside the PI family, the choice in the table, the JSON
// (round trip) and the written files, and the controllers' steps allocation-free for
// every kind.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <sstream>

#include "alloc_counter.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/sweep.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using namespace hysteron;

namespace {

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

const TrackingRun* find_run(const ExperimentResult& r, const std::string& variant) {
  for (const auto& run : r.runs)
    if (run.variant == variant) return &run;
  return nullptr;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

}  // namespace

// --model kp: the compensated variant inverts a kp, the result says so everywhere, and the
// adaptive variant (PI family only) is skipped with a note naming the reason.
TEST(ExperimentKinds, PinnedKpIsUsedAndReported) {
  ExperimentOptions o;
  o.name = "gpi-pid";
  o.learning_periods = 0;
  o.model = FitModel::kp;
  const ExperimentResult r = run_experiment(o);
  EXPECT_EQ(r.model_choice, FitModel::kp);
  EXPECT_EQ(r.best_fit.model_kind, FitModel::kp);
  EXPECT_TRUE(std::holds_alternative<KpParams>(r.best_fit.model));
  ASSERT_EQ(r.candidates.size(), 1u);
  EXPECT_EQ(r.candidates[0].kind, FitModel::kp);
  EXPECT_TRUE(r.candidates[0].ok);
  EXPECT_TRUE(r.candidates[0].chosen);
  EXPECT_DOUBLE_EQ(r.candidates[0].validation.rms, r.best_validation.rms);
  EXPECT_TRUE(contains(r.model_reason, "kp asked for")) << r.model_reason;
  ASSERT_NE(find_run(r, "compensated"), nullptr);
  ASSERT_NE(find_run(r, "faithful"), nullptr);
  ASSERT_NE(find_run(r, "baseline"), nullptr);
  EXPECT_LT(find_run(r, "compensated")->errors.rms_error_mm, find_run(r, "baseline")->errors.rms_error_mm);
  // the adaptive variant: skipped, with the reason
  EXPECT_EQ(find_run(r, "adaptive"), nullptr);
  bool noted = false;
  for (const auto& m : r.messages)
    noted = noted || (m.starts_with("adaptive (sine) not run") && contains(m, "PI-family") && contains(m, "kp"));
  EXPECT_TRUE(noted);
  // the table, the JSON and its round trip
  const std::string table = r.table();
  EXPECT_TRUE(contains(table, "model of the compensated variants: kp asked for")) << table;
  const nlohmann::json j = io::to_json(r);
  EXPECT_EQ(j["best_model"]["model"], "kp");
  EXPECT_EQ(j["best_model"]["choice"], "kp");
  ASSERT_EQ(j["best_model"]["candidates"].size(), 1u);
  EXPECT_EQ(j["best_model"]["candidates"][0]["model"], "kp");
  EXPECT_EQ(j["best_model"]["candidates"][0]["chosen"], true);
  const auto back = io::from_json<ExperimentResult>(j, "result.json");
  EXPECT_EQ(back.model_choice, FitModel::kp);
  EXPECT_EQ(back.model_reason, r.model_reason);
  ASSERT_EQ(back.candidates.size(), 1u);
  EXPECT_EQ(back.candidates[0].kind, FitModel::kp);
  EXPECT_EQ(back.candidates[0].chosen, true);
  EXPECT_EQ(back.candidates[0].status, r.candidates[0].status);
  EXPECT_DOUBLE_EQ(back.candidates[0].validation.rms, r.candidates[0].validation.rms);
  EXPECT_EQ(io::to_json(back)["best_model"], j["best_model"]);
  // the files: result.json says which, best_model.json is that kind
  hysteron::test::TempDir dir;
  r.write(dir.path().string());
  std::ifstream in(dir.path() / "result.json");
  const auto written = nlohmann::json::parse(in);
  EXPECT_EQ(written["best_model"]["model"], "kp");
  EXPECT_EQ(written["best_model"]["reason"], r.model_reason);
  EXPECT_TRUE(std::holds_alternative<KpParams>(io::read_model_file((dir.path() / "best_model.json").string())));
}

// auto without the adaptive variant: every kind is a candidate, each reported with its validation RMS and
// fit time, and the chosen one has the least RMS among those that could be used.
TEST(ExperimentKinds, AutoTriesEveryKindAndChoosesTheLeastValidationRms) {
  ExperimentOptions o;
  EXPECT_EQ(o.model, FitModel::automatic);
  o.name = "mpi-pwm";
  o.learning_periods = 0;
  o.adaptive = false;
  const ExperimentResult r = run_experiment(o);
  EXPECT_EQ(r.model_choice, FitModel::automatic);
  ASSERT_EQ(r.candidates.size(), std::size(fit_model_kinds));
  for (FitModel k : fit_model_kinds)
    EXPECT_EQ(std::count_if(r.candidates.begin(), r.candidates.end(), [k](const ModelCandidate& c) { return c.kind == k; }),
              1)
        << fit_model_name(k);
  EXPECT_EQ(r.candidates.front().kind, FitModel::mpi_deadzone);  // the paper's kind first
  const ModelCandidate* chosen = nullptr;
  double least = std::numeric_limits<double>::infinity();
  for (const auto& c : r.candidates) {
    if (c.chosen) {
      EXPECT_EQ(chosen, nullptr) << "two chosen";
      chosen = &c;
    }
    EXPECT_GE(c.fit_time_s, 0.0);
    if (!c.ok) {
      EXPECT_FALSE(c.message.empty()) << fit_model_name(c.kind);
      continue;
    }
    EXPECT_TRUE(std::isfinite(c.validation.rms)) << fit_model_name(c.kind);
    least = std::min(least, c.validation.rms);
  }
  ASSERT_NE(chosen, nullptr);
  EXPECT_TRUE(chosen->ok);
  EXPECT_EQ(chosen->validation.rms, least);
  EXPECT_EQ(r.best_fit.model_kind, chosen->kind);
  EXPECT_EQ(model_name(r.best_fit.model), fit_model_name(chosen->kind));
  EXPECT_DOUBLE_EQ(r.best_validation.rms, least);
  EXPECT_TRUE(contains(r.model_reason, fmt::format("auto: {} has the least RMS", fit_model_name(chosen->kind))))
      << r.model_reason;
  // every candidate in the table and the JSON
  const std::string table = r.table();
  for (FitModel k : fit_model_kinds) EXPECT_TRUE(contains(table, fmt::format(" {}", fit_model_name(k)))) << table;
  const nlohmann::json j = io::to_json(r);
  EXPECT_EQ(j["best_model"]["choice"], "auto");
  ASSERT_EQ(j["best_model"]["candidates"].size(), r.candidates.size());
  double least_json = std::numeric_limits<double>::infinity();
  std::string least_kind;
  for (const auto& c : j["best_model"]["candidates"])
    if (c["ok"].get<bool>() && c["validate_second_run"]["rms"].get<double>() < least_json)
      least_json = c["validate_second_run"]["rms"].get<double>(), least_kind = c["model"].get<std::string>();
  EXPECT_EQ(least_kind, j["best_model"]["model"].get<std::string>());
  // the cascade with its compensated variant on both references
  for (const auto& run : r.runs) EXPECT_TRUE(std::isfinite(run.errors.rms_error_mm)) << run.variant;
}

// auto with the adaptive variant (the default): only PI-family kinds are eligible, the chosen
// one has the least RMS among them, the others are listed with the reason, and the adaptive
// variant runs on the chosen model.
TEST(ExperimentKinds, AutoWithTheAdaptiveVariantChoosesAmongThePiFamily) {
  ExperimentOptions o;
  o.name = "gpi-pid";
  o.learning_periods = 0;
  ASSERT_TRUE(o.adaptive);
  const ExperimentResult r = run_experiment(o);
  ASSERT_EQ(r.candidates.size(), std::size(fit_model_kinds));
  double least_pi = std::numeric_limits<double>::infinity();
  const ModelCandidate* chosen = nullptr;
  std::size_t others = 0;
  for (const auto& c : r.candidates) {
    if (c.chosen) chosen = &c;
    if (!c.ok) continue;
    const bool pi = c.kind == FitModel::pi || c.kind == FitModel::gpi || c.kind == FitModel::mpi_deadzone ||
                    c.kind == FitModel::mpi_asym || c.kind == FitModel::maxwell_slip;
    if (pi) {
      least_pi = std::min(least_pi, c.validation.rms);
    } else {
      ++others;
      EXPECT_TRUE(contains(c.message, "not eligible for auto while the adaptive variant runs")) << c.message;
    }
  }
  EXPECT_GT(others, 0u);
  ASSERT_NE(chosen, nullptr);
  EXPECT_EQ(chosen->validation.rms, least_pi);
  EXPECT_TRUE(has_pi_structure(r.best_fit.model));
  EXPECT_TRUE(contains(r.model_reason, "the adaptive variant can use (PI family)")) << r.model_reason;
  EXPECT_NE(find_run(r, "adaptive"), nullptr);

  // Without fitting the ineligible kinds (hysteron sweep): the same choice and the same runs;
  // the kinds left out are exactly those whose fitted model had no PI structure above.
  o.fit_ineligible_candidates = false;
  const ExperimentResult lean = run_experiment(o);
  ASSERT_EQ(lean.candidates.size(), r.candidates.size());
  EXPECT_EQ(lean.best_fit.model_kind, r.best_fit.model_kind);
  EXPECT_EQ(lean.best_validation.rms, r.best_validation.rms);
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const ModelCandidate &full = r.candidates[i], &c = lean.candidates[i];
    ASSERT_EQ(c.kind, full.kind);
    const bool left_out = contains(c.message, "not fitted: not eligible");
    EXPECT_EQ(left_out, full.ok && contains(full.message, "not eligible for auto")) << fit_model_name(c.kind);
    if (left_out) {
      EXPECT_FALSE(c.ok);
    } else {
      EXPECT_EQ(c.ok, full.ok);
      EXPECT_EQ(c.validation.rms, full.validation.rms) << fit_model_name(c.kind);
    }
  }
  ASSERT_EQ(lean.runs.size(), r.runs.size());
  for (std::size_t i = 0; i < r.runs.size(); ++i)
    EXPECT_EQ(lean.runs[i].errors.rms_error_mm, r.runs[i].errors.rms_error_mm) << r.runs[i].variant;
}

// Kinds that do not exist: an unknown name, an enum value outside the registry.
TEST(ExperimentKinds, UnknownKindsAreErrors) {
  const std::string m = error_of([] { (void)fit_model_from_name("kpp"); });
  EXPECT_TRUE(contains(m, "kpp")) << m;
  ExperimentOptions o;
  o.model = static_cast<FitModel>(99);
  const std::string v = error_of([&] { o.validate(); });
  EXPECT_TRUE(contains(v, "model")) << v;
  EXPECT_THROW(run_experiment(o), Error);
}

// Every kind fit() identifies drives the three compensating controllers of the experiments
// (inverse feedforward + PID, open loop with pressure loop, PWM cascade) without allocating
// or producing a non-finite command: the per-sample step of the compensated variants.
TEST(ExperimentKinds, CompensatingStepsDoNotAllocateForAnyKind) {
  // a hysteretic record in MPa -> mm: a GPI driven by decaying triangles at 100 Hz
  const GpiParams g = test::rig_like_gpi(Limits{});
  std::vector<double> x;
  for (int k = 0; k < 3000; ++k) {
    const double t = 0.01 * k, a = 0.28 * (1.0 - t / 40.0);
    x.push_back(0.3 + a * (2.0 / std::numbers::pi) * std::asin(std::sin(2.0 * std::numbers::pi * 0.2 * t)));
  }
  const std::vector<double> y = Model(g).simulate(x);
  for (FitModel kind : fit_model_kinds) {
    SCOPED_TRACE(std::string(fit_model_name(kind)));
    FitOptions fo;
    fo.model = kind;
    fo.sample_time = 0.01;
    fo.num_threads = 1;
    FitReport rep = fit(x, y, fo);
    ASSERT_TRUE(has_model(rep.status)) << rep.message;
    std::visit([](auto& p) { p.input_limits = {0.0, 0.6}; }, rep.model);
    if (auto* rp = std::get_if<RatePiParams>(&rep.model)) {  // run at 1 kHz as the experiments do
      rp->dt = 1e-3;
      const double rmax = rp->r.empty() ? 0.0 : *std::max_element(rp->r.begin(), rp->r.end());
      if (rmax > 0) rp->c = std::min(rp->c, 0.5 * (rp->tau + rp->dt) / rmax * (1 - 1e-12));
    }
    FeedforwardParams ff;
    ff.sample_time = 1e-3;
    FeedforwardPidController fp(rep.model, ff, gpi_paper_pid(1e-3));
    OpenLoopParams olp;
    olp.feedforward = ff;
    olp.position = gpi_paper_pid(1e-3);
    OpenLoopController ol(rep.model, olp);
    CascadeParams cp;
    cp.feedforward = ff;
    cp.position = gpi_paper_pid(1e-3);
    cp.pressure.kp = 20;
    cp.pressure.sample_time = 1e-3;
    CascadePwmController cc(rep.model, cp);
    const std::size_t before = hysteron_test::allocations();
    double acc = 0;
    for (int k = 0; k < 4000; ++k) {
      const double r = 0.045 + 0.035 * std::sin(2.0 * std::numbers::pi * 0.5e-3 * k);
      acc += fp.step(r, r, r - 0.001) + ol.step(r, r, r, 0.3) + cc.step(r, r, r, 0.3);
    }
    EXPECT_EQ(hysteron_test::allocations(), before);
    EXPECT_TRUE(std::isfinite(acc));
  }
}

// A sweep pins the kind of every run (SweepOptions::model reaches each run's options) and
// reports the kind each run used (text column, JSON).
TEST(ExperimentKinds, SweepPinsTheKindAndReportsIt) {
  SweepOptions so;
  so.experiments = {"gpi-pid"};
  so.variants = parse_vary("load.mass=35");
  so.model = FitModel::bouc_wen;
  so.jobs = 2;
  std::atomic<int> calls{0};
  so.runner = [&calls](const ExperimentOptions& eo) {
    ++calls;
    if (eo.model != FitModel::bouc_wen) throw Error("the sweep did not pass its model");
    ExperimentResult r;
    r.name = eo.name;
    r.best_fit.model_kind = eo.model;
    r.model_choice = eo.model;
    r.model_reason = "bouc-wen asked for";
    TrackingRun t;
    t.variant = "compensated";
    t.reference = "sine";
    r.runs.push_back(t);
    return r;
  };
  const SweepResult s = run_sweep(so);
  EXPECT_EQ(calls.load(), 2);
  EXPECT_EQ(s.failures(), 0u);
  for (const auto& run : s.runs) EXPECT_EQ(run.model, "bouc-wen");
  const nlohmann::json j = s.to_json();
  EXPECT_EQ(j["model_choice"], "bouc-wen");
  for (const auto& run : j["runs"]) EXPECT_EQ(run["model"], "bouc-wen");
  EXPECT_TRUE(contains(s.text(), "--model bouc-wen")) << s.text();
  // an invalid kind is refused before anything runs
  so.model = static_cast<FitModel>(99);
  calls = 0;
  EXPECT_THROW(run_sweep(so), Error);
  EXPECT_EQ(calls.load(), 0);
}
