// Identification of the kinds beyond the PI family: each recovers its own parameters
// from simulated data with noise (the truth built on the grid / thresholds the fit
// uses), and rate-pi predicts a rate it was not fitted on where the rate-independent
// pi cannot.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "hysteron/identify.hpp"
#include "hysteron/models.hpp"

using namespace hysteron;

namespace {

// A random walk in [0, 1] that starts at 0 and visits both ends first (so that the
// training range, and hence the fitted grid, is exactly [0, 1]).
std::vector<double> walk(unsigned seed, std::size_t n) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> len(5, 60);
  std::vector<double> x{0.0};
  for (int k = 1; k <= 50; ++k) x.push_back(k / 50.0);
  double cur = 1.0;
  while (x.size() < n) {
    const double t = u(rng);
    const int m = len(rng);
    for (int k = 1; k <= m && x.size() < n; ++k) x.push_back(cur + (t - cur) * k / m);
    cur = t;
  }
  return x;
}

std::vector<double> noisy(std::vector<double> y, double sd, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> e(0.0, sd);
  for (double& v : y) v += e(rng);
  return y;
}

FitOptions options(FitModel kind, int n) {
  FitOptions o;
  o.model = kind;
  o.num_operators = n;
  o.num_threads = 1;
  return o;
}

constexpr double kNoise = 1e-3;

// Prediction RMS of a fitted model on a fresh input against the noise-free truth.
double prediction_rms(const ModelParams& fitted, const ModelParams& truth, unsigned seed) {
  const auto x = walk(seed, 4000);
  return evaluate(fitted, x, simulate_record(truth, x)).rms;
}

template <class G>
void grid_recovers(FitModel kind) {
  G truth;
  truth.levels = 6;
  truth.lo = 0.0;
  truth.hi = 1.0;
  truth.q = 0.3;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  truth.w.resize(21);
  for (double& v : truth.w) v = u(rng) < 0.3 ? 0.0 : 0.1 * u(rng);
  const auto x = walk(1, 20000);
  const auto y = noisy(simulate_record(truth, x), kNoise, 2);
  const FitReport r = fit(x, y, options(kind, truth.levels));
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  const auto& g = std::get<G>(r.model);
  ASSERT_EQ(g.levels, truth.levels);
  EXPECT_NEAR(g.lo, 0.0, 1e-12);
  EXPECT_NEAR(g.hi, 1.0, 1e-12);
  EXPECT_NEAR(g.q, truth.q, 0.02);
  // every row but the top one: its relays (alpha = the record's maximum) switch on only
  // where the input reaches its maximum (once here), so their weights are barely
  // identified; they still enter the prediction check
  for (std::size_t k = 0; k < truth.w.size() - static_cast<std::size_t>(truth.levels); ++k)
    EXPECT_NEAR(g.w[k], truth.w[k], 0.01) << "w[" << k << "]";
  // (the top row's split between its relays shows on a fresh record that reaches the
  // maximum again: preisach predicts to 3.3 noise levels here, kp to under 2)
  EXPECT_LT(prediction_rms(r.model, truth, 9), 4 * kNoise);
}

}  // namespace

TEST(KindsFit, PreisachRecoversItsWeights) { grid_recovers<PreisachParams>(FitModel::preisach); }
TEST(KindsFit, KpRecoversItsWeights) { grid_recovers<KpParams>(FitModel::kp); }

TEST(KindsFit, MaxwellSlipRecoversItsStiffnesses) {
  const auto x = walk(4, 20000);
  MaxwellSlipParams truth;
  truth.k0 = 0.4;
  truth.delta = default_thresholds(x, 6);
  truth.k = {0.3, 0.0, 0.5, 0.2, 0.1};
  ASSERT_EQ(truth.delta.size(), truth.k.size());
  const auto y = noisy(simulate_record(truth, x), kNoise, 5);
  const FitReport r = fit(x, y, options(FitModel::maxwell_slip, 6));
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  const auto& m = std::get<MaxwellSlipParams>(r.model);
  EXPECT_NEAR(m.k0, truth.k0, 0.01);
  for (std::size_t i = 0; i < truth.k.size(); ++i) EXPECT_NEAR(m.k[i], truth.k[i], 0.01) << "k[" << i << "]";
  EXPECT_LT(prediction_rms(r.model, truth, 9), 2 * kNoise);
}

