// Identification: LM parameter recovery with standard errors, constrained LS,
// invertibility of fitted models, RLS (batch equivalence, tracking, no
// allocation), input validation, and fits of the measured records in ../shared/data.
#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "alloc_counter.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/models.hpp"

using namespace hysteron;

namespace {

// Triangle input 0 -> A -> 0 with decaying amplitudes (as in the paper's experiment).
std::vector<double> decaying_triangle(std::initializer_list<double> amplitudes, int samples_per_leg) {
  std::vector<double> x;
  for (double a : amplitudes) {
    for (int k = 0; k < samples_per_leg; ++k) x.push_back(a * k / samples_per_leg);
    for (int k = 0; k < samples_per_leg; ++k) x.push_back(a * (1.0 - static_cast<double>(k) / samples_per_leg));
  }
  x.push_back(0.0);
  return x;
}

GpiParams true_gpi() {
  GpiParams g;
  g.envelope = Envelope::tanh(2.0, 0.4, -1.2, 1.5);
  g.q = 1.0;
  g.n = 10;
  g.rho = 0.5;
  g.tau = 1.5;
  g.alpha = 0.1;
  return g;
}

std::vector<double> with_noise(std::vector<double> y, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, sigma);
  for (double& v : y) v += nd(rng);
  return y;
}

const FitParameter& param(const FitReport& r, std::string_view name) {
  for (const auto& p : r.parameters)
    if (p.name == name) return p;
  throw std::runtime_error("no parameter " + std::string(name));
}

// Reads numeric columns of a headerless CSV (empty fields read as NaN).
std::vector<std::vector<double>> read_csv(const std::filesystem::path& path) {
  std::vector<std::vector<double>> cols;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    std::size_t c = 0;
    while (std::getline(ss, cell, ',')) {
      if (cols.size() <= c) cols.resize(c + 1);
      cols[c].push_back(cell.empty() ? std::nan("") : std::stod(cell));
      ++c;
    }
  }
  return cols;
}

std::filesystem::path shared_data() {
  return std::filesystem::path(HYSTERON_SOURCE_DIR) / ".." / "shared" / "data";
}

}  // namespace

TEST(IdentifyGpi, RecoversParametersWithinStandardErrors) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 400);
  const GpiParams truth = true_gpi();
  const auto clean = simulate_record(truth, x);
  const double sigma = 0.01;
  const auto y = with_noise(clean, sigma, 7);
  FitOptions o;
  o.model = FitModel::gpi;
  o.num_operators = 10;
  const FitReport r = fit(x, y, o);
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  EXPECT_NEAR(r.train.rms, sigma, 0.1 * sigma) << r.full_report();
  // Compare gauge invariants (c0 is held, see FitOptions::gpi_fix_scale): k = c0_fit / c0_true.
  const double k = param(r, "c[0]").value / truth.envelope.c[0];
  struct Check {
    const char* name;
    double truth;
    double scale;  // fitted value * scale is comparable with truth
  };
  const Check checks[] = {{"c[1]", truth.envelope.c[1], 1.0}, {"c[2]", truth.envelope.c[2], 1.0},
                          {"c[3]", truth.envelope.c[3], 1.0 / k}, {"q", truth.q, k},
                          {"rho", truth.rho, k},             {"tau", truth.tau, k},
                          {"alpha", truth.alpha, 1.0 / k}};
  for (const auto& c : checks) {
    const auto& p = param(r, c.name);
    ASSERT_TRUE(std::isfinite(p.std_error)) << c.name << "\n" << r.full_report();
    const double est = p.value * c.scale, se = p.std_error * c.scale;
    EXPECT_LE(std::abs(est - c.truth), 3.5 * se + 1e-12) << c.name << " est " << est << " se " << se;
    EXPECT_LE(std::abs(est - c.truth), 0.05 * std::abs(c.truth)) << c.name << " est " << est;
    EXPECT_GT(se, 0.0) << c.name;
  }
  EXPECT_NO_THROW(Inverse inv(r.model));
}

// From a relaxed start the plays begin at the envelope's value, so c3 shifts the output by a
// constant, exactly like the free output offset: the two are one direction of the Jacobian.
// The other parameters still get standard errors (with the envelope's level held), and
// recover the truth within them; c[3] gets none, and the note says why.
TEST(IdentifyGpi, LevelAndOffsetConfoundedStillGivesTheOtherStandardErrors) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 400);
  const GpiParams truth = true_gpi();
  const double sigma = 0.01;
  const auto y = with_noise(simulate_record(truth, x, InitialState::relaxed), sigma, 7);
  FitOptions o;
  o.model = FitModel::gpi;
  o.num_operators = 10;
  o.initial_state = InitialState::relaxed;
  const FitReport r = fit(x, y, o);
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  EXPECT_NEAR(r.train.rms, sigma, 0.1 * sigma) << r.full_report();
  EXPECT_TRUE(std::isnan(param(r, "c[3]").std_error)) << r.full_report();
  EXPECT_NE(r.covariance_note.find("c[3] and output_offset are not separately identifiable"), std::string::npos)
      << r.covariance_note;
  EXPECT_EQ(r.covariance_note.find("rank deficient"), std::string::npos) << r.covariance_note;
  const double k = param(r, "c[0]").value / truth.envelope.c[0];
  struct Check {
    const char* name;
    double truth;
    double scale;
  };
  const Check checks[] = {{"c[1]", truth.envelope.c[1], 1.0}, {"c[2]", truth.envelope.c[2], 1.0},
                          {"q", truth.q, k},                  {"rho", truth.rho, k},
                          {"tau", truth.tau, k},              {"alpha", truth.alpha, 1.0 / k}};
  for (const auto& c : checks) {
    const auto& p = param(r, c.name);
    ASSERT_TRUE(std::isfinite(p.std_error)) << c.name << "\n" << r.full_report();
    const double est = p.value * c.scale, se = p.std_error * c.scale;
    EXPECT_GT(se, 0.0) << c.name;
    EXPECT_LE(std::abs(est - c.truth), 3.5 * se + 1e-12) << c.name << " est " << est << " se " << se;
  }
  // the sum the record determines: the model's output (offset included) matches the truth
  EXPECT_LT(evaluate(r.model, x, simulate_record(truth, x, InitialState::relaxed), {}, InitialState::relaxed).rms,
            0.2 * sigma);
}

TEST(IdentifyGpi, AnalyticJacobianMatchesAutodiff) {
  const auto x = decaying_triangle({6, 4, 5, 2}, 150);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.05, 5);
  const std::vector<double> th{2.1, 0.38, -1.1, 1.4, 0.9, 0.6, 1.2, 0.12};
  for (InitialState init : {InitialState::virgin, InitialState::relaxed}) {
    for (double huber : {0.0, 0.02}) {
      Eigen::VectorXd ra, rb;
      Eigen::MatrixXd Ja, Jb;
      const IndexRange tr{20, IndexRange::npos};
      gpi_residuals(th, 10, x, y, tr, init, huber, false, ra, Ja);
      gpi_residuals(th, 10, x, y, tr, init, huber, true, rb, Jb);
      ASSERT_EQ(Ja.rows(), static_cast<Eigen::Index>(x.size() - 20));
      ASSERT_EQ(Ja.cols(), 8);
      EXPECT_LT((ra - rb).cwiseAbs().maxCoeff(), 1e-10);
      for (Eigen::Index c = 0; c < 8; ++c)
        EXPECT_LT((Ja.col(c) - Jb.col(c)).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, Jb.col(c).cwiseAbs().maxCoeff()))
            << "column " << c << " huber " << huber;
    }
  }
}

TEST(IdentifySlopes, AnalyticJacobianMatchesAutodiff) {
  // pi, mpi-deadzone (both dead-zone sides, active and inactive) and mpi-asym: the
  // hand-written forward sensitivities against Ceres Jets through structure_step<Jet>.
  const auto x = decaying_triangle({6, 4, 5, 2}, 150);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.05, 5);
  const std::vector<double> r{0.4, 0.9, 1.5, 2.2};
  const std::vector<double> zp{0.8, 2.5}, zn{-0.3};
  struct Case {
    FitModel m;
    std::vector<double> th;
  };
  const std::vector<Case> cases{
      {FitModel::pi, {0.5, 0.8, 0.7, 1.1, 1.2}},
      {FitModel::mpi_deadzone, {0.5, 0.8, 0.7, 1.1, 1.2, 1.3, 1.9, 0.7}},
      {FitModel::mpi_asym, {2.1, 0.38, -1.1, 1.4, 1.9, 0.42, -0.9, 1.6, 0.9, 0.3, 0.2, 0.1, 0.05}},
      {FitModel::gpi, {2.1, 0.38, -1.1, 1.4, 0.5, 0.8, 0.7, 1.1, 1.2}},  // free-weight variant
  };
  for (const Case& c : cases) {
    for (InitialState init : {InitialState::virgin, InitialState::relaxed}) {
      for (double huber : {0.0, 0.02}) {
        Eigen::VectorXd ra, rb;
        Eigen::MatrixXd Ja, Jb;
        const IndexRange tr{20, IndexRange::npos};
        slope_residuals(c.m, c.th, r, zp, zn, x, y, tr, init, huber, false, ra, Ja);
        slope_residuals(c.m, c.th, r, zp, zn, x, y, tr, init, huber, true, rb, Jb);
        ASSERT_EQ(Ja.rows(), static_cast<Eigen::Index>(x.size() - 20));
        ASSERT_EQ(Ja.cols(), static_cast<Eigen::Index>(c.th.size()));
        EXPECT_LT((ra - rb).cwiseAbs().maxCoeff(), 1e-10) << fit_model_name(c.m);
        for (Eigen::Index k = 0; k < Ja.cols(); ++k)
          EXPECT_LT((Ja.col(k) - Jb.col(k)).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, Jb.col(k).cwiseAbs().maxCoeff()))
              << fit_model_name(c.m) << " column " << k << " huber " << huber;
      }
    }
  }
}

