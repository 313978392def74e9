// Issue 13 item 4: records scaled to 1e-300 or 1e300 fit like unit-scaled ones
// (or are refused), and a fit that never moved from its start is not "converged".
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hysteron/identify.hpp"
#include "hysteron/models.hpp"

using namespace hysteron;

namespace {

struct Record {
  std::vector<double> x, y;
};

// A decaying sine through a PI with four plays: a record with real hysteresis.
Record pi_record() {
  PiParams truth;
  truth.q = 0.5;
  truth.r = {0.05, 0.1, 0.2, 0.3};
  truth.p = {0.4, 0.3, 0.2, 0.1};
  Model model(truth);
  Record r;
  for (int k = 0; k < 3000; ++k) {
    const double t = 0.004 * k;
    r.x.push_back(0.5 + 0.45 * std::sin(2.0 * t) * std::exp(-0.08 * t));
    r.y.push_back(model.step(r.x.back()) + 0.002 * std::sin(37.0 * t));
  }
  return r;
}

Record scaled(const Record& r, double sx, double sy) {
  Record s = r;
  for (double& v : s.x) v *= sx;
  for (double& v : s.y) v *= sy;
  return s;
}

}  // namespace

TEST(Degenerate, TinyAndHugeRecordsFitLikeUnitOnes) {
  const Record unit = pi_record();
  for (FitModel kind : {FitModel::pi, FitModel::gpi}) {
    FitOptions o;
    o.model = kind;
    const FitReport ref = fit(unit.x, unit.y, o);
    ASSERT_TRUE(has_model(ref.status)) << fit_model_name(kind) << ": " << ref.message;
    for (double s : {1e-300, 1e-150, 1e150, 1e300}) {
      const Record r = scaled(unit, s, s);
      const FitReport rep = fit(r.x, r.y, o);
      SCOPED_TRACE(::testing::Message() << fit_model_name(kind) << " scale " << s);
      EXPECT_EQ(rep.status, ref.status) << rep.message;
      ASSERT_TRUE(std::isfinite(rep.train.rms) && std::isfinite(rep.train.r2)) << rep.train.rms << " " << rep.train.r2;
      EXPECT_NEAR(rep.train.rms_percent_span, ref.train.rms_percent_span, 1e-3 * ref.train.rms_percent_span);
      EXPECT_NEAR(rep.train.r2, ref.train.r2, 1e-6);
      EXPECT_NEAR(rep.train.rms / s, ref.train.rms, 1e-3 * ref.train.rms);
    }
  }
}

TEST(Degenerate, MetricsDoNotUnderflowOrOverflow) {
  const std::vector<double> y = {1.0, 2.0, 4.0, 3.0}, p = {1.5, 2.0, 3.0, 3.5};
  const FitMetrics ref = compute_metrics(y, p);
  for (double s : {1e-305, 1e305}) {
    std::vector<double> ys = y, ps = p;
    for (double& v : ys) v *= s;
    for (double& v : ps) v *= s;
    const FitMetrics m = compute_metrics(ys, ps);
    EXPECT_NEAR(m.rms / s, ref.rms, 1e-12 * ref.rms) << s;
    EXPECT_NEAR(m.mae / s, ref.mae, 1e-12 * ref.mae) << s;
    EXPECT_NEAR(m.r2, ref.r2, 1e-12) << s;
    EXPECT_NEAR(m.rms_percent_span, ref.rms_percent_span, 1e-12 * ref.rms_percent_span) << s;
  }
}

TEST(Degenerate, TinyHuberIsNotConvergedAtItsStart) {
  // --huber 1e-300 scaled the cost and its gradient below the solver's absolute
  // tolerance: "converged after 0 iterations", exit 0.
  const Record r = pi_record();
  FitOptions o;
  o.model = FitModel::gpi;
  o.huber_delta = 1e-300;
  const FitReport rep = fit(r.x, r.y, o);
  EXPECT_FALSE(rep.status == FitStatus::converged && rep.total_iterations == 0) << rep.message;
  EXPECT_GT(rep.total_iterations, 0) << rep.message;
  EXPECT_TRUE(std::isfinite(rep.train.rms));
}

// A record too short for a kind's parameters (10 samples each) is refused with the operator count
// that fits it: fitted with that count the same record is not refused, with one more it is.
TEST(Degenerate, TooShortARecordNamesTheOperatorCountThatFits) {
  Record r = pi_record();
  r.x.resize(140);  // 0.56 s of the decaying sine: one rise and part of the fall
  r.y.resize(140);
  for (const FitModel kind : {FitModel::preisach, FitModel::kp, FitModel::mpi_asym, FitModel::mpi_deadzone}) {
    SCOPED_TRACE(fit_model_name(kind));
    FitOptions o;
    o.model = kind;
    const FitReport rep = fit(r.x, r.y, o);
    ASSERT_EQ(rep.status, FitStatus::invalid_input) << rep.message;
    const auto at = rep.message.find("--n ");
    ASSERT_NE(at, std::string::npos) << rep.message;
    const int n = std::stoi(rep.message.substr(at + 4));
    ASSERT_GE(n, 1);
    ASSERT_LT(n, o.num_operators);
    o.num_operators = n;
    EXPECT_EQ(fit(r.x, r.y, o).message.find("too few"), std::string::npos) << "--n " << n;
    o.num_operators = n + 1;
    EXPECT_NE(fit(r.x, r.y, o).message.find("too few"), std::string::npos) << "--n " << n + 1;
  }
}

// compute_metrics on a record small enough to compute by hand: errors {0, 0, 0, -2} on an
// output {0, 1, 2, 3} (span 3, mean 1.5, SST 5): RMS 1, MAE 0.5, max 2, RMS 33.3 % of the span,
// R^2 = 1 - 4 / 5 = 0.2. A constant output has no variance to explain: R^2 NaN (its sum of squares
// about the mean is only rounding: 0.1 summed ten times is not 1).
TEST(Degenerate, MetricsOfAHandComputedRecordAndAConstantOne) {
  const FitMetrics m = compute_metrics(std::vector<double>{0, 1, 2, 3}, std::vector<double>{0, 1, 2, 5});
  EXPECT_EQ(m.n, 4u);
  EXPECT_DOUBLE_EQ(m.rms, 1.0);
  EXPECT_DOUBLE_EQ(m.mae, 0.5);
  EXPECT_DOUBLE_EQ(m.max, 2.0);
  EXPECT_DOUBLE_EQ(m.rms_percent_span, 100.0 / 3.0);
  EXPECT_NEAR(m.r2, 0.2, 1e-12);  // (the scaled sums round in the last bits)
  const std::vector<double> flat(10, 0.1), off(10, 0.2);
  const FitMetrics c = compute_metrics(flat, off);
  EXPECT_TRUE(std::isnan(c.r2)) << c.r2;
  EXPECT_TRUE(std::isnan(c.rms_percent_span)) << c.rms_percent_span;
  EXPECT_DOUBLE_EQ(c.rms, 0.1);
}