TEST(KindsFit, BoucWenRecoversItsParameters) {
  // counterclockwise loops (kw < 0), invertible: kx + kw rho max(1, 2 sigma) = 0.6 > 0
  const BoucWenParams truth{1.0, -0.05, 4.0, 1.0, 1.5, {}, {}};
  const auto x = walk(6, 8000);
  const auto y = noisy(simulate_record(truth, x), kNoise, 7);
  const FitReport r = fit(x, y, options(FitModel::bouc_wen, 10));
  ASSERT_EQ(r.status, FitStatus::converged) << r.full_report();
  const auto& b = std::get<BoucWenParams>(r.model);
  EXPECT_NEAR(b.kx, truth.kx, 0.05 * truth.kx) << r.full_report();
  EXPECT_NEAR(b.kw, truth.kw, 0.1 * std::abs(truth.kw)) << r.full_report();
  EXPECT_NEAR(b.rho, truth.rho, 0.1 * truth.rho) << r.full_report();
  EXPECT_NEAR(b.sigma, truth.sigma, 0.2 * truth.sigma) << r.full_report();
  EXPECT_NEAR(b.n, truth.n, 0.2 * truth.n) << r.full_report();
  EXPECT_LT(prediction_rms(r.model, truth, 9), 2 * kNoise);
}

// Sines of one amplitude at several rates from a rate-dependent truth: fitted on 0.2 and
// 3 Hz, the rate-pi predicts 1 Hz better than the rate-independent pi by a wide margin.
TEST(KindsFit, RatePiPredictsAnUnseenRateWherePiCannot) {
  const double dt = 1e-3;
  RatePiParams truth;
  truth.q = 0.3;
  truth.r = {0.1, 0.2, 0.3, 0.4};
  truth.p = {0.4, 0.3, 0.2, 0.1};
  truth.tau = 0.1;
  truth.dt = dt;
  truth.c = 0.12;  // c max(r) = 0.048 <= (tau + dt) / 2
  auto sine = [&](double hz, double periods) {
    std::vector<double> x;
    for (int k = 0; k < static_cast<int>(periods / (hz * dt)); ++k) x.push_back(std::sin(2 * M_PI * hz * k * dt));
    return x;
  };
  std::vector<double> train = sine(0.2, 2), fast = sine(3.0, 12), val = sine(1.0, 4);
  train.insert(train.end(), fast.begin(), fast.end());
  const auto y = noisy(simulate_record(truth, train), kNoise, 11);
  FitOptions o = options(FitModel::rate_pi, 8);
  o.sample_time = dt;
  const FitReport rr = fit(train, y, o);
  ASSERT_EQ(rr.status, FitStatus::converged) << rr.full_report();
  EXPECT_GT(std::get<RatePiParams>(rr.model).c, 0.0);
  const FitReport rp = fit(train, y, options(FitModel::pi, 8));
  ASSERT_TRUE(has_model(rp.status)) << rp.full_report();
  const auto yv = simulate_record(truth, val);
  const double e_rate = evaluate(rr.model, val, yv).rms, e_pi = evaluate(rp.model, val, yv).rms;
  EXPECT_LT(e_rate, 0.5 * e_pi) << "rate-pi " << e_rate << " vs pi " << e_pi;
  // without a sample time rate-pi is refused with the reason
  const FitReport none = fit(train, y, options(FitModel::rate_pi, 8));
  EXPECT_EQ(none.status, FitStatus::invalid_input);
  EXPECT_NE(none.message.find("sample time"), std::string::npos) << none.message;
  // named as every front end's user gives it: sample_time (Python's sample_time=, MATLAB's 'sample_time'),
  // the CLI's options in parentheses; not a C++ member (before: "--sample-time (FitOptions::sample_time)")
  EXPECT_NE(none.message.find("give sample_time"), std::string::npos) << none.message;
  EXPECT_EQ(none.message.find("FitOptions::"), std::string::npos) << none.message;
}

// The linear kinds' least squares use a subset of the rows of a long record (one per block,
// FitOptions::max_ls_rows). Rows at a fixed position in each block aliased with a periodic
// input: a dither of period 4 with blocks of 4 samples put every row at one phase of it, and
// kp (which cannot follow the PI that made the record exactly) fitted that phase only.
TEST(KindsFit, RowSubsetDoesNotAliasWithAPeriodicInput) {
  PiParams truth;
  truth.q = 0.5;
  for (int i = 0; i < 10; ++i) {
    truth.r.push_back(0.04 * i);
    truth.p.push_back(0.3 * std::exp(-0.16 * i));
  }
  const int n = 24000;
  std::vector<double> x(n);
  for (int k = 0; k < n; ++k)
    x[static_cast<std::size_t>(k)] = 0.5 + 0.4 * std::sin(2 * M_PI * k / 5000.0) * std::exp(-double(k) / n) +
                                     (k % 4 < 2 ? 0.1 : -0.1);
  const auto y = simulate_record(truth, x);
  auto rms = [&](std::size_t rows) {
    FitOptions o = options(FitModel::kp, 10);
    o.max_ls_rows = rows;
    const FitReport r = fit(x, y, o);
    EXPECT_NE(r.status, FitStatus::failed) << r.full_report();
    return evaluate(r.model, x, y).rms;
  };
  const double all = rms(0), subset = rms(6000);  // blocks of 4 samples, the dither's period
  EXPECT_LT(subset, 1.25 * all) << "all rows " << all << ", one in four " << subset;
}