TEST(IdentifyGpi, FitsQuicklyAndFreeScaleReportsSingularCovariance) {
  const auto x = decaying_triangle({6, 4, 2}, 300);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.01, 3);
  FitOptions o;
  o.gpi_fix_scale = false;
  const FitReport r = fit(x, y, o);
  ASSERT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << r.full_report();
  EXPECT_LT(r.train.rms, 0.02);
  EXPECT_FALSE(r.covariance_note.empty());
}

// A gpi whose weight density is U-shaped (large at the smallest and the largest
// thresholds, as the classical PI fitted to the piezo record has): Eq. 8's monotone
// law cannot follow it, the free-weight variant can.
TEST(IdentifyGpi, FreeWeightsFitWhatEq8CannotAndStayInvertible) {
  const auto x = decaying_triangle({6, 3, 5, 1.5, 4, 2}, 300);
  GpiParams truth;
  truth.envelope = Envelope::tanh(2.0, 0.4, -1.2, 1.5);
  truth.q = 0.8;
  truth.n = 8;
  for (int i = 1; i <= 8; ++i) truth.r.push_back(0.2 * i);
  truth.p = {0.9, 0.35, 0.1, 0.05, 0.05, 0.1, 0.35, 0.9};
  const double sigma = 0.005;
  const auto y = with_noise(simulate_record(truth, x), sigma, 11);
  FitOptions o;
  o.model = FitModel::gpi;
  o.num_operators = 8;
  const FitReport eq8 = fit(x, y, o);
  o.gpi_free_weights = true;
  const FitReport fw = fit(x, y, o);
  ASSERT_TRUE(fw.status == FitStatus::converged || fw.status == FitStatus::no_convergence) << fw.full_report();
  ASSERT_TRUE(eq8.status == FitStatus::converged || eq8.status == FitStatus::no_convergence) << eq8.full_report();
  const auto& g = std::get<GpiParams>(fw.model);
  EXPECT_EQ(g.r.size(), 8u);
  EXPECT_EQ(g.p.size(), 8u);
  EXPECT_EQ(fw.parameters.size(), 4u + 1u + 8u + 4u);  // c, q, p_i, the units map
  EXPECT_LT(fw.train.rms, 0.5 * eq8.train.rms) << "free " << fw.train.rms << " eq8 " << eq8.train.rms;
  EXPECT_LT(fw.train.rms, 4 * sigma) << fw.full_report();
  // invertible (partial sums > 0): the inverse undoes the fitted model
  Inverse inv(fw.model);
  Model fwd(fw.model);
  double worst = 0;
  for (double v : x) worst = std::max(worst, std::abs(inv.step(fwd.step(v)) - v));
  EXPECT_LT(worst, 1e-9);
}

TEST(IdentifyPi, ConstrainedLeastSquaresRecoversExactWeights) {
  const auto x = decaying_triangle({10, 7, 9, 3, 6, 1}, 100);
  PiParams truth;
  truth.r = default_thresholds(x, 8);
  truth.q = 0.8;
  truth.p = {0.5, 0.3, -0.2, 0.25, 0.1, 0.05, 0.02};
  const auto y = simulate_record(truth, x);
  PiParams tmpl = truth;
  std::fill(tmpl.p.begin(), tmpl.p.end(), 0.0);
  tmpl.q = 0.0;
  const auto fitted = std::get<PiParams>(fit_weights(tmpl, x, y));
  EXPECT_NEAR(fitted.q, truth.q, 1e-8);
  for (std::size_t i = 0; i < truth.p.size(); ++i) EXPECT_NEAR(fitted.p[i], truth.p[i], 1e-8) << i;

  FitOptions o;
  o.model = FitModel::pi;
  o.num_operators = 8;
  const FitReport r = fit(x, y, o);
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  EXPECT_LT(r.train.rms, 1e-8);
  EXPECT_NEAR(param(r, "q").value, truth.q, 1e-7);
}

TEST(IdentifyPi, ConstraintsKeepModelsInvertible) {
  // Data from a non-invertible PI (q + p_1 < 0): unconstrained LS would reproduce it.
  const auto x = decaying_triangle({10, 7, 4}, 100);
  PiParams bad;
  bad.r = default_thresholds(x, 4);
  bad.q = 1.0;
  bad.p = {-1.6, 0.2, 0.1};
  const auto y = simulate_record(bad, x);
  EXPECT_THROW(Inverse inv(bad), Error);
  PiParams tmpl = bad;
  tmpl.q = 0;
  std::fill(tmpl.p.begin(), tmpl.p.end(), 0.0);
  const auto fitted = fit_weights(tmpl, x, y);
  EXPECT_NO_THROW(Inverse inv(fitted));
  const auto& f = std::get<PiParams>(fitted);
  double s = f.q;
  EXPECT_GT(s, 0);
  for (double p : f.p) EXPECT_GT(s += p, 0);
}

TEST(IdentifyAll, EveryModelFitsAndIsInvertible) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.005, 11);
  double rms_gpi = 0, rms_pi = 0;
  for (FitModel m : {FitModel::pi, FitModel::gpi, FitModel::mpi_deadzone, FitModel::mpi_asym}) {
    FitOptions o;
    o.model = m;
    const FitReport r = fit(x, y, o);
    ASSERT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence)
        << fit_model_name(m) << ": " << r.full_report();
    EXPECT_EQ(model_name(r.model), fit_model_name(m));
    EXPECT_NO_THROW(Inverse inv(r.model)) << fit_model_name(m);
    EXPECT_LT(r.train.rms_percent_span, m == FitModel::pi ? 5.0 : 2.0) << r.full_report();
    if (m == FitModel::gpi) rms_gpi = r.train.rms;
    if (m == FitModel::pi) rms_pi = r.train.rms;
    if (m == FitModel::mpi_asym) {
      EXPECT_LE(r.train.rms, rms_gpi * 1.25);  // fixed threshold grid vs the exact gpi law of the data
    }
  }
  EXPECT_LT(rms_gpi, rms_pi);
}

// Starts refined on worker threads give the result of the sequential run, bit for bit,
// and every start reports its progress.
TEST(IdentifyAll, ResultDoesNotDependOnTheThreadCount) {
  const auto x = decaying_triangle({6, 4, 2}, 100);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.005, 5);
  for (FitModel m : {FitModel::pi, FitModel::gpi, FitModel::mpi_deadzone, FitModel::mpi_asym}) {
    FitOptions o;
    o.model = m;
    o.num_starts = 3;
    o.max_iterations = 60;
    o.num_threads = 1;
    const FitReport seq = fit(x, y, o);
    std::mutex mu;
    std::set<int> seen;
    std::atomic<int> inside{0}, concurrent{0};
    o.num_threads = 3;
    o.progress = [&](int start, int, double) {
      const int now = ++inside;  // the library serialises the calls: never 2 at once
      if (now > concurrent) concurrent = now;
      std::this_thread::sleep_for(std::chrono::microseconds(20));
      --inside;
      const std::lock_guard<std::mutex> lock(mu);
      seen.insert(start);
    };
    const FitReport par = fit(x, y, o);
    SCOPED_TRACE(fit_model_name(m));
    ASSERT_NE(seq.status, FitStatus::invalid_input) << seq.message;
    EXPECT_EQ(par.status, seq.status);
    EXPECT_EQ(par.final_cost, seq.final_cost);
    EXPECT_EQ(par.total_iterations, seq.total_iterations);
    EXPECT_EQ(par.num_starts, seq.num_starts);
    ASSERT_EQ(par.parameters.size(), seq.parameters.size());
    for (std::size_t i = 0; i < seq.parameters.size(); ++i) {
      EXPECT_EQ(par.parameters[i].value, seq.parameters[i].value) << seq.parameters[i].name;
      EXPECT_EQ(std::isnan(par.parameters[i].std_error), std::isnan(seq.parameters[i].std_error));
      if (!std::isnan(seq.parameters[i].std_error)) {
        EXPECT_EQ(par.parameters[i].std_error, seq.parameters[i].std_error);
      }
    }
    EXPECT_EQ(static_cast<int>(seen.size()), par.num_starts);
    EXPECT_EQ(concurrent, 1);
  }
  FitOptions bad;
  bad.num_threads = -1;
  const FitReport r = fit(x, y, bad);
  EXPECT_EQ(r.status, FitStatus::invalid_input);
  EXPECT_NE(r.message.find("num_threads"), std::string::npos) << r.message;
}

// The stationarity test ends LM as converged once the cost's relative decrease over
// the last stall_iterations iterations is at most stall_tolerance.
TEST(IdentifyAll, StationaryCostEndsTheFitAsConverged) {
  const auto x = decaying_triangle({6, 4, 2}, 100);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.005, 5);
  FitOptions o;
  o.model = FitModel::mpi_asym;
  o.num_starts = 1;
  o.max_iterations = 3;
  o.compute_covariance = false;
  const FitReport limited = fit(x, y, o);  // window 25 > 3 iterations: the limit ends it
  EXPECT_EQ(limited.status, FitStatus::no_convergence) << limited.full_report();
  o.max_iterations = 200;
  o.stall_iterations = 3;
  o.stall_tolerance = 1e300;  // (decrease relative to the current cost) any decrease passes: ends after 3
  const FitReport stalled = fit(x, y, o);
  EXPECT_EQ(stalled.status, FitStatus::converged) << stalled.full_report();
  // 3 in each orientation of the input (mpi-asym fits both, FitOptions::mpi_asym_mirror)
  EXPECT_EQ(stalled.total_iterations, 2 * 3) << stalled.full_report();
  EXPECT_EQ(stalled.num_starts, 2);
  EXPECT_NE(stalled.message.find("stationary"), std::string::npos) << stalled.message;
  o.stall_tolerance = 0.0;  // disabled: Ceres' own tolerances decide
  const FitReport plain = fit(x, y, o);
  EXPECT_GT(plain.total_iterations, 3);
  EXPECT_EQ(plain.message.find("stationary"), std::string::npos) << plain.message;
  for (auto [it, tol] : {std::pair{0, 1e-5}, std::pair{25, -1.0}, std::pair{25, std::nan("")}}) {
    FitOptions bad;
    bad.stall_iterations = it;
    bad.stall_tolerance = tol;
    const FitReport r = fit(x, y, bad);
    EXPECT_EQ(r.status, FitStatus::invalid_input);
    EXPECT_NE(r.message.find("stall_"), std::string::npos) << r.message;
  }
}

// gpi's LM runs in two passes (a probe, then the rest with the parameters on their bounds
// held): a fit that ends on the iteration limit says the whole count, as `iterations` does
// (the message said Ceres' "Number of iterations: 3." of the second pass for 43 in all).
TEST(IdentifyGpi, IterationLimitMessageCountsBothPasses) {
  // a record gpi cannot fit exactly (a ripple in the input): LM still moves after 40 iterations
  const auto x = decaying_triangle({6, 4, 2, 5, 1, 3}, 100);
  auto y = with_noise(simulate_record(true_gpi(), x), 0.2, 5);
  for (std::size_t k = 0; k < x.size(); ++k) y[k] += 0.5 * std::sin(7.0 * x[k]);
  FitOptions o;
  o.model = FitModel::gpi;
  o.num_starts = 1;
  o.compute_covariance = false;
  o.stall_tolerance = 0.0;  // only the iteration limit ends it
  o.function_tolerance = o.gradient_tolerance = o.parameter_tolerance = 0.0;
  o.max_iterations = 43;  // above the probe's 40: a second pass
  const FitReport r = fit(x, y, o);
  ASSERT_EQ(r.status, FitStatus::no_convergence) << r.full_report();
  EXPECT_EQ(r.iterations, 43) << r.full_report();
  EXPECT_NE(r.message.find("43 in all"), std::string::npos) << r.message;
  EXPECT_EQ(r.message.find("Number of iterations: 3."), std::string::npos) << r.message;
}

// The same confounding for the kinds fitted in the cumulative-slope layout with envelopes
// (mpi-asym: two, gpi --free-weights: one): from a relaxed start a common shift of the c[3]s
// is the output offset. The other parameters keep their standard errors.
TEST(IdentifyAll, EnvelopeLevelsConfoundedWithTheOffsetLeaveTheOtherStandardErrors) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = with_noise(simulate_record(true_gpi(), x, InitialState::relaxed), 0.01, 9);
  for (const bool asym : {true, false}) {
    FitOptions o;
    o.model = asym ? FitModel::mpi_asym : FitModel::gpi;
    o.gpi_free_weights = !asym;
    o.num_operators = 6;
    o.initial_state = InitialState::relaxed;
    const FitReport r = fit(x, y, o);
    ASSERT_TRUE(has_model(r.status)) << r.full_report();
    EXPECT_NE(r.covariance_note.find("not separately identifiable"), std::string::npos) << r.full_report();
    int with_error = 0;
    for (const FitParameter& p : r.parameters) {
      if (p.name.ends_with("c[3]")) {
        EXPECT_TRUE(std::isnan(p.std_error)) << p.name;
      } else if (p.name != "output_offset" && std::isfinite(p.std_error) && p.std_error > 0) {
        ++with_error;
      }
    }
    EXPECT_GE(with_error, asym ? 8 : 5) << r.full_report();
  }
}

// A Huber threshold far above every residual makes the loss least squares (scaled): the
// standard errors must then be those of the least-squares fit. They were sqrt(d) of them
// (d = threshold / output span), the plain SSE paired with the robust residuals' Jacobian.
TEST(IdentifyAll, HuberAboveEveryResidualGivesTheLeastSquaresStandardErrors) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.01, 13);
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  const double huber = 0.2 * (*hi - *lo);  // d = 0.2: above every residual of these fits
  for (const FitModel kind : {FitModel::pi, FitModel::gpi, FitModel::mpi_asym}) {
    FitOptions o;
    o.model = kind;
    o.num_operators = 6;
    const FitReport ls = fit(x, y, o);
    o.huber_delta = huber;
    const FitReport hb = fit(x, y, o);
    ASSERT_TRUE(has_model(ls.status) && has_model(hb.status)) << ls.full_report() << hb.full_report();
    ASSERT_EQ(ls.parameters.size(), hb.parameters.size());
    // every residual inside the quadratic zone: the least-squares start of the slope kinds is
    // the Huber fit's minimum too, so a fit that stays there has converged as without Huber
    EXPECT_EQ(hb.status, ls.status) << fit_model_name(kind) << ": " << hb.message;
    int compared = 0;
    for (std::size_t i = 0; i < ls.parameters.size(); ++i) {
      const FitParameter &a = ls.parameters[i], &b = hb.parameters[i];
      if (!(std::isfinite(a.std_error) && std::isfinite(b.std_error)) || a.std_error <= 0 || b.std_error <= 0) continue;
      if (a.name.ends_with("c[3]")) continue;  // with the offset free (least squares) c3 is another direction
      EXPECT_GT(b.std_error / a.std_error, 0.5) << fit_model_name(kind) << " " << a.name;
      EXPECT_LT(b.std_error / a.std_error, 2.0) << fit_model_name(kind) << " " << a.name;
      ++compared;
    }
    EXPECT_GE(compared, 4) << fit_model_name(kind) << "\n" << ls.full_report() << hb.full_report();
  }
}

// A Huber fit gives up some RMS to down-weight large residuals, so the poor-fit rule compares
// it with the reference PI under its own loss (sqrt of twice the mean Huber loss), not by RMS:
// a 6-operator PI with --huber on a GPI record was poor_fit by RMS (1.07x the 10-operator
// reference) while better than the reference under the Huber loss. A fit that is worse than
// the reference under its loss is still poor, and says so.
TEST(IdentifyAll, HuberFitIsJudgedUnderItsOwnLoss) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = with_noise(simulate_record(true_gpi(), x), 0.01, 13);
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  FitOptions o;
  o.model = FitModel::pi;
  o.num_operators = 6;
  o.huber_delta = 0.02 * (*hi - *lo);
  const FitReport r = fit(x, y, o);
  EXPECT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << r.message;
  EXPECT_GT(r.train.rms, r.reference.rms);  // (worse by RMS: the case the rule must not call poor)
  o.num_operators = 2;  // two plays cannot follow the loops: worse than the reference under any loss
  const FitReport poor = fit(x, y, o);
  EXPECT_EQ(poor.status, FitStatus::poor_fit) << poor.message;
  EXPECT_NE(poor.message.find("Huber RMS"), std::string::npos) << poor.message;
}

TEST(IdentifyDeadzone, FitWeightsInvertsTheDeadZoneMap) {
  // Forward mpi-deadzone data; fit_weights with thresholds in output units.
  const auto x = decaying_triangle({10, 7, 9, 3, 6, 1}, 100);
  MpiDeadzoneParams truth;
  truth.r = default_thresholds(x, 5);
  truth.q = 0.5;
  truth.p = {0.3, 0.2, 0.1, 0.05};
  truth.z = {3.0, 6.0};
  truth.g = {0.4, 0.3};
  const auto y = simulate_record(truth, x);
  MpiDeadzoneParams tmpl = truth;
  // inverse thresholds: output values at the forward thresholds, S(z) = z
  tmpl.z = {3.0, 3.0 + 1.4 * 3.0};
  tmpl.g = {0.0, 0.0};
  const auto fitted = fit_weights(tmpl, x, y);
  const FitMetrics m = evaluate(fitted, x, y);
  EXPECT_LT(m.rms, 1e-7);
  EXPECT_NO_THROW(Inverse inv(fitted));
}

TEST(IdentifyDeadzone, MajorLoopFitExtrapolatesToMinorLoops) {
  // Fit on one major loop 0 -> 6 -> 0 only, validate on the minor loops that follow.
  // Without the weight regularization LM found large cancelling play weights that
  // fit the major loop and failed on the minor loops (rig record: 1.3 mm train,
  // 16 mm validation).
  // The "plant" has been cycled before the record starts (a pre-roll 0 -> 6 -> 0 is
  // simulated and dropped), so its first ascent equals its later ones, as on the rig.
  GpiParams truth = true_gpi();
  truth.alpha = 0.3;
  const auto x = decaying_triangle({6, 3, 5, 2, 4, 1.5}, 100);
  auto xp = decaying_triangle({6}, 100);
  const std::size_t pre = xp.size();
  xp.insert(xp.end(), x.begin(), x.end());
  const auto yp = simulate_record(truth, xp);
  const auto y = with_noise(std::vector<double>(yp.begin() + static_cast<std::ptrdiff_t>(pre), yp.end()), 0.01, 17);
  FitOptions o;
  o.model = FitModel::mpi_deadzone;
  o.train = {0, 200};
  o.compute_covariance = false;
  const FitReport r = fit(x, y, o);
  ASSERT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << r.full_report();
  const FitMetrics v = evaluate(r.model, x, y, {200, IndexRange::npos});
  EXPECT_LT(v.rms, 3.0 * r.train.rms) << r.full_report() << "validation rms " << v.rms;
  EXPECT_NO_THROW(Inverse inv(r.model));
}

TEST(IdentifyRls, ConvergesToBatchLeastSquares) {
  const auto x = decaying_triangle({10, 7, 9, 3, 6, 1, 8}, 100);
  PiParams truth;
  truth.r = default_thresholds(x, 6);
  truth.q = 0.8;
  truth.p = {0.5, 0.3, 0.2, 0.1, 0.05};
  const auto y = with_noise(simulate_record(truth, x), 0.01, 5);
  PiParams tmpl = truth;
  tmpl.q = 0;
  std::fill(tmpl.p.begin(), tmpl.p.end(), 0.0);
  const auto batch = std::get<PiParams>(fit_weights(tmpl, x, y));  // constraints inactive here
  const auto rls = std::get<PiParams>(rls_fit(tmpl, x, y, 1.0, 1));
  EXPECT_NEAR(rls.q, batch.q, 1e-4);
  for (std::size_t i = 0; i < batch.p.size(); ++i) EXPECT_NEAR(rls.p[i], batch.p[i], 1e-4) << i;
}

TEST(IdentifyRls, TracksAChangeWithForgettingAndNeverAllocates) {
  std::vector<double> x;
  for (int rep = 0; rep < 12; ++rep) {
    const auto seg = decaying_triangle({10, 6, 8, 3}, 40);
    x.insert(x.end(), seg.begin(), seg.end());
  }
  PiParams a;
  a.r = default_thresholds(x, 4);
  a.q = 0.8;
  a.p = {0.5, 0.3, 0.2};
  PiParams b = a;
  b.q = 1.2;
  b.p = {0.2, 0.4, 0.1};
  const auto ya = simulate_record(a, x);
  const auto yb = simulate_record(b, x);
  PiParams tmpl = a;
  tmpl.q = 0;
  std::fill(tmpl.p.begin(), tmpl.p.end(), 0.0);
  Rls rls(tmpl, 0.98);
  const std::size_t half = x.size() / 2;
  for (std::size_t k = 0; k < half; ++k) rls.step(x[k], ya[k]);
  EXPECT_NEAR(rls.theta()(0), a.q, 1e-3);
  const std::size_t before = hysteron_test::allocations();
  for (std::size_t k = half; k < x.size(); ++k) rls.step(x[k], yb[k]);
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_NEAR(rls.theta()(0), b.q, 1e-3);
  for (std::size_t i = 0; i < b.p.size(); ++i) EXPECT_NEAR(rls.theta()(static_cast<Eigen::Index>(i + 1)), b.p[i], 1e-3);
  EXPECT_THROW(Rls(MpiDeadzoneParams{}, 0.99), Error);
  EXPECT_THROW(Rls(tmpl, 1.5), Error);
}

// The input held for hundreds of memory lengths (a rig at rest), then moving again: forgetting
// grows P as lambda^-k in the directions a constant regressor does not excite; unbounded, the
// standard update lost positive definiteness after 20-40 memory lengths and the estimate then
// ran away (q = -9.3e7). With the covariance bounded by its prior the estimate after the hold
// is as good as before it.
TEST(IdentifyRls, AHeldInputNeitherWindsUpNorBreaksTheCovariance) {
  PiParams nominal;
  nominal.q = 0.5;
  nominal.r = {0.05, 0.1, 0.2, 0.3, 0.4};
  nominal.p = {0.3, 0.2, 0.15, 0.1, 0.05};
  PiParams truth = nominal;
  for (double& v : truth.p) v *= 1.3;
  const double lambda = 0.9998, sigma = 0.005;
  const int period = 20000;  // 2 s at 10 kHz
  auto sine = [&](int k) { return 0.5 - 0.45 * std::cos(2 * M_PI * k / period); };
  Model plant(truth);
  Rls rls(nominal, lambda);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, sigma);
  // The regressor from the play operators directly, and the forgetting-weighted information
  // R1 = sum lambda^(N-k) phi phi^T and R2 = sum lambda^(2(N-k)) phi phi^T of the data.
  std::vector<double> ops(5, 0.0);
  Eigen::MatrixXd R1 = Eigen::MatrixXd::Zero(6, 6), R2 = R1;
  Eigen::VectorXd phi(6);
  auto feed = [&](double x) {
    rls.step(x, plant.step(x) + noise(rng));
    phi(0) = x;
    for (int i = 0; i < 5; ++i)
      phi(i + 1) = ops[static_cast<std::size_t>(i)] =
          std::max(x - nominal.r[static_cast<std::size_t>(i)],
                   std::min(x + nominal.r[static_cast<std::size_t>(i)], ops[static_cast<std::size_t>(i)]));
    R1 = lambda * R1 + phi * phi.transpose();
    R2 = lambda * lambda * R2 + phi * phi.transpose();
  };
  for (int k = 0; k < 3 * period; ++k) feed(sine(k));
  for (int k = 0; k < 1'000'000; ++k) feed(0.5);  // 100 s, 200 memory lengths
  auto positive_definite = [&] {
    const Eigen::LLT<Eigen::MatrixXd> llt(rls.covariance());
    return llt.info() == Eigen::Success && rls.covariance().allFinite();
  };
  EXPECT_TRUE(positive_definite()) << "after the hold";
  EXPECT_LE(rls.covariance().trace(), 6 * 1e6 * (1 + 1e-12));  // the prior's trace: 6 weights, p0 = 1e6
  R1.setZero();
  R2.setZero();
  for (int k = 0; k < 3 * period; ++k) feed(sine(k));  // 12 memory lengths: the hold is forgotten
  EXPECT_TRUE(positive_definite()) << "after the second sine";
  // Tolerance from the noise: the forgetting-weighted least-squares estimate has the covariance
  // sigma^2 R1^-1 R2 R1^-1; 6 standard deviations.
  const Eigen::MatrixXd R1inv = R1.inverse();
  const Eigen::MatrixXd C = sigma * sigma * R1inv * R2 * R1inv;
  for (Eigen::Index i = 0; i < 6; ++i) {
    const double want = i == 0 ? truth.q : truth.p[static_cast<std::size_t>(i - 1)];
    EXPECT_NEAR(rls.theta()(i), want, 6 * std::sqrt(C(i, i))) << "weight " << i;
    EXPECT_LT(std::sqrt(C(i, i)), 0.05 * std::abs(want)) << "weight " << i << ": the test would be too weak";
  }
  EXPECT_EQ(rls.faults(), 0u);
  EXPECT_GT(rls.bounded(), 0u);  // the bound acted (during the hold)
}

TEST(IdentifyInput, BadInputIsRejected) {
  const auto x = decaying_triangle({6, 3}, 100);
  const auto y = simulate_record(true_gpi(), x);
  auto status = [](std::span<const double> xs, std::span<const double> ys, FitOptions o = {}) {
    const FitReport r = fit(xs, ys, o);
    EXPECT_FALSE(r.message.empty());
    return r.status;
  };
  EXPECT_EQ(status(x, std::span<const double>(y).first(y.size() - 1)), FitStatus::invalid_input);
  auto yn = y;
  yn[10] = std::nan("");
  EXPECT_EQ(status(x, yn), FitStatus::invalid_input);
  const std::vector<double> xc(x.size(), 1.0);
  EXPECT_EQ(status(xc, y), FitStatus::invalid_input);
  EXPECT_EQ(status(std::span<const double>(x).first(50), std::span<const double>(y).first(50)), FitStatus::invalid_input);
  FitOptions o;
  o.train = {10, x.size() + 5};
  EXPECT_EQ(status(x, y, o), FitStatus::invalid_input);
  o = {};
  o.num_operators = 0;
  EXPECT_EQ(status(x, y, o), FitStatus::invalid_input);
  EXPECT_THROW(fit_weights(PiParams{1.0, {1.0}, {0.0}, {}, {}}, x, yn), Error);
  EXPECT_THROW(evaluate(true_gpi(), x, y, {0, x.size() + 1}), Error);
  EXPECT_THROW(fit_model_from_name("preisach2"), Error);
}

// A record scored beyond the input range a model was fitted on is said to be (audit of
// 2026-11-29: kp fitted on a tracking run up to 0.28 MPa scored 14.4 mm RMS on an
// identification run up to 0.6 MPa, with nothing saying 26 % of it was outside that range).
// fit() sets input_limits to the training range's input; samples within 2 % of the limits'
// span beyond them are not counted; unbounded limits count nothing.
TEST(IdentifyInput, InputCoverageCountsSamplesBeyondTheFittedRange) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = simulate_record(true_gpi(), x);
  const std::size_t half = x.size() / 2;  // the smaller loops: a narrower input range
  FitOptions o;
  o.train = {half, x.size()};
  const FitReport r = fit(x, y, o);
  ASSERT_TRUE(has_model(r.status));
  const Limits lim = input_limits(r.model);
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t k = half; k < x.size(); ++k) lo = std::min(lo, x[k]), hi = std::max(hi, x[k]);
  EXPECT_EQ(lim.lo, lo);
  EXPECT_EQ(lim.hi, hi);
  const double tol = kInputCoverageTolerance * (hi - lo);
  std::size_t outside = 0;
  double beyond = 0.0;
  for (double v : x) {
    outside += std::max(lo - v, v - hi) > tol;  // (the definition: beyond the limits by more than tol)
    beyond = std::max({beyond, v - hi, lo - v});
  }
  ASSERT_GT(outside, x.size() / 20);
  const InputCoverage c = input_coverage(r.model, x);
  EXPECT_EQ(c.outside, outside);
  EXPECT_EQ(c.n, x.size());
  EXPECT_DOUBLE_EQ(c.max_beyond, beyond);
  const std::string w = input_coverage_warning(c, "rec.csv");
  EXPECT_EQ(w.rfind(fmt::format("rec.csv: {} of the {} scored samples", outside, x.size()), 0), 0u) << w;
  // the training range itself: nothing outside, no warning
  const InputCoverage own = input_coverage(r.model, x, {half, x.size()});
  EXPECT_EQ(own.outside, 0u);
  EXPECT_TRUE(input_coverage_warning(own, "rec.csv").empty());
  // unbounded limits: nothing to be outside of
  ModelParams open = r.model;
  std::visit([](auto& p) { p.input_limits = Limits{}; }, open);
  EXPECT_EQ(input_coverage(open, x).outside, 0u);
}

// The sign / scale / zero diagnosis only where the map makes the model describe the record: its
// R^2 at least kMinFitR2 and, given the training R^2, 1 - r2_mapped <= sqrt(1 - train R^2).
// Otherwise the warning says plainly that the model describes the record far worse than its
// training record, with the numbers. (Audit of 2026-12-01: a time column taken for the output
// scored R^2 -639 and was asked "is its sign flipped" at a mapped R^2 of 0.239; two independent
// random walks, R^2 -16 mapped 0.148, alike.) The maps below are those the audit measured.
TEST(IdentifyInput, OutputMapClaimsASignOrZeroOnlyWhereTheMapFits) {
  const auto map = [](double gain, double r2, double r2_mapped, double rms, double rms_mapped, double span) {
    OutputMap m;
    m.gain = gain, m.offset = 1.0, m.r2 = r2, m.r2_mapped = r2_mapped, m.rms = rms, m.rms_mapped = rms_mapped;
    m.span = span;
    return m;
  };
  const OutputMap time_column = map(-0.02902, -639.02, 0.2388, 208.46, 7.189, 28.252);
  const OutputMap walks = map(-0.3548, -16.107, 0.1475, 69.45, 15.50, 83.33);
  const OutputMap negated = map(-0.989, -8.437, 0.992, 425.9, 12.35, 379.8);  // Festo test9, force negated
  for (const OutputMap& m : {time_column, walks}) {
    for (double train : {0.99955, 0.894, std::nan("")}) {
      const std::string w = output_map_warning(m, "v.csv", train);
      EXPECT_FALSE(output_map_explains(m, train));
      EXPECT_EQ(w.find("sign flipped"), std::string::npos) << w;
      EXPECT_EQ(w.rfind("v.csv: the model's prediction scores R^2 ", 0), 0u) << w;
      EXPECT_NE(w.find("worse than the record's mean"), std::string::npos) << w;
      EXPECT_NE(w.find("far worse than the one it was fitted on"), std::string::npos) << w;
      EXPECT_EQ(w.find("in training") != std::string::npos, std::isfinite(train)) << w;
    }
  }
  EXPECT_NE(output_map_warning(time_column, "v.csv", 0.99955).find("R^2 -639"), std::string::npos);
  EXPECT_NE(output_map_warning(time_column, "v.csv", 0.99955).find("(the best map gain x prediction + offset leaves "
                                                                    "R^2 0.239)"),
            std::string::npos)
      << output_map_warning(time_column, "v.csv", 0.99955);
  // a sign the map does explain: named, against a training fit of R^2 0.99955 (up to 0.021 unexplained) or none
  for (double train : {0.99955, std::nan("")}) {
    EXPECT_TRUE(output_map_explains(negated, train));
    EXPECT_NE(output_map_warning(negated, "v.csv", train).find("is its sign flipped"), std::string::npos);
  }
  // ... but not against a training fit 100 times closer (R^2 0.99999: 1 - 0.992 > sqrt(1e-5))
  EXPECT_FALSE(output_map_explains(negated, 0.99999));
  EXPECT_NE(output_map_warning(negated, "v.csv", 0.99999).find("far worse"), std::string::npos);
}

// On a stretch spanning less than kNarrowInputShare of the model's input range (review of 2026-12-01):
// a flipped sign the map explains convincingly is still named (Festo test9 with its force negated, its
// first 40 % of the input range: said only "R^2 ... say little" before), with or without the training
// error; the maps of 100-sample windows of the training record itself (test8) name nothing; and such
// a stretch is never useless (those windows exited 3).
TEST(IdentifyInput, NarrowStretchNamesOnlyAConvincingMap) {
  const auto map = [](double gain, double r2, double r2_mapped, double rms, double rms_mapped, double span) {
    OutputMap m;
    m.gain = gain, m.offset = 1.0, m.r2 = r2, m.r2_mapped = r2_mapped, m.rms = rms, m.rms_mapped = rms_mapped;
    m.span = span;
    return m;
  };
  const double train_r2 = 0.99955, train_rms = 3.3325, nan = std::nan("");
  const OutputMap negated = map(-0.8797, -20.77, 0.9770, 114.93, 3.7348, 90.17);
  for (double tr : {train_rms, nan}) {
    const std::string w = output_map_warning(negated, "v.csv", std::isfinite(tr) ? train_r2 : nan, tr, 0.40);
    EXPECT_NE(w.find("is its sign flipped"), std::string::npos) << w;
  }
  for (const OutputMap& m : {map(0.4066, -0.8208, 0.7203, 7.1849, 2.8161, 37.57),
                             map(-4.5302, -0.5958, 0.5571, 7.1157, 3.7485, 30.74),
                             map(-2.4287, -0.5996, 0.5813, 6.9038, 3.5323, 28.01)})
    for (double tr : {train_rms, nan}) {
      const std::string w = output_map_warning(m, "t8.csv", std::isfinite(tr) ? train_r2 : nan, tr, 0.05);
      EXPECT_NE(w.find("say little about the model"), std::string::npos) << w;
      EXPECT_EQ(w.find("sign flipped"), std::string::npos) << w;
      EXPECT_EQ(w.find("sensor offset"), std::string::npos) << w;
    }
  FitMetrics train, bad;
  train.rms = train_rms;
  bad.r2 = -0.82;
  bad.rms = 7.18;
  EXPECT_TRUE(validation_useless(bad, train));
  EXPECT_TRUE(validation_useless(bad, train, 0.5));
  EXPECT_FALSE(validation_useless(bad, train, 0.05));
  // ... unless a sign, unit or zero explains it (a record in bar against a model in kPa spans 1 %)
  EXPECT_TRUE(validation_useless(bad, train, 0.05, true));
  EXPECT_TRUE(output_map_names(negated, train_r2, train_rms, 0.40));
  EXPECT_TRUE(output_map_names(negated, nan, nan, 0.40));
}

// judge_evaluation: what evaluate says (the CLI's, Python's and MATLAB's alike, 2026-12-01: the
// bindings had ignored the training error and the input map). A record of the model's own actuator
// with its input in another unit (x / 1000: MPa against kPa) names the input map and is useless
// against the training error; without a training error nothing is useless; the training record
// itself gets neither.
TEST(IdentifyInput, JudgeEvaluationNamesTheInputMapAndTheVerdict) {
  GpiParams g = true_gpi();
  g.input_limits = {0.0, 6.0};
  const ModelParams model = g;
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto y = with_noise(simulate_record(model, x), 0.01, 7);
  FitMetrics train = evaluate_scored(model, x, y, {}, InitialState::virgin, false);
  ASSERT_LT(train.rms, 0.02);
  const auto judge = [&](const std::vector<double>& xr, const FitMetrics& tr) {
    const FitMetrics m = evaluate_scored(model, xr, y, {}, InitialState::virgin, false);
    const InputCoverage cov = input_coverage(model, xr, {});
    return std::pair{m, judge_evaluation(model, xr, y, {}, InitialState::virgin, false,
                                         output_map(model, xr, y, {}, InitialState::virgin, false), m, tr,
                                         cov.span_share, "r.csv", "samples 0..2401")};
  };
  const auto [own_m, own] = judge(x, train);
  EXPECT_TRUE(own.diagnosis.warning.empty()) << own.diagnosis.warning;
  EXPECT_FALSE(own.useless);
  EXPECT_TRUE(own.useless_warning.empty());
  std::vector<double> mpa(x);
  for (double& v : mpa) v /= 1000.0;
  const auto [m, v] = judge(mpa, train);
  ASSERT_TRUE(v.diagnosis.input_map.found) << v.diagnosis.warning;
  EXPECT_EQ(v.diagnosis.input_map.scale, 1000.0);
  EXPECT_LT(v.diagnosis.input_map.rms, 2.0 * train.rms);
  EXPECT_NE(v.diagnosis.warning.find("scaled by 1000"), std::string::npos) << v.diagnosis.warning;
  EXPECT_TRUE(v.diagnosis.map_named);
  ASSERT_LE(m.r2, 0.0);  // the model's output barely moves over 0..0.006
  EXPECT_TRUE(v.useless);
  EXPECT_NE(v.useless_warning.find("the evaluation is useless: the model predicts r.csv (samples 0..2401: "),
            std::string::npos)
      << v.useless_warning;
  // no training error (a hand-made model file): nothing to compare with, never useless
  FitMetrics unknown;
  unknown.rms = unknown.r2 = std::nan("");
  const auto [m2, v2] = judge(mpa, unknown);
  EXPECT_FALSE(v2.useless);
  EXPECT_TRUE(v2.useless_warning.empty());
}

// A record whose output differs from the model's by a sign, a unit or a zero (audit of 2026-11-30:
// a Festo model scored on test9 with its force negated gave R^2 -8.4 with nothing saying why):
// output_map gives the least-squares y ~ gain * prediction + offset, and the warning names a
// flipped sign, or a scale or zero, where the map explains what the prediction does not. The
// model's own output, or with noise, gets none; a constant output no map.
TEST(IdentifyInput, OutputMapNamesASignAUnitOrAZero) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const ModelParams model = true_gpi();
  const auto y = simulate_record(model, x);
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  const double span = *hi - *lo;
  const auto mapped = [&](double a, double b) {
    std::vector<double> v(y);
    for (double& e : v) e = a * e + b;
    return v;
  };
  const auto expect_map = [&](const std::vector<double>& v, double a, double b, const char* words) {
    const OutputMap m = output_map(model, x, v);
    EXPECT_NEAR(m.gain, a, 1e-9 * std::abs(a)) << words;
    EXPECT_NEAR(m.offset, b, 1e-9 * (std::abs(b) + span * std::abs(a))) << words;
    EXPECT_NEAR(m.r2_mapped, 1.0, 1e-12) << words;
    EXPECT_NEAR(m.rms_mapped, 0.0, 1e-9 * span * std::abs(a)) << words;
    const std::string w = output_map_warning(m, "rec.csv");
    if (*words == '\0') {
      EXPECT_TRUE(w.empty()) << w;
    } else {
      EXPECT_EQ(w.rfind("rec.csv: the record's output matches", 0), 0u) << w;
      EXPECT_NE(w.find(words), std::string::npos) << w;
    }
  };
  expect_map(y, 1.0, 0.0, "");
  expect_map(mapped(-1.0, 0.0), -1.0, 0.0, "is its sign flipped");  // R^2 far below 0
  expect_map(mapped(1000.0, 0.0), 1000.0, 0.0, "by a scale (another unit");
  expect_map(mapped(1.0, 0.3 * span), 1.0, 0.3 * span, "or a zero (a sensor offset)");  // R^2 still 0.9 or so
  expect_map(mapped(1.0, 0.005 * span), 1.0, 0.005 * span, "");  // within 1 % of the span: no warning
  {  // the prediction's own R^2 and RMS, against the definitions
    const auto v = mapped(1.0, 0.3 * span);
    const OutputMap m = output_map(model, x, v);
    EXPECT_NEAR(m.rms, 0.3 * span, 1e-9 * span);
    double mean = 0.0, var = 0.0;
    for (double e : v) mean += e / static_cast<double>(v.size());
    for (double e : v) var += (e - mean) * (e - mean);
    EXPECT_NEAR(m.r2, 1.0 - static_cast<double>(v.size()) * 0.09 * span * span / var, 1e-9);
    EXPECT_DOUBLE_EQ(m.span, span);
  }
  // noise: the map explains no more than the prediction does
  const auto noisy = with_noise(y, 0.02 * span, 5);
  EXPECT_TRUE(output_map_warning(output_map(model, x, noisy), "rec.csv").empty());
  // a constant output: no map, no warning
  const OutputMap flat = output_map(model, x, std::vector<double>(x.size(), 3.0));
  EXPECT_TRUE(std::isnan(flat.gain));
  EXPECT_TRUE(output_map_warning(flat, "rec.csv").empty());
  // the range: scored only there
  const OutputMap part = output_map(model, x, mapped(-2.0, 1.0), {100, 700});
  EXPECT_NEAR(part.gain, -2.0, 1e-9);
  // an output that clips (a sensor's limit at its lower third): scored as censored, as evaluate and fit
  // score it, the map leaves the censored samples out and finds nothing to say; as recorded, the flat
  // stretch is a scale and a zero (review of 2026-11-30: the warning quoted an RMS 65 times the score's)
  std::vector<double> sorted(y);
  std::sort(sorted.begin(), sorted.end());
  int warned_as_recorded = 0;
  for (const double fraction : {0.33, 0.5, 0.67, 0.8}) {
    const double limit = sorted[static_cast<std::size_t>(fraction * static_cast<double>(sorted.size()))];
    std::vector<double> clipped = with_noise(y, 0.002 * span, 7);
    for (double& v : clipped) v = std::max(v, limit);
    std::size_t censored = 0;
    (void)evaluate_censored(model, x, clipped, {}, InitialState::virgin, &censored);
    ASSERT_GT(censored, x.size() / 10) << fraction;
    const std::string w = output_map_warning(output_map(model, x, clipped, {}, InitialState::virgin, true), "rec.csv");
    EXPECT_TRUE(w.empty()) << fraction << ": " << w;
    warned_as_recorded += !output_map_warning(output_map(model, x, clipped), "rec.csv").empty();
  }
  EXPECT_GT(warned_as_recorded, 0);  // the case the censoring is for
}

TEST(IdentifyInput, HuberLossResistsOutliers) {
  const auto x = decaying_triangle({6, 5, 4, 3, 2, 1}, 200);
  const auto clean = simulate_record(true_gpi(), x);
  auto y = with_noise(clean, 0.005, 13);
  for (std::size_t k = 50; k < y.size(); k += 97) y[k] += 1.0;  // gross outliers
  FitOptions o;
  const FitReport plain = fit(x, y, o);
  o.huber_delta = 0.02;
  const FitReport robust = fit(x, y, o);
  ASSERT_TRUE(robust.status == FitStatus::converged || robust.status == FitStatus::no_convergence);
  const FitMetrics e_plain = evaluate(plain.model, x, clean), e_robust = evaluate(robust.model, x, clean);
  EXPECT_LT(e_robust.rms, e_plain.rms);
}

TEST(IdentifyRealData, FestoForcePressureValidates) {
  const auto dir = shared_data() / "pam-force-pressure";
  if (!std::filesystem::exists(dir / "festo10mm_20cm_test8.csv"))
    GTEST_SKIP() << "measured data not found at " << dir << " (../shared/data is absent in this checkout)";
  const auto train = read_csv(dir / "festo10mm_20cm_test8.csv");
  const auto val = read_csv(dir / "festo10mm_20cm_test9.csv");
  FitOptions o;
  o.model = FitModel::gpi;
  const FitReport r = fit(train[1], train[0], o);
  ASSERT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << r.full_report();
  const FitMetrics v = evaluate(r.model, val[1], val[0]);
  EXPECT_LT(v.rms_percent_span, 5.0) << r.full_report();
  EXPECT_NO_THROW(Inverse inv(r.model));
}

// A record of exact repeats (Festo test8, every 5th sample, 10 times over): every data-derived
// start of the gpi fit left its play operators unused and LM stopped on that plateau after 4
// iterations, `converged` at 4.23 N RMS without a word. The lost loops are detected and the
// fit is repeated from jittered starts (seed 1), whose model has the record's loops.
TEST(IdentifyRealData, AGpiFitThatLostItsLoopsIsRefittedFromJitteredStarts) {
  const auto dir = shared_data() / "pam-force-pressure";
  if (!std::filesystem::exists(dir / "festo10mm_20cm_test8.csv"))
    GTEST_SKIP() << "measured data not found at " << dir << " (../shared/data is absent in this checkout)";
  const auto rec = read_csv(dir / "festo10mm_20cm_test8.csv");
  std::vector<double> x, y;
  for (int t = 0; t < 10; ++t)
    for (std::size_t k = 0; k < rec[1].size(); k += 5) x.push_back(rec[1][k]), y.push_back(rec[0][k]);
  FitOptions o;
  o.model = FitModel::gpi;
  o.num_starts = 1;
  o.num_threads = 1;
  const FitReport r = fit(x, y, o);
  ASSERT_TRUE(has_model(r.status)) << r.full_report();
  const auto has = [&](const char* what) {
    return std::any_of(r.warnings.begin(), r.warnings.end(),
                       [&](const std::string& w) { return w.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(has("refitted from jittered starts (seed 1)")) << r.full_report();
  EXPECT_FALSE(has("enclose almost none of the record's loop area")) << r.full_report();
  // jittered starts by hand give the same model
  o.seed = 1;
  EXPECT_EQ(fit(x, y, o).train.rms, r.train.rms);
}

// The README's claim on measured data: the GPI (free-weight variant) and the dead-zone
// MPI validate better than the classical PI on the piezo record (every 2nd sample;
// fit on the second to fourth sine periods, validate on the rest, as
// bench/real_data_table.sh does on the full record).
TEST(IdentifyRealData, PiezoGpiAndMpiBeatPiOnValidation) {
  const auto file = shared_data() / "piezo-sine" / "piezo_150V_1Hz.csv";
  if (!std::filesystem::exists(file))
    GTEST_SKIP() << "measured data not found at " << file << " (../shared/data is absent in this checkout)";
  const auto cols = read_csv(file);
  std::vector<double> x, y;
  for (std::size_t k = 0; k < cols[3].size(); k += 2) x.push_back(cols[3][k]), y.push_back(cols[2][k]);
  const IndexRange train{21286 / 2, 33143 / 2}, val{33143 / 2, x.size()};
  auto validate = [&](FitModel m, bool free_weights) {
    FitOptions o;
    o.model = m;
    o.train = train;
    o.gpi_free_weights = free_weights;
    o.compute_covariance = false;
    const FitReport r = fit(x, y, o);
    EXPECT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << r.full_report();
    return evaluate(r.model, x, y, val).rms_percent_span;
  };
  const double pi = validate(FitModel::pi, false);
  const double gpi_free = validate(FitModel::gpi, true);
  const double dz = validate(FitModel::mpi_deadzone, false);
  EXPECT_LT(gpi_free, 0.8 * pi) << "gpi (free weights) " << gpi_free << " % vs pi " << pi << " %";
  // The dead zones do not help on this record (no saturation): the fit keeps the PI
  // it contains (fit_api.cpp), so mpi-deadzone is never worse than pi.
  EXPECT_LE(dz, pi * (1 + 1e-9)) << "mpi-deadzone " << dz << " % vs pi " << pi << " %";
}

// A sensor that clips reads its limit for everything beyond it; a sensor that sees a rest on
// a stop at its own zero clamps only the noise's negative half. detect_clipping tells them
// apart by the share of the samples near the least reading that are exactly it, and fit()
// warns on the first only.
TEST(Clipping, SensorLimitIsFlaggedRestOnAStopIsNot) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  const std::size_t n = 20000;
  std::vector<double> x(n), clipped(n), rest(n), topped(n), clean(n);
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = 0.5 - 0.5 * std::cos(2.0 * M_PI * 0.5 * 1e-3 * static_cast<double>(k));
    const double e = noise(rng);
    clipped[k] = std::max(0.0, 10.0 * (x[k] - 0.3) + e);                  // zeroed 3 units above the stop
    rest[k] = std::max(0.0, std::max(0.0, 10.0 * (x[k] - 0.3)) + e);      // the stop at the sensor's zero
    topped[k] = std::min(5.0, 10.0 * x[k] + e);                           // range ends inside the stroke
    clean[k] = std::max(0.0, 10.0 * (x[k] - 0.3));                        // a stop without noise
  }
  const Clipping c = detect_clipping(clipped);
  EXPECT_TRUE(c.low);
  EXPECT_FALSE(c.high);
  EXPECT_EQ(c.lo, 0.0);
  EXPECT_NEAR(c.sigma, 0.01, 0.002);  // the noise off the clipped stretches
  EXPECT_GT(c.low_share, 0.95);
  const Clipping r = detect_clipping(rest);
  EXPECT_FALSE(r.any()) << r.low_share;
  EXPECT_GT(r.low_share, 0.4);  // about half: the noise's negative half clamped
  EXPECT_LT(r.low_share, 0.75);
  const Clipping t = detect_clipping(topped);
  EXPECT_TRUE(t.high);
  EXPECT_FALSE(t.low);
  EXPECT_EQ(t.hi, 5.0);
  EXPECT_TRUE(detect_clipping(clean).low) << "a stop without noise cannot be told from a limit";
  EXPECT_FALSE(detect_clipping(std::vector<double>(50, 0.0)).any());

  FitOptions o;
  o.model = FitModel::pi;
  o.num_operators = 5;
  auto warned = [](const FitReport& rep) {
    for (const auto& w : rep.warnings)
      if (w.find("sits at its least reading") != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(warned(fit(x, clipped, o)));
  EXPECT_FALSE(warned(fit(x, rest, o)));
}

// A decaying oscillation x (n samples, `cycles` periods, its amplitude falling by `decay`) and
// a PI model (6 operators) fitted to the curve 10 x^2 + 2 x on it: a hysteretic "truth".
struct CurvedTruth {
  std::vector<double> x, curved;
  FitReport pi;
};
CurvedTruth curved_truth(std::size_t n, double cycles, double decay) {
  CurvedTruth c;
  c.x.resize(n);
  c.curved.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(n);
    c.x[k] = 0.5 + 0.5 * (1.0 - decay * t) * std::sin(2.0 * M_PI * cycles * t);
    c.curved[k] = 10.0 * c.x[k] * c.x[k] + 2.0 * c.x[k];
  }
  FitOptions o;
  o.model = FitModel::pi;
  o.num_operators = 6;
  c.pi = fit(c.x, c.curved, o);
  return c;
}

// A record clipped by its sensor is fitted as censored data (FitOptions::censor_passes): the
// clipped samples only say the output is at or below the limit, so the model is no longer
// pulled onto the limit, and it follows the true output better where the sensor sees it and
// where it does not. The truth is a hysteretic model (a PI fitted to a curved record) driven
// by a decaying oscillation; the sensor reads max(truth + noise, c), c its 30th percentile.
TEST(Clipping, ClippedOutputIsFittedAsCensored) {
  const std::size_t n = 12000;
  const CurvedTruth ct = curved_truth(n, 6.0, 0.8);
  const std::vector<double>& x = ct.x;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.01);
  FitOptions o;
  const FitReport& truth_fit = ct.pi;
  ASSERT_TRUE(has_model(truth_fit.status)) << truth_fit.message;
  const std::vector<double> truth = simulate_record(truth_fit.model, x);
  std::vector<double> sorted = truth;
  std::sort(sorted.begin(), sorted.end());
  const double c = sorted[n * 3 / 10];
  std::vector<double> y(n);
  for (std::size_t k = 0; k < n; ++k) y[k] = std::max(truth[k] + noise(rng), c);
  ASSERT_TRUE(detect_clipping(y).low);

  o.model = FitModel::mpi_asym;
  o.num_operators = 6;
  FitOptions plain = o;
  plain.censor_passes = 0;
  const FitReport as_recorded = fit(x, y, plain), censored = fit(x, y, o);
  ASSERT_TRUE(has_model(as_recorded.status)) << as_recorded.message;
  ASSERT_TRUE(has_model(censored.status)) << censored.message;
  auto says = [](const FitReport& r, const std::string& what) {
    for (const auto& w : r.warnings)
      if (w.find(what) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(says(as_recorded, "fitted to the limit there"));
  EXPECT_TRUE(says(censored, "fitted as censored data (2 refit(s)"));
  // RMS against the truth where the sensor sees it (3 noise widths above the limit) and below it
  auto rms_vs_truth = [&](const FitReport& r, bool seen) {
    const std::vector<double> p = simulate_record(r.model, x);
    double s2 = 0.0;
    std::size_t m = 0;
    for (std::size_t k = 0; k < n; ++k)
      if ((truth[k] > c + 0.03) == seen && (seen || truth[k] < c)) s2 += (p[k] - truth[k]) * (p[k] - truth[k]), ++m;
    return std::sqrt(s2 / static_cast<double>(m));
  };
  const double seen_plain = rms_vs_truth(as_recorded, true), seen_cens = rms_vs_truth(censored, true);
  const double hidden_plain = rms_vs_truth(as_recorded, false), hidden_cens = rms_vs_truth(censored, false);
  // where the sensor sees it the censored fit is closer to the truth (0.086 vs 0.093 mm with 2
  // passes; 0.077 with 10: the refits converge slowly; 0.063 fitted on the unclipped record),
  // and it is not worse below the limit, where neither extrapolates well (1.90 vs 1.96)
  EXPECT_LT(seen_cens, 0.95 * seen_plain) << seen_cens << " vs " << seen_plain;
  EXPECT_LT(hidden_cens, hidden_plain) << hidden_cens << " vs " << hidden_plain;
  // the censored record's metrics: no error where the model predicts beyond the limit
  std::size_t replaced = 0;
  const std::vector<double> yc = censored_output(y, simulate_record(censored.model, x), detect_clipping(y), &replaced);
  EXPECT_GT(replaced, n / 10);
  EXPECT_NEAR(evaluate(censored.model, x, yc).rms, censored.train.rms, 0.2 * censored.train.rms);
  EXPECT_THROW(censored_output(y, std::vector<double>(n - 1, 0.0), detect_clipping(y)), Error);
  EXPECT_LT(censored.train.rms, as_recorded.train.rms);

  // an unclipped record: the passes change nothing
  std::vector<double> seen_only(n);
  for (std::size_t k = 0; k < n; ++k) seen_only[k] = truth[k] + noise(rng);
  ASSERT_FALSE(detect_clipping(seen_only).any());
  const FitReport a = fit(x, seen_only, plain), b = fit(x, seen_only, o);
  ASSERT_EQ(a.parameters.size(), b.parameters.size());
  for (std::size_t i = 0; i < a.parameters.size(); ++i) EXPECT_EQ(a.parameters[i].value, b.parameters[i].value);
  EXPECT_FALSE(says(b, "censored"));
}

// evaluate_censored: on a record whose output clips, a sample at the limit where the model
// predicts beyond it counts no error (computed here sample by sample); the other samples
// count as in evaluate(); on a record that does not clip it equals evaluate().
TEST(Clipping, EvaluateCensoredScoresAClippedRecordAsTheFitDoes) {
  const std::size_t n = 4000;
  const CurvedTruth ct = curved_truth(n, 4.0, 0.6);
  const std::vector<double>&x = ct.x, &curved = ct.curved;
  const FitReport& r = ct.pi;
  ASSERT_TRUE(has_model(r.status)) << r.message;
  const std::vector<double> pred = simulate_record(r.model, x);
  // the "measured" output: the curve 0.3 high with noise, clipped at its 25th percentile
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<double> y(n);
  for (std::size_t k = 0; k < n; ++k) y[k] = curved[k] + 0.3 + noise(rng);
  std::vector<double> sorted = y;
  std::sort(sorted.begin(), sorted.end());
  const double c = sorted[n / 4];
  std::vector<double> clipped(n);
  for (std::size_t k = 0; k < n; ++k) clipped[k] = std::max(y[k], c);
  ASSERT_TRUE(detect_clipping(clipped).low);
  const IndexRange range{n / 8, n - n / 8};
  double s2 = 0.0;
  std::size_t at_limit = 0;
  for (std::size_t k = range.begin; k < range.end; ++k) {
    const bool no_error = clipped[k] == c && pred[k] < c;
    at_limit += no_error ? 1 : 0;
    const double e = no_error ? 0.0 : clipped[k] - pred[k];
    s2 += e * e;
  }
  ASSERT_GT(at_limit, n / 20);
  std::size_t censored = 0;
  const FitMetrics m = evaluate_censored(r.model, x, clipped, range, InitialState::virgin, &censored);
  EXPECT_EQ(censored, at_limit);
  EXPECT_EQ(m.n, range.end - range.begin);
  EXPECT_NEAR(m.rms, std::sqrt(s2 / static_cast<double>(m.n)), 1e-12);
  EXPECT_LT(m.rms, evaluate(r.model, x, clipped, range).rms);
  // a record that does not clip: exactly evaluate(), nothing censored
  ASSERT_FALSE(detect_clipping(y).any());
  const FitMetrics plain = evaluate(r.model, x, y, range), same = evaluate_censored(r.model, x, y, range, InitialState::virgin, &censored);
  EXPECT_EQ(censored, 0u);
  EXPECT_EQ(same.rms, plain.rms);
  EXPECT_EQ(same.max, plain.max);
  EXPECT_THROW(evaluate_censored(r.model, x, std::vector<double>(n - 1, 0.0)), Error);
  // evaluate_scored: the one censored-or-as-recorded choice of the CLI, the reports and Python
  std::size_t scored = 99;
  EXPECT_EQ(evaluate_scored(r.model, x, clipped, range, InitialState::virgin, true, &scored).rms, m.rms);
  EXPECT_EQ(scored, at_limit);
  EXPECT_EQ(evaluate_scored(r.model, x, clipped, range, InitialState::virgin, false, &scored).rms,
            evaluate(r.model, x, clipped, range).rms);
  EXPECT_EQ(scored, 0u);
  // censor_clipped: censored_output where the detection range clips, y unchanged where it does not
  std::size_t replaced = 99;
  EXPECT_EQ(censor_clipped(clipped, pred, {}, &replaced), censored_output(clipped, pred, detect_clipping(clipped)));
  EXPECT_GT(replaced, at_limit);  // the whole record, not only the scored range
  bool unclipped_stretch = false;
  for (std::size_t k = 0; k < n && !unclipped_stretch; ++k)
    if (clipped[k] > c + 1.0) {  // a stretch well above the limit: nothing clips there
      std::size_t e = k;
      while (e < n && clipped[e] > c + 1.0) ++e;
      if (e - k >= 200) {
        EXPECT_EQ(censor_clipped(clipped, pred, {k, e}, &replaced), clipped);
        EXPECT_EQ(replaced, 0u);
        unclipped_stretch = true;
      }
      k = e;
    }
  EXPECT_TRUE(unclipped_stretch);
  EXPECT_THROW(censor_clipped(y, std::vector<double>(n - 1, 0.0)), Error);
  EXPECT_THROW(censor_clipped(y, pred, {0, n + 1}), Error);
}

// Mutation testing of the verdicts (2026-12-01): each threshold below is the documented one
// (identify.hpp), checked on both sides with inputs built by hand, not read back from the code.

// input_coverage_warning: "more than 1 % of its samples outside" (identify.hpp).
TEST(IdentifyVerdicts, CoverageWarningAboveOnePercentOutside) {
  InputCoverage c;
  c.limits = {0.0, 1.0};
  c.n = 1000;
  c.max_beyond = 0.5;
  for (const auto& [outside, warns] : {std::pair<std::size_t, bool>{0, false}, {10, false}, {11, true}, {20, true},
                                       {150, true}}) {
    c.outside = outside;
    EXPECT_EQ(!input_coverage_warning(c, "rec.csv").empty(), warns) << outside << " of 1000 outside";
  }
}

// validation_useless: R^2 <= 0 AND an RMS error more than kValidationRmsFactor (2) times the
// training one; each condition alone is not enough.
TEST(IdentifyVerdicts, UselessNeedsRSquaredAtMostZeroAndMoreThanTwiceTheTrainingRms) {
  FitMetrics train, v;
  train.rms = 1.0;
  train.r2 = 0.99;
  const auto useless = [&](double r2, double rms) {
    v.r2 = r2;
    v.rms = rms;
    return validation_useless(v, train);
  };
  EXPECT_TRUE(useless(0.0, 3.0));
  EXPECT_TRUE(useless(-5.0, 2.01));
  EXPECT_FALSE(useless(0.3, 3.0));   // explains 30 % of the variance: poor, not useless
  EXPECT_FALSE(useless(0.01, 100.0));
  EXPECT_FALSE(useless(-5.0, 2.0));  // exactly twice: not more than
  EXPECT_FALSE(useless(-5.0, 1.5));
}

// output_map_warning with the training RMS given: a prediction of R^2 below kMinFitR2 (0.5) whose
// RMS error is more than twice the training one gets the plain warning even where no map helps;
// one within twice the training RMS gets none, whatever its R^2 (a quiet stretch).
TEST(IdentifyVerdicts, OutputMapWarningBelowHalfRSquaredAndOnlyBeyondTwiceTheTrainingRms) {
  OutputMap m;
  m.gain = 0.8, m.offset = 0.1, m.span = 100.0;
  m.r2 = 0.3, m.r2_mapped = 0.32;  // poor, and no map explains it
  m.rms = 10.0, m.rms_mapped = 9.5;  // the map does not halve the error
  const double train_r2 = 0.99, train_rms = 1.0;
  const std::string w = output_map_warning(m, "v.csv", train_r2, train_rms);
  EXPECT_EQ(w.rfind("v.csv: the model's prediction scores R^2 0.3 ", 0), 0u) << w;
  EXPECT_FALSE(output_map_names(m, train_r2, train_rms));
  // the same R^2 at 1.5x the training RMS error: the model describes the record as well as its own
  m.rms = 1.5, m.rms_mapped = 1.45;
  EXPECT_TRUE(output_map_warning(m, "v.csv", train_r2, train_rms).empty())
      << output_map_warning(m, "v.csv", train_r2, train_rms);
  m.r2 = -0.5, m.r2_mapped = 0.1;
  EXPECT_TRUE(output_map_warning(m, "v.csv", train_r2, train_rms).empty())
      << output_map_warning(m, "v.csv", train_r2, train_rms);
}

// detect_clipping: "Of the samples within 3 sigma of the least reading, the share exactly at it
// ... Clipped above 3/4 with at least 50 samples at the limit" (identify.hpp). A noisy signal well
// above 0 and a stretch of 100 samples near 0, 60 of them exactly at 0 (share 0.6): not clipped;
// 90 of them (share 0.9): clipped.
TEST(IdentifyVerdicts, ClippedOnlyAboveThreeQuartersOfTheSamplesNearTheLimit) {
  for (const auto& [at, clipped] : {std::pair<std::size_t, bool>{60, false}, {90, true}}) {
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.01);
    std::vector<double> y;
    for (int k = 0; k < 1000; ++k) y.push_back(0.5 + 0.4 * std::sin(2.0 * M_PI * k / 250.0) + noise(rng));
    // the stretch at the bottom: `at` samples at 0, the others 0.005..0.0075 (within 3 noise widths of it)
    for (std::size_t k = 0; k < 100; ++k) y.push_back(k % 10 < at / 10 ? 0.0 : 0.005 + 0.00025 * static_cast<double>(k % 10));
    for (int k = 0; k < 1000; ++k) y.push_back(0.5 + 0.4 * std::sin(2.0 * M_PI * k / 250.0) + noise(rng));
    const Clipping c = detect_clipping(y);
    ASSERT_EQ(c.lo, 0.0);
    ASSERT_GT(c.sigma, 0.005);  // the noise's 0.01, as estimated
    ASSERT_LT(c.sigma, 0.02);
    std::size_t near = 0, at_lo = 0;
    for (double v : y) near += v <= 3.0 * c.sigma, at_lo += v == 0.0;
    ASSERT_EQ(near, 100u);  // the sine's least value, 0.1 less its noise, lies beyond 3 sigma
    ASSERT_EQ(at_lo, at);
    EXPECT_EQ(c.low, clipped) << at << " of " << near << " at the least reading";
    EXPECT_DOUBLE_EQ(c.low_share, static_cast<double>(at) / 100.0);
    EXPECT_FALSE(c.high);
  }
}

// A long periodic record whose screening stride (training samples / 2500, starts.cpp's decimate)
// is a whole number of its periods: every strided sample has the same input, and the start
// screening of gpi and mpi-asym found "no usable start" (scale audit, 2026-12-02: a 42-minute
// 1 Hz sine at 1 kHz). The screening record keeps the reversals now, and the fits recover the truth.
TEST(IdentifyStarts, ALongPeriodicRecordWhoseStrideIsItsPeriodStillFits) {
  constexpr int period = 8;                       // samples per period of the input
  constexpr std::size_t m = 2500 * period;        // stride m / 2500 = one period
  const double amplitude[3] = {2.8, 1.8, 0.8};    // each for 10 periods, in turn: minor loops
  std::vector<double> x(m);
  for (std::size_t k = 0; k < m; ++k)
    x[k] = 3.0 + amplitude[(k / (10 * period)) % 3] * std::sin(2 * M_PI * static_cast<double>(k) / period);
  const GpiParams truth = true_gpi();
  const double sigma = 0.01;
  const auto y = with_noise(simulate_record(truth, x), sigma, 11);
  for (const FitModel kind : {FitModel::gpi, FitModel::mpi_asym}) {
    SCOPED_TRACE(std::string(fit_model_name(kind)));
    FitOptions o;
    o.model = kind;
    o.num_operators = 10;
    o.compute_covariance = false;
    o.mpi_asym_mirror = false;
    const FitReport r = fit(x, y, o);
    ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
    EXPECT_LT(r.train.rms, 3 * sigma) << r.full_report();  // noise 0.01 on an output span of about 4
  }
}
