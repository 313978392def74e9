// Iterative learning control (learning.hpp) and the learning variant of the experiments.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <variant>
#include <vector>

#include "alloc_counter.hpp"
#include "hysteron/error.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/io/results.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/loop_design.hpp"
#include "hysteron/report.hpp"
#include "hysteron/signals.hpp"
#include "hysteron/sweep.hpp"
#include "../src/experiment/detail.hpp"

using namespace hysteron;
using hysteron::test::error_of;
// The papers' actuator limit, the nominal rig's (the experiments' tuning functions take the run's).
constexpr double kPaperMax = experiment::kPaperPressureMax;
constexpr double kRelayLevel = experiment::relay_level(kPaperMax);

namespace {

// The regulator alone as the experiments' actuator, limited to the papers' 0..0.6 MPa.
experiment::Actuator plain_regulator() {
  return [](double p, const RigOutputs&) { return experiment::regulator(p, kPaperMax); };
}

// A known loop for the unit tests: y(k) = a y(k-1) + (1 - a) u(k - delay), u = r + c.
struct LagDelay {
  double a;
  std::size_t delay;
  std::vector<double> buf;
  double y = 0.0;
  std::size_t k = 0;
  LagDelay(double a_, std::size_t d) : a(a_), delay(d), buf(d + 1, 0.0) {}
  double step(double u) {
    buf[k % buf.size()] = u;
    const double ud = buf[(k + buf.size() - delay) % buf.size()];
    ++k;
    y = a * y + (1.0 - a) * ud;
    return y;
  }
  std::complex<double> T(double w) const {
    const std::complex<double> zi = std::polar(1.0, -w);
    return std::pow(zi, static_cast<double>(delay)) * (1.0 - a) / (1.0 - a * zi);
  }
};

double reference(std::size_t k, std::size_t n) {
  const double t = 2.0 * std::numbers::pi * static_cast<double>(k % n) / static_cast<double>(n);
  return std::sin(t) + 0.3 * std::sin(2.0 * t + 0.4) + 0.1 * std::cos(3.0 * t);
}

// Per-period RMS errors of `periods` periods of the loop with the ILC.
std::vector<double> run_loop(const LearningParams& p, double a, std::size_t delay, int periods) {
  IterativeLearning ilc(p);
  LagDelay plant(a, delay);
  std::vector<double> rms;
  double y = 0.0;
  for (int j = 0; j < periods; ++j) {
    double s2 = 0.0;
    for (std::size_t k = 0; k < p.period; ++k) {
      const double r = reference(k, p.period);
      const double e = r - y;  // the output of the previous sample against this reference
      s2 += e * e;
      const double u = r + ilc.correction();
      ilc.step(e);
      y = plant.step(u);
    }
    rms.push_back(std::sqrt(s2 / static_cast<double>(p.period)));
  }
  return rms;
}

std::vector<double> grid(std::size_t n) {
  std::vector<double> w;
  for (std::size_t l = 1; l <= 400; ++l) w.push_back(std::numbers::pi * static_cast<double>(l) / 400.0);
  (void)n;
  return w;
}

}  // namespace

TEST(Learning, InvalidParametersAreRejected) {
  LearningParams p;
  EXPECT_THROW(IterativeLearning{p}, Error);  // period 0
  p.period = 100;
  p.gain = 2.0;
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.gain = std::nan("");
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.gain = 0.5;
  p.lead = 50;
  p.half_width = 15;
  p.lookahead = 20;  // 50 + 2 x 15 + 20 = 100: not < period
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.lookahead = 19;
  EXPECT_NO_THROW(IterativeLearning{p});
  p.max_correction = 0.0;
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.max_correction = 1.0;
  p.rise_tolerance = -0.1;
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.rise_tolerance = std::nan("");
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.rise_tolerance = std::numeric_limits<double>::infinity();
  p.max_gain = 1.0;  // growth without supervision
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.rise_tolerance = 0.0;
  EXPECT_NO_THROW(IterativeLearning{p});
  p.max_gain = 0.4;  // below the gain
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.max_gain = 2.0;
  EXPECT_THROW(IterativeLearning{p}, Error);
  p.max_gain = std::nan("");
  EXPECT_THROW(IterativeLearning{p}, Error);
}

// The taps the update sums end where q_m falls below 1e-18 of q_0, checked against the binomial
// coefficients by lgamma (ln q_m / q_0 = 2 ln h! - ln (h + m)! - ln (h - m)!); the window that must
// fit in the period is that reach, not h: a filter with h above the period is accepted where its
// summed taps fit, and refused, naming the reach, where they do not.
TEST(Learning, FilterReachIsWhereTheTapsFallBelow1e18) {
  const auto log_ratio = [](std::size_t h, std::size_t m) {
    const double H = static_cast<double>(h), M = static_cast<double>(m);
    return 2.0 * std::lgamma(H + 1.0) - std::lgamma(H + M + 1.0) - std::lgamma(H - M + 1.0);
  };
  const double floor = std::log(1e-18);
  for (std::size_t h : {0u, 1u, 31u, 32u, 300u, 5000u, 20000u, 10'000'000u}) {
    const std::size_t r = binomial_reach(h);
    ASSERT_LE(r, h);
    if (h <= 31) {
      EXPECT_EQ(r, h) << "h = " << h;  // C(2h, h) <= 1e18: every tap is summed
    }
    EXPECT_GE(log_ratio(h, r), floor - 1e-6) << "h = " << h;
    if (r < h) {
      EXPECT_LT(log_ratio(h, r + 1), floor + 1e-6) << "h = " << h;
    }
    if (h >= 300) {
      EXPECT_NEAR(static_cast<double>(r) / std::sqrt(static_cast<double>(h)), 6.4, 0.3) << "h = " << h;
    }
  }
  LearningParams p;
  p.period = 2500;
  p.lead = 35;
  p.lookahead = 80;
  p.half_width = 20000;  // 35 + 2 x 910 + 80 < 2500
  ASSERT_EQ(binomial_reach(p.half_width), 910u);
  IterativeLearning ilc(p);
  EXPECT_EQ(ilc.filter_reach(), 910u);
  ASSERT_EQ(ilc.filter_taps().size(), 2u * 910u + 1u);
  double sum = 0.0;
  for (double q : ilc.filter_taps()) sum += q;
  EXPECT_NEAR(sum, 1.0, 1e-14);
  // the centre tap against lgamma: q_0 = C(2h, h) / 4^h
  const double q0 = std::exp(std::lgamma(40001.0) - 2.0 * std::lgamma(20001.0) - 40000.0 * std::log(2.0));
  EXPECT_NEAR(ilc.filter_taps()[910] / q0, 1.0, 1e-9);
  p.half_width = 60000;  // reach 1576: 35 + 3152 + 80 >= 2500
  try {
    IterativeLearning{p};
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_TRUE(test::has(e.what(), "lead + 2 reach + lookahead = 35 + 2 x 1576 + 80 must be < period = 2500"))
        << e.what();
  }
  p.half_width = kMaxLearningHalfWidth + 1;
  p.period = 100'000;
  EXPECT_THROW(IterativeLearning{p}, Error);
}

// With max_gain, L is doubled after every period that is the new best, up to max_gain, until
// the first rise: that one restores the best correction and halves L, and L grows no more. Away
// from the period's ends a constant error e_j learns c_{j+1} = c_j + L_j e_j (unit DC gain).
TEST(Learning, GainGrowsAfterBestPeriodsUntilTheFirstRise) {
  // period 0 not compared; 1-4 new bests (L 0.1 -> 0.2 -> 0.4 -> 0.5, capped, -> 0.5); 5 a rise
  // (back to 4's correction, L 0.25); 6 a new best: no growth after a cut
  const std::vector<double> rms{1.0, 0.9, 0.8, 0.7, 0.6, 0.65, 0.5};
  const std::vector<double> gain_after{0.1, 0.2, 0.4, 0.5, 0.5, 0.25, 0.25};
  const std::vector<double> mid{0.0, 0.1, 0.19, 0.35, 0.63, 0.93, 0.63};  // c_j(20) applied in period j
  LearningParams p{.period = 40, .gain = 0.1, .lead = 3, .half_width = 2, .rise_tolerance = 0.0};
  p.max_gain = 0.5;
  IterativeLearning ilc(p);
  for (std::size_t j = 0; j < rms.size(); ++j) {
    for (std::size_t k = 0; k < p.period; ++k) {
      if (k == 20) {
        EXPECT_NEAR(ilc.correction(), mid[j], 1e-12) << "period " << j;
      }
      ilc.step(rms[j]);
    }
    EXPECT_DOUBLE_EQ(ilc.gain(), gain_after[j]) << "period " << j;
  }
  EXPECT_EQ(ilc.gain_raises(), 3u);
  EXPECT_EQ(ilc.gain_cuts(), 1u);
  ilc.reset();
  EXPECT_EQ(ilc.gain_raises(), 0u);
  EXPECT_DOUBLE_EQ(ilc.gain(), 0.1);
  // without max_gain the same errors keep L at 0.1 until the rise
  p.max_gain = 0.0;
  IterativeLearning fixed(p);
  for (std::size_t j = 0; j < 5; ++j)
    for (std::size_t k = 0; k < p.period; ++k) fixed.step(rms[j]);
  EXPECT_DOUBLE_EQ(fixed.gain(), 0.1);
  EXPECT_EQ(fixed.gain_raises(), 0u);
}

// The supervisor keeps the best period's correction. After a period whose mean squared error
// is above (1 + tolerance)^2 times the best's it applies that correction again and halves L;
// the restored period is re-measured and becomes the best. Without supervision nothing changes.
TEST(Learning, SupervisorRestoresTheBestCorrectionAndHalvesTheGain) {
  // RMS of each period (a constant error); with tolerance 0.1: the 4th (1.2 > 1.1 x 0.9, the
  // best, 2nd) and the 6th (1.0 > 1.1 x 0.8, the restored 5th) are rises, the 3rd (0.95 <=
  // 1.1 x 0.9) is not; the 1st is not compared (it starts from the initial state), so the
  // 2nd is not a rise
  const std::vector<double> rms{0.5, 0.9, 0.95, 1.2, 0.8, 1.0, 0.79};
  const std::vector<std::size_t> cuts_after{0, 0, 0, 1, 1, 2, 2};
  for (double tol : {0.1, std::numeric_limits<double>::infinity()}) {
    const bool supervised = std::isfinite(tol);
    const LearningParams p{.period = 40, .gain = 0.4, .lead = 3, .half_width = 2, .rise_tolerance = tol};
    IterativeLearning ilc(p);
    std::vector<std::vector<double>> applied(rms.size());
    for (std::size_t j = 0; j < rms.size(); ++j) {
      for (std::size_t k = 0; k < p.period; ++k) {
        applied[j].push_back(ilc.correction());
        ilc.step(rms[j]);
      }
      const std::size_t expected = supervised ? cuts_after[j] : 0;
      EXPECT_EQ(ilc.gain_cuts(), expected) << "period " << j << ", tolerance " << tol;
      EXPECT_DOUBLE_EQ(ilc.gain(), 0.4 / static_cast<double>(1u << expected));
    }
    // the corrections grow with every period's (positive) error, so they differ per period
    EXPECT_NE(applied[2], applied[1]);
    if (supervised) {
      EXPECT_EQ(applied[4], applied[1]);  // after the rise of period 3: the best, period 1
      EXPECT_EQ(applied[6], applied[4]);  // after the rise of period 5: the restored period 4
      // the update after a restore starts from the restored correction, with the halved gain:
      // c_5(i) = sum_m q_m c_4(i + m) + (L / 2) e_4 away from the period's ends (q = 1 4 6 4 1 / 16)
      const double q[] = {1.0 / 16, 4.0 / 16, 6.0 / 16, 4.0 / 16, 1.0 / 16};
      for (std::size_t i = 2; i + 2 + p.lead < p.period; ++i) {
        double filtered = 0.0;
        for (std::size_t m = 0; m < 5; ++m) filtered += q[m] * applied[4][i + m - 2];
        EXPECT_NEAR(applied[5][i], filtered + 0.2 * rms[4], 1e-12) << "i = " << i;
      }
    } else {
      EXPECT_NE(applied[4], applied[1]);
      EXPECT_NE(applied[6], applied[4]);
    }
    ilc.reset();
    EXPECT_EQ(ilc.gain_cuts(), 0u);
    EXPECT_DOUBLE_EQ(ilc.gain(), 0.4);
    EXPECT_EQ(ilc.correction(), 0.0);
  }
}

// After hold_after_cuts halvings the supervisor holds the best correction: the periods after
// apply it unchanged (no update, whatever their error), the gain is not cut again, and the
// lookahead across the period's end reads the held correction's start.
TEST(Learning, SupervisorHoldsTheBestCorrectionAfterEnoughCuts) {
  // period 0 not compared; 1 best; 2 a rise (cut 1, back to 1's correction); 3 best; 4 a rise
  // (cut 2: held at 3's correction); 5 and 6 would be rises, 7 a fall: no effect when held
  const std::vector<double> rms{0.5, 0.9, 1.2, 0.8, 1.0, 1.5, 2.0, 0.1};
  for (std::size_t hold : {std::size_t{0}, std::size_t{2}}) {
    LearningParams p{.period = 40, .gain = 0.4, .lead = 3, .half_width = 2, .lookahead = 5, .rise_tolerance = 0.0};
    p.hold_after_cuts = hold;
    IterativeLearning ilc(p);
    std::vector<std::vector<double>> applied(rms.size());
    double ahead_at_end = 0.0;
    for (std::size_t j = 0; j < rms.size(); ++j) {
      for (std::size_t k = 0; k < p.period; ++k) {
        applied[j].push_back(ilc.correction());
        if (j == 5 && k == p.period - 2) ahead_at_end = ilc.correction(5);  // period 6's sample 3
        ilc.step(rms[j]);
      }
    }
    EXPECT_EQ(applied[3], applied[1]);  // restored after the first rise
    EXPECT_EQ(applied[5], applied[3]);  // restored after the second rise
    if (hold) {
      EXPECT_TRUE(ilc.held());
      EXPECT_EQ(ilc.gain_cuts(), 2u);
      EXPECT_DOUBLE_EQ(ilc.gain(), 0.1);
      for (std::size_t j = 6; j < rms.size(); ++j) EXPECT_EQ(applied[j], applied[3]) << "period " << j;
      EXPECT_EQ(ahead_at_end, applied[3][3]);
    } else {
      EXPECT_FALSE(ilc.held());
      EXPECT_GT(ilc.gain_cuts(), 2u);  // 5 is updated from 3's correction and rises: cut again
      EXPECT_NE(applied[6], applied[3]);
    }
    ilc.reset();
    EXPECT_FALSE(ilc.held());
    EXPECT_EQ(ilc.correction(), 0.0);
  }
}

// Review s26: with hold_after_cuts = 0 ("never held" then) and tolerance 0 on a noisy loop, the
// supervisor halved L at every rise the noise made, to exactly 0 through the subnormals (7412
// cuts in 20,000 periods), and then smoothed the learnt correction away: a restored best was kept
// whatever its re-measured error, and with L ~ 0 an update is c <- Q c. The true RMS error rose
// to 0.0082 by period 2000 (0.0016 without supervision, 0.077 before learning), with nothing to
// say so. L's floor now holds the best correction after kMaxLearningCuts halvings. The audit's
// loop: y += a (r + c - y), a = 0.1, N = 500, L = 0.5, d = 10, h = 5, measurement noise 0.01.
TEST(Learning, SupervisorHoldsAtTheGainFloorOnANoisyLoop) {
  constexpr std::size_t kPeriods = 2000, kLast = 200;  // the RMS compared: mean over the last kLast periods
  struct Run {
    std::vector<double> rms;  // true error (r - y, without the noise) per period
    double least_gain = 0.0;
    std::size_t cuts = 0;
    bool held = false;
  };
  const auto run = [](double tolerance) {
    const LearningParams p{.period = 500, .gain = 0.5, .lead = 10, .half_width = 5, .rise_tolerance = tolerance};
    IterativeLearning ilc(p);
    std::uint64_t seed = 88172645463325252ULL;  // xorshift64, Box-Muller: the same noise for both runs
    const auto u01 = [&seed] {
      seed ^= seed << 13;
      seed ^= seed >> 7;
      seed ^= seed << 17;
      return static_cast<double>(seed >> 11) * 0x1p-53;
    };
    Run out;
    out.least_gain = ilc.gain();
    double y = 0.0;
    for (std::size_t j = 0; j < kPeriods; ++j) {
      double s2 = 0.0;
      for (std::size_t k = 0; k < p.period; ++k) {
        const double r = std::sin(2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(p.period));
        y += 0.1 * (r + ilc.correction() - y);
        const double noise = 0.01 * std::sqrt(-2.0 * std::log(u01() + 1e-300)) * std::cos(2.0 * std::numbers::pi * u01());
        s2 += (r - y) * (r - y);
        ilc.step(r - (y + noise));
      }
      out.rms.push_back(std::sqrt(s2 / static_cast<double>(p.period)));
      out.least_gain = std::min(out.least_gain, ilc.gain());
    }
    out.cuts = ilc.gain_cuts();
    out.held = ilc.held();
    return out;
  };
  const auto tail_mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (std::size_t j = v.size() - kLast; j < v.size(); ++j) s += v[j];
    return s / static_cast<double>(kLast);
  };
  const Run free = run(std::numeric_limits<double>::infinity());
  const Run supervised = run(0.0);
  ASSERT_EQ(free.cuts, 0u);
  // the unsupervised loop learns: its error far below the first period's
  const double learnt = tail_mean(free.rms);
  ASSERT_LT(learnt, 0.1 * free.rms[0]);
  // the noise made rises: L halved down to its floor, then held there
  EXPECT_EQ(supervised.cuts, kMaxLearningCuts);
  EXPECT_TRUE(supervised.held);
  EXPECT_GE(supervised.least_gain, 0.5 * std::ldexp(1.0, -static_cast<int>(kMaxLearningCuts)));
  // the held correction keeps the error near the learnt level (it rose 5x without the floor)
  EXPECT_LT(tail_mean(supervised.rms), 2.0 * learnt) << "unsupervised " << learnt;
}

// A warm start (reset(correction)): period 0 applies the given correction (clipped to
// max_correction), the update goes on from it, c_1 = Q(c_0 + L e_0), and a correction learnt
// before starts the loop near where it ended; a wrong size or a non-finite value is an error
// that leaves the state as it was.
TEST(Learning, WarmStartContinuesFromTheGivenCorrection) {
  const LearningParams p{.period = 120, .gain = 0.5, .lead = 3, .half_width = 3, .lookahead = 2,
                         .rise_tolerance = 0.0, .hold_after_cuts = 3};
  // learn cold for 12 periods on a lagged loop, keeping the correction the last period applied
  std::vector<double> saved(p.period);
  double cold_first = 0.0, cold_last = 0.0;
  {
    IterativeLearning ilc(p);
    LagDelay plant(0.9, 3);
    double y = 0.0;
    for (int j = 0; j < 12; ++j) {
      double s2 = 0.0;
      for (std::size_t k = 0; k < p.period; ++k) {
        const double r = reference(k, p.period), e = r - y;
        s2 += e * e;
        if (j == 11) saved[k] = ilc.correction();
        const double u = r + ilc.correction();
        ilc.step(e);
        y = plant.step(u);
      }
      (j == 0 ? cold_first : cold_last) = std::sqrt(s2 / static_cast<double>(p.period));
    }
  }
  ASSERT_LT(cold_last, 0.2 * cold_first);
  IterativeLearning warm(p);
  warm.reset(saved);
  LagDelay plant(0.9, 3);
  double y = 0.0, s2 = 0.0;
  std::vector<double> e0(p.period);
  for (std::size_t k = 0; k < p.period; ++k) {
    const double r = reference(k, p.period);
    e0[k] = r - y;
    s2 += e0[k] * e0[k];
    ASSERT_EQ(warm.correction(), saved[k]) << "phase " << k;
    const double u = r + warm.correction();
    warm.step(e0[k]);
    y = plant.step(u);
  }
  EXPECT_LT(std::sqrt(s2 / static_cast<double>(p.period)), 0.3 * cold_first);
  // c_1(k) = sum_m q_m [c_0(k+m) + L e(k+m+d)], q_m = binom(6, m+3) / 64, c_0's index mod N, the
  // error's in time: beyond the period it is period 1's (fed 0 below)
  const double q[7] = {1 / 64.0, 6 / 64.0, 15 / 64.0, 20 / 64.0, 15 / 64.0, 6 / 64.0, 1 / 64.0};
  const auto N = static_cast<std::ptrdiff_t>(p.period);
  for (std::ptrdiff_t k = 0; k < N; ++k) {
    double c1 = 0.0;
    for (std::ptrdiff_t m = -3; m <= 3; ++m) {
      const std::ptrdiff_t t = k + m + 3;
      c1 += q[m + 3] * (saved[static_cast<std::size_t>((k + m + N) % N)] +
                        p.gain * (t < N ? e0[static_cast<std::size_t>(t)] : 0.0));
    }
    ASSERT_NEAR(warm.correction(), c1, 1e-12) << "phase " << k;
    warm.step(0.0);
  }
  // clipped to max_correction
  LearningParams clipped = p;
  clipped.max_correction = 0.5;
  IterativeLearning small(clipped);
  std::vector<double> big(p.period, 2.0);
  big[5] = -3.0;
  small.reset(big);
  EXPECT_EQ(small.correction(), 0.5);
  for (int k = 0; k < 5; ++k) small.step(0.0);
  EXPECT_EQ(small.correction(), -0.5);
  // errors leave the state as it was
  const std::size_t phase = small.phase();
  EXPECT_THROW(small.reset(std::vector<double>(p.period - 1, 0.0)), Error);
  big[7] = std::numeric_limits<double>::quiet_NaN();
  try {
    small.reset(big);
    ADD_FAILURE() << "a NaN correction was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("phase 7"), std::string::npos) << e.what();
  }
  EXPECT_EQ(small.phase(), phase);
  EXPECT_EQ(small.correction(), -0.5);
}

// A copy carries on exactly as the original would, also after the original is gone (the
// supervisor's bookkeeping holds no pointer into the object's own buffers).
TEST(Learning, CopyCarriesOnAsTheOriginal) {
  const LearningParams p{.period = 60, .gain = 0.4, .lead = 4, .half_width = 3, .rise_tolerance = 0.0};
  auto error = [](std::size_t n) { return std::sin(0.37 * static_cast<double>(n)) + (n / 60 == 1 ? 0.0 : 0.5); };
  IterativeLearning reference(p);
  std::unique_ptr<IterativeLearning> original = std::make_unique<IterativeLearning>(p);
  std::size_t n = 0;
  for (; n < 122; ++n) {  // two period ends; the copy is made while the end of c_2 is computed from the best
    reference.step(error(n));
    original->step(error(n));
  }
  IterativeLearning copy = *original;
  original.reset();
  for (; n < 400; ++n) {
    ASSERT_EQ(copy.correction(2), reference.correction(2)) << "sample " << n;
    reference.step(error(n));
    copy.step(error(n));
  }
  EXPECT_EQ(copy.gain_cuts(), reference.gain_cuts());
  EXPECT_GT(reference.gain_cuts(), 0u);
}

// Q has unit DC gain (sum of taps 1): a constant error e learns c = L e after one period,
// also for a filter far wider than 2h = 1020 taps, whose binomial coefficients overflow a double.
TEST(Learning, ConstantErrorLearnsGainTimesErrorWithAWideFilter) {
  for (std::size_t h : {0u, 3u, 600u}) {
    LearningParams p;
    p.period = 2000;
    p.gain = 0.4;
    p.lead = 5;
    p.half_width = h;
    IterativeLearning ilc(p);
    for (std::size_t k = 0; k < p.period; ++k) ilc.step(2.0);
    // away from the period's ends (where the window reaches the errors of the period before
    // the first, taken as 0) the correction is exactly L e
    for (std::size_t k = 0; k < p.period; ++k) {
      if (k >= h + p.lead && k + h + p.lead < p.period) {
        ASSERT_NEAR(ilc.correction(), 0.8, 1e-12) << "h = " << h << ", k = " << k;
      }
      ASSERT_TRUE(std::isfinite(ilc.correction()));
      ilc.step(2.0);
    }
    EXPECT_EQ(ilc.iteration(), 2u);
  }
}

// The progressive update equals the documented formula evaluated directly, over the whole
// error history E (E(n) = e of sample n since the start, 0 before it; c's index wraps within
// a period):  c_{j+1}(i) = sum_{m=-h..h} q_m [c_j((i+m) mod N) + L E(jN + i + m + d)],
// on windows that wrap at either end of the period.
TEST(Learning, ProgressiveUpdateEqualsTheFormula) {
  for (const auto& [N, h, d] : {std::tuple<std::size_t, std::size_t, std::size_t>{97, 20, 7}, {50, 1, 0},
                                {64, 31, 1}, {300, 0, 12}, {41, 10, 19},
                                {3000, 1400, 9},   // h = 1400: the negligible tails are skipped
                                {400, 600, 9}}) {  // h above the period: its 2 x 156 summed taps inside it
    LearningParams p;
    p.period = N;
    p.gain = 0.35;
    p.lead = d;
    p.half_width = h;
    IterativeLearning ilc(p);
    std::vector<double> q(2 * h + 1, 0.0);  // binomial taps / 4^h, by Pascal's rule
    q[0] = 1.0;
    for (std::size_t n = 1; n <= 2 * h; ++n)
      for (std::size_t m = n; m > 0; --m) q[m] = 0.5 * (q[m] + q[m - 1]), q[m - 1] *= (m == 1 ? 0.5 : 1.0);
    std::vector<double> E, c_applied;
    const std::size_t periods = 5;
    // two periods more of errors than compared: the formula's taps reach h (600 > N = 400) after
    // the period, the library's only its summed ones
    for (std::size_t n = 0; n < (periods + 2) * N; ++n) {
      c_applied.push_back(ilc.correction(0));
      E.push_back(std::sin(0.731 * static_cast<double>(n)) + 0.3 * std::cos(0.057 * static_cast<double>(n * n % 1009)));
      ilc.step(E.back());
    }
    for (std::size_t j = 0; j + 1 < periods; ++j)
      for (std::size_t i = 0; i < N; ++i) {
        double want = 0.0;
        for (std::ptrdiff_t m = -static_cast<std::ptrdiff_t>(h); m <= static_cast<std::ptrdiff_t>(h); ++m) {
          const auto Ns = static_cast<std::ptrdiff_t>(N);  // (i + m) mod N, also for |m| > N (h above the period)
          const auto ci = static_cast<std::size_t>(((static_cast<std::ptrdiff_t>(i) + m) % Ns + Ns) % Ns);
          const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(j * N + i + d) + m;
          const double e = n < 0 ? 0.0 : E[static_cast<std::size_t>(n)];
          want += q[static_cast<std::size_t>(m + static_cast<std::ptrdiff_t>(h))] * (c_applied[j * N + ci] + p.gain * e);
        }
        ASSERT_NEAR(c_applied[(j + 1) * N + i], want, 1e-12) << "N " << N << " h " << h << " d " << d << " period "
                                                              << j + 1 << " i " << i;
      }
  }
}

// feedforward_preview is docs' preview(k) = s(k + lead), s(k) = a1 r(k + advance) + a2 r(k + advance - delay),
// evaluated directly where no index leaves the record (r(k) = k^2: every sample distinct).
TEST(Learning, FeedforwardPreviewIsTheShapedReferenceAhead) {
  LoopDesign d;
  d.feedforward_lead = 3;
  d.shaper = LoopDesign::Shaper{.a1 = 0.75, .a2 = 0.25, .delay = 5, .advance = 2};
  std::vector<double> ref(40);
  for (std::size_t k = 0; k < ref.size(); ++k) ref[k] = static_cast<double>(k * k);
  const std::vector<double> preview = feedforward_preview(d, ref);
  for (std::size_t k = 0; k + 3 + 2 < ref.size(); ++k) {
    const std::size_t i = k + 3 + 2;
    if (i < 5) continue;
    EXPECT_EQ(preview[k], 0.75 * ref[i] + 0.25 * ref[i - 5]) << k;
  }
}

// A learning loop's step feeds the PID's reference the correction c_j(k) and the feedforward's preview
// the correction lead samples ahead, c_j(k + lead) (loop_design.hpp). A pure gain q = 1 (model_scale 1)
// with no PID gains commands the preview itself: 0.3 + c(k + 5) for a warm-started c(i) = 0.001 i.
TEST(Learning, LoopStepAddsTheCorrectionLeadSamplesAheadToThePreview) {
  LoopDesign d;
  d.feedforward.model_scale = 1.0;
  d.feedforward_lead = 5;
  const PiParams model{1.0, {}, {}, {0.0, 0.6}, {}};
  Controller c = make_controller(d, model);
  LearningParams lp;
  lp.period = 50;
  lp.gain = 0.5;
  lp.lookahead = 5;
  IterativeLearning ilc(lp);
  std::vector<double> c0(lp.period);
  for (std::size_t i = 0; i < c0.size(); ++i) c0[i] = 0.001 * static_cast<double>(i);
  ilc.reset(c0);
  for (std::size_t k = 0; k + 5 < lp.period; ++k) {
    const LoopOutput o = step(c, ilc, d, 0.3, 0.3, 0.3, 0.3);
    EXPECT_NEAR(o.command_mpa, 0.3 + c0[k + 5], 1e-12) << k;
  }
}

// correction(ahead) at phase k is the correction(0) that phase k + ahead will see, across
// the period boundary too (the preview of a loop must agree with what it later applies).
TEST(Learning, LookaheadAgreesWithTheLaterCorrection) {
  LearningParams p;
  p.period = 97;
  p.gain = 0.7;
  p.lead = 4;
  p.half_width = 6;
  p.lookahead = 11;
  IterativeLearning ilc(p);
  std::vector<double> seen_ahead, seen_now;
  for (std::size_t k = 0; k < 6 * p.period; ++k) {
    seen_now.push_back(ilc.correction(0));
    seen_ahead.push_back(ilc.correction(p.lookahead));
    ilc.step(std::sin(0.37 * static_cast<double>(k)) + 0.2);
  }
  for (std::size_t k = 0; k + p.lookahead < seen_now.size(); ++k)
    ASSERT_EQ(seen_ahead[k], seen_now[k + p.lookahead]) << "sample " << k;
}

// On a loop whose T is known, a design the contraction bound accepts converges
// monotonically, and one it rejects (no phase lead on a delayed loop) does not.
TEST(Learning, ContractionBoundPredictsConvergence) {
  const double a = 0.9;
  const std::size_t delay = 8;
  LagDelay plant(a, delay);
  std::vector<double> w = grid(400);
  std::vector<std::complex<double>> T;
  for (double x : w) T.push_back(plant.T(x));

  LearningParams good;
  good.period = 400;
  good.gain = 0.5;
  good.lead = delay + 9;  // dead time + the lag's ~ a / (1 - a) samples
  good.half_width = 8;
  ASSERT_LT(learning_contraction(good, w, T), 1.0);
  const std::vector<double> rms = run_loop(good, a, delay, 25);
  for (std::size_t j = 1; j < rms.size(); ++j) EXPECT_LE(rms[j], rms[j - 1] * (1.0 + 1e-9)) << "period " << j;
  EXPECT_LT(rms.back(), 0.05 * rms.front());

  LearningParams bad = good;
  bad.lead = 0;
  bad.half_width = 0;
  bad.gain = 1.0;
  EXPECT_GT(learning_contraction(bad, w, T), 1.0);
  const std::vector<double> rb = run_loop(bad, a, delay, 60);
  EXPECT_GT(rb.back(), rb.front());  // the high frequencies grow
}

// The widest window the parameters allow (lead + 2h + lookahead = period - 1) wraps around the
// period once on each side: every correction stays finite and bounded by the errors' bound
// (L <= 1, |e| <= 1, Q sums to 1: |c| grows by at most L per period). Under ASan this also checks
// that no index leaves the buffers (a window wider than half the period overflowed them).
TEST(Learning, WidestWindowStaysInsideThePeriod) {
  LearningParams p;
  p.period = 101;
  p.gain = 0.5;
  p.lead = 7;
  p.half_width = 51;  // the largest h whose summed taps reach 42
  p.lookahead = 9;    // 7 + 2 x 42 + 9 = 100
  IterativeLearning ilc(p);
  double worst = 0.0;
  for (std::size_t k = 0; k < 12 * p.period; ++k) {
    const double c0 = ilc.correction(0), c1 = ilc.correction(p.lookahead);
    ASSERT_TRUE(std::isfinite(c0) && std::isfinite(c1)) << "sample " << k;
    worst = std::max({worst, std::abs(c0), std::abs(c1)});
    ilc.step(std::sin(0.9 * static_cast<double>(k)));
  }
  EXPECT_LE(worst, 0.5 * 12 + 1e-9);
  EXPECT_GT(worst, 0.0);
}

TEST(Learning, NonFiniteErrorsAreCountedNotLearned) {
  LearningParams p;
  p.period = 10;
  IterativeLearning ilc(p);
  for (int k = 0; k < 10; ++k) ilc.step(k == 3 ? std::nan("") : 0.0);
  EXPECT_EQ(ilc.faults(), 1u);
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(ilc.correction(), 0.0);
    ilc.step(0.0);
  }
}

// Finite errors of the order of 1e308 overflow the update's sum (L e + c beyond the double
// range; with alternating signs inf - inf = NaN, which the clamp to max_correction lets through).
// The sample then keeps its correction of the period before: every correction stays finite and
// within max_correction, the overflows are counted, and ordinary errors afterwards learn again.
TEST(Learning, HugeErrorsNeverOverflowTheCorrection) {
  for (const double limit : {std::numeric_limits<double>::infinity(), 0.01}) {
    LearningParams p;
    p.period = 20;
    p.gain = 1.9;
    p.half_width = 2;
    p.max_correction = limit;
    IterativeLearning ilc(p);
    const double huge = std::numeric_limits<double>::max() / 1.5;
    for (std::size_t k = 0; k < 4 * p.period; ++k) {
      const double c = ilc.correction(0);
      ASSERT_TRUE(std::isfinite(c)) << "limit " << limit << ", sample " << k << ": " << c;
      ASSERT_LE(std::abs(c), limit) << "sample " << k;
      ilc.step(k % 2 ? huge : -huge);
    }
    EXPECT_GT(ilc.overflows(), 0u) << "limit " << limit;
    EXPECT_EQ(ilc.faults(), 0u);  // finite errors: not faults
    std::size_t overflows = 0;
    for (std::size_t k = 0; k < 4 * p.period; ++k) {
      ASSERT_TRUE(std::isfinite(ilc.correction(0)));
      ilc.step(1e-3);
      if (k + 1 == p.period) overflows = ilc.overflows();  // the update's window has passed the huge errors
    }
    EXPECT_EQ(ilc.overflows(), overflows);  // ordinary errors do not overflow
    ilc.reset();
    EXPECT_EQ(ilc.overflows(), 0u);
  }
}

TEST(Learning, StepDoesNotAllocate) {
  LearningParams p;
  p.period = 500;
  p.lead = 10;
  p.half_width = 40;
  p.lookahead = 30;
  IterativeLearning ilc(p);
  const std::size_t before = hysteron_test::allocations();
  double acc = 0.0;
  for (int k = 0; k < 5000; ++k) {
    acc += ilc.correction(0) + ilc.correction(30);
    ilc.step(std::sin(0.01 * k));
  }
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_TRUE(std::isfinite(acc));
}

// ---- the experiments ---------------------------------------------------------------

namespace {

// A loop as the experiments identify it (docs/control.md, section 1): dead time theta [s], lag
// tau [s], slope K [m/MPa] and the position relay's K_u [MPa/m] and T_u [s]; the load mode is
// fitted through the relay's point.
RigDynamics relay_identified(double theta, double tau, double K, double Ku, double Tu) {
  RigDynamics d;
  d.dead_time_s = theta;
  d.lag_s = tau;
  d.gain_m_per_mpa = K;
  d.position_relay_gain = Ku;
  d.position_relay_period_s = Tu;
  experiment::fit_load_mode(d);
  return d;
}

// gpi-pid on `rig` with `periods` of learning; `pinned`: hysteron's model pinned to mpi-asym
// and no adaptive run (the kind the default run chooses, without fitting the others).
ExperimentOptions gpi_pid_options(const PamRigParams& rig, int periods, bool pinned = false) {
  ExperimentOptions o;
  o.name = "gpi-pid";
  o.rig = rig;
  o.learning_periods = periods;
  if (pinned) {
    o.adaptive = false;
    o.model = FitModel::mpi_asym;
  }
  return o;
}

ExperimentResult run_gpi_pid(const PamRigParams& rig, int periods) { return run_experiment(gpi_pid_options(rig, periods)); }

const TrackingRun& find_run(const ExperimentResult& r, const std::string& variant) {
  for (const auto& run : r.runs)
    if (run.variant == variant) return run;
  throw Error("no " + variant + " run");
}

}  // namespace

// The compensated loop's gains come from the rig at hand: twice the load gives another
// relay result and other gains (not the nominal rig's constants).
TEST(ExperimentTuning, GainsComeFromTheIdentification) {
  PamRigParams heavy;
  heavy.load.mass *= 2.0;
  const ExperimentResult a = run_gpi_pid(PamRigParams{}, 0);
  const ExperimentResult b = run_gpi_pid(heavy, 0);
  EXPECT_GT(a.dynamics.position_relay_gain, 0.0);
  EXPECT_GT(b.dynamics.position_relay_gain, 0.0);
  EXPECT_GT(std::abs(b.dynamics.position_relay_period_s / a.dynamics.position_relay_period_s - 1.0), 0.05);
  EXPECT_NE(find_run(a, "compensated").description, find_run(b, "compensated").description);
  for (const auto& run : a.runs) EXPECT_NE(run.variant, "learning");  // learning_periods = 0
}

// A rig with switching valves has no proportional regulator in its loops: mpi-pwm identifies
// (fits, dead time, lag, the feedforward's lead, the load mode) through the valves and the
// pressure loop its variants use. Before, its identification ran through the regulator, so a
// slower regulator changed the valve rig's tuning and its identified lag was the regulator's.
TEST(ExperimentTuning, ValveRigIsIdentifiedThroughItsValves) {
  ExperimentOptions o;
  o.name = "mpi-pwm";
  o.learning_periods = 0;
  o.adaptive = false;
  o.model = FitModel::mpi_asym;
  const ExperimentResult a = run_experiment(o);
  o.rig.regulator.time_constant = 0.1;
  o.rig.regulator.dead_time = 0.012;
  const ExperimentResult b = run_experiment(o);
  EXPECT_EQ(a.identification.pressure_mpa, b.identification.pressure_mpa);
  EXPECT_EQ(a.identification.contraction_mm, b.identification.contraction_mm);
  EXPECT_EQ(a.dynamics, b.dynamics);
  EXPECT_EQ(a.lead_s, b.lead_s);
  ASSERT_EQ(a.runs.size(), b.runs.size());
  for (std::size_t i = 0; i < a.runs.size(); ++i)
    EXPECT_EQ(a.runs[i].errors.rms_error_mm, b.runs[i].errors.rms_error_mm) << a.runs[i].variant;
  // the valves' pressure loop follows the identification's command: the measured pressure
  // stays within the command's range
  double lo = 1e9, hi = -1e9;
  for (double p : a.identification.pressure_command_mpa) lo = std::min(lo, p), hi = std::max(hi, p);
  for (double p : a.identification.pressure_mpa) {
    EXPECT_GE(p, lo - 0.05);
    EXPECT_LE(p, hi + 0.05);
  }
}

// mpi-openloop's hysteron variants drive the regulator through the paper's proportional
// pressure loop (command = p_d + 0.5 (p_d - p_measured)); its identification and relay tests run
// through the same loop, so the lag identified is the one the loops see. Before, they ran
// through the plain regulator while the compensated loop tracked through the pressure loop.
TEST(ExperimentTuning, OpenLoopRigIsIdentifiedThroughItsPressureLoop) {
  const double tc = 1e-3;
  PamRigParams slow;  // a slow regulator, where the pressure loop matters most
  slow.regulator.time_constant = 0.1;
  slow.regulator.dead_time = 0.012;
  ExperimentOptions o;
  o.name = "mpi-openloop";
  o.rig = slow;
  o.learning_periods = 0;
  o.adaptive = false;
  o.model = FitModel::mpi_asym;
  const ExperimentResult r = run_experiment(o);
  const IdentificationRun plain = experiment::identification_run(
      slow, o.seed, mpi_identification_pressure(tc), tc,
      [](double p, const RigOutputs&) { return experiment::regulator(p, kPaperMax); },
      kPaperMax);
  ASSERT_EQ(plain.pressure_mpa.size(), r.identification.pressure_mpa.size());
  EXPECT_EQ(plain.pressure_command_mpa, r.identification.pressure_command_mpa);
  // the pressure follows the command more closely through the pressure loop
  double lag_loop = 0, lag_plain = 0;
  for (std::size_t k = 0; k < plain.pressure_mpa.size(); ++k) {
    lag_loop += std::abs(r.identification.pressure_command_mpa[k] - r.identification.pressure_mpa[k]);
    lag_plain += std::abs(plain.pressure_command_mpa[k] - plain.pressure_mpa[k]);
  }
  EXPECT_LT(lag_loop, 0.8 * lag_plain);
  // and the identified lag of the loop's actuator is shorter than the plain regulator's
  std::size_t lead = 0;
  const RigDynamics d = experiment::identify_dynamics(r.best_fit.model, plain, tc, lead);
  EXPECT_LT(r.dynamics.dead_time_s + r.dynamics.lag_s, d.dead_time_s + d.lag_s);
}

// A rig whose hysteresis band (40 kPa) is nearly as wide as the relay's first amplitude
// (+-0.05 MPa): the muscle only creeps and the relay does not oscillate, so the amplitude is
// doubled; the nominal rig keeps the first. Before, the whole experiment failed there.
TEST(ExperimentTuning, RelayAmplitudeGrowsWhereTheHysteresisBandHoldsTheMuscle) {
  const double tc = 1e-3;
  auto make_actuator = [] { return plain_regulator(); };
  RigDynamics nominal, wide_d;
  experiment::position_relay_test(PamRigParams{}, 7, tc, make_actuator, nominal, kPaperMax, kPaperMax);
  EXPECT_EQ(nominal.position_relay_amplitude_mpa, experiment::kPositionRelayAmplitude);
  PamRigParams wide;
  wide.hysteresis.pressure_band = 40e3;
  experiment::position_relay_test(wide, 7, tc, make_actuator, wide_d, kPaperMax, kPaperMax);
  EXPECT_GT(wide_d.position_relay_amplitude_mpa, experiment::kPositionRelayAmplitude);
  EXPECT_GT(wide_d.position_relay_gain, 0.0);
  EXPECT_GT(wide_d.position_relay_period_s, 0.0);
  // the experiment runs end to end, its compensated loop well below the baseline's error
  const ExperimentResult r = run_gpi_pid(wide, 0);
  EXPECT_EQ(r.dynamics.position_relay_amplitude_mpa, wide_d.position_relay_amplitude_mpa);
  EXPECT_NE(r.table().find("position relay (+-"), std::string::npos);
  EXPECT_LT(find_run(r, "compensated").errors.rms_error_mm, 0.2 * find_run(r, "baseline").errors.rms_error_mm);
  // a rig that cannot be made to oscillate within 0..0.6 MPa: a clear error naming the amplitudes
  PamRigParams stuck;
  stuck.hysteresis.pressure_band = 400e3;
  RigDynamics none;
  const std::string what =
      error_of([&] { experiment::position_relay_test(stuck, 7, tc, make_actuator, none, kPaperMax, kPaperMax); });
  EXPECT_NE(what.find("+-0.2 MPa"), std::string::npos) << what;
}

// Valves that drop pulses shorter than 1.82 ms, at 346 Hz (a period of 2.89 ms): at the valves'
// relay's duty +-0.5 (1.45 ms) they never open and the muscle stays vented (0.004 MPa); the
// relay runs again at +-1 (before 2026-11-29 mpi-pwm failed there, naming the supply). Nominal
// valves keep +-0.5.
TEST(ExperimentTuning, ValveRelayRunsAtFullDutyWhereHalfDutyDoesNotOpenTheValves) {
  const double tc = 1e-3;
  RigDynamics nominal, slow;
  experiment::relay_test(PamRigParams{}, 7, tc, nominal, kPaperMax);
  EXPECT_EQ(nominal.relay_duty, 0.5);
  EXPECT_GT(nominal.relay_gain, 0.0);
  PamRigParams p;
  p.valves.min_pulse = 1.822864e-3;
  p.valves.pwm_frequency = 345.900323424;
  experiment::relay_test(p, 7, tc, slow, kPaperMax);
  EXPECT_EQ(slow.relay_duty, 1.0);
  EXPECT_GT(slow.relay_gain, 0.0);
  EXPECT_GT(slow.relay_period_s, 0.0);
  EXPECT_NEAR(slow.relay_level_mpa, kRelayLevel, 1e-12);
}

// A heavy load hangs on its rest below a pressure that grows with its weight (the
// identification run lifts 65 kg off its rest only above about 0.29 MPa, 70 kg above 0.31).
// A relay at 0.3 +- 0.05 MPa then lets it down onto the rest every cycle: at 65 kg the cycle
// is cut there and the describing function gave K_u = 79.5 MPa/m (6x the nominal rig's), and
// every loop tuned from it oscillated (gpi-pid compensated 16.2 mm RMS, 2.2x the baseline's);
// at 70 kg the contraction could not fall below its level and every experiment failed ("did
// not oscillate"). The relay now runs around the middle of the identification run's stroke
// wherever its lower level is below the pressure that lifts the load.
TEST(ExperimentTuning, PositionRelayMovesToTheMiddleOfTheStrokeWhereItsLevelWouldSetTheLoadDown) {
  const double tc = 1e-3;
  auto make_actuator = [] { return plain_regulator(); };
  PamRigParams heavy;
  heavy.load.mass = 70.0;
  RigDynamics none;
  // (no error at all would mean 0.3 MPa lifts 70 kg: the test's premise would not hold)
  const std::string at_level =
      error_of([&] { experiment::position_relay_test(heavy, 7, tc, make_actuator, none, kPaperMax, kPaperMax); });
  EXPECT_NE(at_level.find("around 0.3 MPa: +-0.05 MPa"), std::string::npos) << at_level;
  // a level that cannot fit the first amplitude within the actuator's range is named as such
  const std::string what = error_of([&] {
    experiment::position_relay_test(heavy, 7, tc, make_actuator, none, kPaperMax, kPaperMax, {0.31, 0.58});
  });
  EXPECT_NE(what.find("around 0.58 MPa: no amplitude of at least 0.05 MPa fits"), std::string::npos) << what;
  EXPECT_NE(what.find("off its rest only above 0.310 MPa"), std::string::npos) << what;
  // 77.6 kg on a 5.16 bar (absolute) supply, with 0.16 mm of displacement noise: a stroke of a
  // few mm between lift-off and the supply's cap, too narrow for the relay. The error names the
  // lift-off pressure, not a noise peak at the rest (it said 0.009 MPa when 2 % of that short
  // stroke was within the noise), and the top with 3 digits.
  PamRigParams narrow;
  narrow.load.mass = 77.6;
  narrow.air.supply_pressure = 515554.0;
  narrow.sensors.displacement_noise = 0.16e-3;
  const std::string narrow_what = error_of([&] { run_gpi_pid(narrow, 0); });
  EXPECT_NE(narrow_what.find("within the actuator's 0..0.416 MPa ("), std::string::npos) << narrow_what;
  const auto at = narrow_what.find("off its rest only above ");
  ASSERT_NE(at, std::string::npos) << narrow_what;
  const double lift = std::stod(narrow_what.substr(at + 24));
  EXPECT_GT(lift, 0.3) << narrow_what;  // 70 kg is lifted above 0.31 MPa
  EXPECT_LT(lift, 0.416) << narrow_what;
  // end to end: the level comes from the identification run, and the loops track
  const ExperimentResult nominal = run_gpi_pid(PamRigParams{}, 0);
  EXPECT_EQ(nominal.dynamics.position_relay_level_mpa, kRelayLevel);
  for (double mass : {65.0, 70.0}) {
    heavy.load.mass = mass;
    const ExperimentResult r = run_gpi_pid(heavy, 0);
    double lo = 1e9, hi = -1e9;
    for (double x : r.identification.contraction_mm) lo = std::min(lo, x), hi = std::max(hi, x);
    double p_mid_up = 0.0;  // the ascent's pressure at mid-stroke: the first sample at or above it
    for (std::size_t k = 0; k < r.identification.contraction_mm.size(); ++k)
      if (r.identification.contraction_mm[k] >= 0.5 * (lo + hi)) {
        p_mid_up = r.identification.pressure_mpa[k];
        break;
      }
    EXPECT_GT(r.dynamics.position_relay_level_mpa, kRelayLevel + experiment::kPositionRelayAmplitude);
    EXPECT_NEAR(r.dynamics.position_relay_level_mpa, p_mid_up, 0.05) << mass;  // within the hysteresis band
    // the free-hanging load's loop: an ultimate gain of the nominal rig's order, not 6x it
    EXPECT_LT(r.dynamics.position_relay_gain, 2.0 * nominal.dynamics.position_relay_gain) << mass;
    EXPECT_NE(r.table().find("position relay (at 0.4"), std::string::npos) << r.table();
    EXPECT_LT(find_run(r, "compensated").errors.rms_error_mm, 0.2 * find_run(r, "baseline").errors.rms_error_mm)
        << mass;
  }
}

// A slow rig oscillates under the relay with a period too long for 3 cycles in the 2 s the
// test measured: the contraction crosses its level (so the hysteresis does not hold it), and
// the run is made longer instead of failing or raising the amplitude. A regulator with a
// 0.3 s lag and 250 ms dead time and a 40 kg load: the relay's period is about 1.1 s (with
// the 2 s window the amplitude was raised instead; mpi-pwm on a 16 mm muscle through the
// paper's valves failed with "2 crossings in 2 s" at every amplitude). (Until the relay's
// hysteresis came from the sensor's noise alone, the rig here was 0.4 s / 60 ms: the load still
// settling at p0 widened the hysteresis and the period to 1.6 s; it is 0.65 s now.)
TEST(ExperimentTuning, RelayRunsLongerWhereTheRigIsSlow) {
  const double tc = 1e-3;
  auto make_actuator = [] { return plain_regulator(); };
  PamRigParams slow;
  slow.regulator.time_constant = 0.3;
  slow.regulator.dead_time = 0.25;
  slow.load.mass = 40.0;
  RigDynamics d;
  experiment::position_relay_test(slow, 7, tc, make_actuator, d, kPaperMax, kPaperMax);
  EXPECT_EQ(d.position_relay_amplitude_mpa, experiment::kPositionRelayAmplitude);  // not raised
  EXPECT_GT(d.position_relay_period_s, 1.0);  // 3 cycles do not fit in 2 s
  EXPECT_LT(d.position_relay_period_s, 4.0);  // 3 cycles fit in the longest window, 8 s
  EXPECT_GT(d.position_relay_gain, 0.0);
}

// A heavy load (45 kg) rings at 3 Hz with damping 0.27: the design contracts on the identified
// loop (bound 0.978) but on the rig the 3-6 Hz error grows after the 5th period (RMS 0.374 ->
// 0.504 mm by the 10th without supervision). After each rise the supervisor restores the best
// correction and halves L, so the last period ends below every period before the first rise.
TEST(ExperimentTuning, LearningSupervisorStopsTheGrowthOnAHeavyLoad) {
  PamRigParams heavy;
  heavy.load.mass = 45.0;
  const ExperimentResult r = run_experiment(gpi_pid_options(heavy, 10, true));
  const TrackingRun& l = find_run(r, "learning");
  ASSERT_EQ(l.periods.size(), 10u);
  std::size_t first_rise = 0;
  double least = l.periods[0].rms_error_mm;
  for (std::size_t j = 1; j < l.periods.size() && first_rise == 0; ++j) {
    if (l.periods[j].rms_error_mm > least) first_rise = j;
    least = std::min(least, l.periods[j].rms_error_mm);
  }
  ASSERT_GT(first_rise, 0u) << "no rise: the supervisor is not exercised on this rig";
  EXPECT_LT(l.periods.back().rms_error_mm, least) << l.description;
  EXPECT_NE(l.description.find("L halved"), std::string::npos) << l.description;
}

// A 2 kg load falls too slowly for the Eq. 18 sinusoid's descent (damping 400 N s/m: at most
// m g / c = 49 mm/s with the muscle vented, the reference needs 57 mm/s): the command sits at
// 0 MPa and the error there is the rig's. The result says so, per run; the nominal rig (whose
// command stays inside 0..0.6 MPa) gets no such note.
TEST(ExperimentTuning, SaturationIsSaidWhereTheLoadCannotFollow) {
  PamRigParams light;
  light.load.mass = 2.0;
  const auto notes = [](const ExperimentResult& r) {
    std::size_t n = 0;
    for (const auto& m : r.messages) n += m.find("the pressure command was at a limit") != std::string::npos;
    return n;
  };
  const ExperimentResult a = run_gpi_pid(PamRigParams{}, 0), b = run_gpi_pid(light, 0);
  EXPECT_EQ(notes(a), 0u);
  bool compensated = false;
  for (const auto& m : b.messages)
    compensated = compensated || m.rfind("compensated (sine): the pressure command was at a limit", 0) == 0;
  EXPECT_TRUE(compensated) << b.table();
  EXPECT_GT(find_run(b, "compensated").saturated, 0u);
}

// The relay tests count one cycle per upward crossing of the level after the signal was below
// level - eps (the relay's hysteresis). Counting every raw crossing, sensor noise around the
// level counted cycles twice: the valves' pressure relay measured T_u = 12.0 ms on the nominal
// rig (20.0 ms counted with the hysteresis) and 5.5 ms with a 10x noisier pressure sensor.
// A noisier sensor widens the relay's hysteresis (3 noise sigmas), which can only slow the
// cycle: its period is not shorter than the nominal's.
TEST(ExperimentTuning, RelayPeriodIsNotShortenedBySensorNoise) {
  const double tc = 1e-3;
  RigDynamics nominal, noisy;
  experiment::relay_test(PamRigParams{}, 7, tc, nominal, kPaperMax);
  PamRigParams loud;
  loud.sensors.pressure_noise *= 10.0;
  experiment::relay_test(loud, 7, tc, noisy, kPaperMax);
  ASSERT_GT(nominal.relay_period_s, 0.0);
  EXPECT_GE(noisy.relay_period_s, nominal.relay_period_s);
  // the cycle is the valves' fill/vent through the PWM loop: well above 2 samples
  EXPECT_GT(nominal.relay_period_s, 10.0 * tc);
}

// Both relay tests run at the middle of the pressure the rig can use: 0.3 MPa of the actuator's
// 0..0.6 MPa, or half the top where the supply caps it. A 4 bar (absolute) supply holds the
// muscle at 0.3 MPa gauge: the valves' relay around 0.3 MPa could not rise above its level and
// mpi-pwm failed on that rig ("did not oscillate around 0.3 MPa (amplitude 0.00256 MPa, 0
// crossings)"); the position relay switched 0.3 +- 0.05 MPa, half of it out of reach. And the
// identification run's commands above that cap made the FOPDT's lag the grid's bound (300 ms).
// A supply that still holds the relay's 0.35 MPa keeps it at 0.3 MPa.
TEST(ExperimentTuning, RelaysRunAtTheMiddleOfThePressureTheSupplyReaches) {
  const double tc = 1e-3;
  RigDynamics nominal;
  experiment::relay_test(PamRigParams{}, 7, tc, nominal, kPaperMax);
  EXPECT_EQ(nominal.relay_level_mpa, kRelayLevel);
  PamRigParams low;
  low.air.supply_pressure = 4e5;  // [Pa abs]
  const double cap = (low.air.supply_pressure - low.air.atmospheric_pressure) * 1e-6;  // 0.3 MPa gauge
  RigDynamics d;
  experiment::relay_test(low, 7, tc, d, kPaperMax);
  EXPECT_NEAR(d.relay_level_mpa / (0.5 * cap), 1.0, 0.03) << d.relay_level_mpa;
  EXPECT_GT(d.relay_gain, 0.0);
  EXPECT_GT(d.relay_period_s, 10.0 * tc);
  // the position relay around half the top it is given where 0.3 + 0.05 MPa is beyond it; the
  // full range, and a top that still holds 0.35 MPa, keep 0.3 MPa
  auto make_actuator = [] { return plain_regulator(); };
  RigDynamics pos_nominal, pos_low;
  experiment::position_relay_test(PamRigParams{}, 7, tc, make_actuator, pos_nominal, kPaperMax, kPaperMax);
  EXPECT_EQ(pos_nominal.position_relay_level_mpa, kRelayLevel);
  experiment::position_relay_test(low, 7, tc, make_actuator, pos_low, kPaperMax, cap);
  EXPECT_EQ(pos_low.position_relay_level_mpa, 0.5 * cap);
  RigDynamics pos_mid;
  experiment::position_relay_test(PamRigParams{}, 7, tc, make_actuator, pos_mid, kPaperMax, 0.4);
  EXPECT_EQ(pos_mid.position_relay_level_mpa, kRelayLevel);
  EXPECT_EQ(pos_mid.position_relay_gain, pos_nominal.position_relay_gain);
  EXPECT_GT(pos_low.position_relay_gain, 0.0);
  EXPECT_THROW(experiment::position_relay_test(low, 7, tc, make_actuator, pos_low, kPaperMax, 0.0), Error);
  // mpi-pwm end to end on that rig: both levels near 0.15 MPa, in the result and its table, a
  // lag well inside the identification's 0.3 s grid, and the compensated loop well below the
  // baseline
  ExperimentOptions o;
  o.name = "mpi-pwm";
  o.rig = low;
  o.adaptive = false;
  o.model = FitModel::mpi_asym;
  o.learning_periods = 0;
  const ExperimentResult r = run_experiment(o);
  EXPECT_NEAR(r.dynamics.relay_level_mpa / (0.5 * cap), 1.0, 0.03);
  EXPECT_NEAR(r.dynamics.position_relay_level_mpa / (0.5 * cap), 1.0, 0.03);
  EXPECT_LT(r.dynamics.dead_time_s + r.dynamics.lag_s, 0.1);
  const std::string table = r.table();
  EXPECT_NE(table.find("position relay (at 0.15"), std::string::npos) << table;
  EXPECT_NE(table.find("pressure relay (at 0.15"), std::string::npos) << table;
  for (const char* ref : {"sine", "triangle"}) {
    const TrackingRun* c = nullptr;
    const TrackingRun* b = nullptr;
    for (const auto& run : r.runs) {
      if (run.reference != ref) continue;
      if (run.variant == "compensated") c = &run;
      if (run.variant == "baseline") b = &run;
    }
    ASSERT_TRUE(c && b) << ref;
    EXPECT_LT(c->errors.rms_error_mm, 0.2 * b->errors.rms_error_mm) << ref;
  }
}

// The valves' relay takes its hysteresis from the sensor's noise measured at the relay's level
// with the valves closed, not while vented: a pressure sensor reading 10 kPa low clips at 0
// there (no noise seen, no hysteresis), and the relay chattered on the noise at half the
// nominal period (10.3 ms against 20.8 ms), which tuned the pressure PI's integral 2.4x up.
// An offset of the sensor is not the rig's dynamics: the cycle is the nominal one.
TEST(ExperimentTuning, RelayCycleDoesNotDependOnThePressureSensorsOffset) {
  const double tc = 1e-3;
  RigDynamics nominal;
  experiment::relay_test(PamRigParams{}, 7, tc, nominal, kPaperMax);
  ASSERT_GT(nominal.relay_period_s, 0.0);
  for (double offset : {-10e3, 10e3}) {
    PamRigParams shifted;
    shifted.sensors.pressure_offset = offset;
    RigDynamics d;
    experiment::relay_test(shifted, 7, tc, d, kPaperMax);
    EXPECT_NEAR(d.relay_period_s / nominal.relay_period_s, 1.0, 0.1) << offset;
    EXPECT_NEAR(d.relay_gain / nominal.relay_gain, 1.0, 0.15) << offset;
  }
}

// The valves' pressure relay measures the same limit cycle in seconds at every control period:
// it runs at kRelayDecisionPeriod (1 ms; also for 0.3 and 0.7 ms loops, whose samples do not
// add up to 1 ms: a review found them at 0.9 and 0.7 ms), not at every sample of a faster loop. Deciding at
// every sample, 25 decisions per 5 ms PWM period at 0.2 ms switched the relay on the sensor's
// noise and the PWM ripple (its hysteresis, 3 sigma, bounds a switch on noise per decision):
// T_u 26.8 ms and K_u 137 /MPa for 32.5 ms and 151 at 1 ms (mpi-pwm --seed 1's relay), a
// pressure PI of Kp 42.8 / Ki 725 for 47.1 / 660, and mpi-pwm's compensated triangle 0.293 mm
// RMS for 0.192 (docs/control.md, section 7). At 0.5 ms: T_u 28.4 ms, Ki 771.
TEST(ExperimentTuning, ValvesRelayIsTheSameInSecondsAtEveryControlPeriod) {
  const double dt = PamRigParams{}.simulation.dt;  // 1e-4 s
  EXPECT_EQ(experiment::relay_decision_period(1e-3, dt), 1e-3);
  EXPECT_EQ(experiment::relay_decision_period(2e-3, dt), 2e-3);
  EXPECT_EQ(experiment::relay_decision_period(1e-2, dt), 1e-2);
  // faster loops: the 1 ms test, also where 1 ms is no whole number of the loop's samples
  for (const double tc : {5e-4, 2e-4, 3e-4, 7e-4, 8e-4, 1e-4})
    EXPECT_EQ(experiment::relay_decision_period(tc, dt), 1e-3) << tc;
  // a rig whose dt does not divide 1 ms: the whole number of loop samples nearest it
  EXPECT_DOUBLE_EQ(experiment::relay_decision_period(3e-4, 3e-5), 9e-4);
  const std::uint64_t seed = 1 + 15485863;  // the relay of mpi-pwm --seed 1
  RigDynamics at_1ms;
  experiment::relay_test(PamRigParams{}, seed, 1e-3, at_1ms, kPaperMax);
  ASSERT_GT(at_1ms.relay_period_s, 0.0);
  const PidParams pi_1ms = experiment::tyreus_luyben_pi(at_1ms, 1e-3);
  for (const double tc : {5e-4, 2e-4, 7e-4}) {
    SCOPED_TRACE(fmt::format("T_s = {} s", tc));
    RigDynamics d;
    experiment::relay_test(PamRigParams{}, seed, tc, d, kPaperMax);
    EXPECT_NEAR(d.relay_period_s / at_1ms.relay_period_s, 1.0, 0.02) << d.relay_period_s;
    EXPECT_NEAR(d.relay_gain / at_1ms.relay_gain, 1.0, 0.02) << d.relay_gain;
    // the pressure PI runs at the loop's own T_s with the same gains in seconds
    const PidParams pi = experiment::tyreus_luyben_pi(d, tc);
    EXPECT_EQ(pi.sample_time, tc);
    EXPECT_NEAR(pi.kp / pi_1ms.kp, 1.0, 0.02) << pi.kp;
    EXPECT_NEAR(pi.ki / pi_1ms.ki, 1.0, 0.02) << pi.ki;
  }
}

// The position relay's hysteresis is 3 sigma of the contraction sensor's noise, whatever the
// load still does at p0: sigma comes from the reading's first differences. The spread of the
// samples around their mean counted the settling too: 1.8x the sensor's sigma on the nominal
// rig, 2.3x with damping 800 N s/m (the relay then switched late and measured another point).
TEST(ExperimentTuning, PositionRelayHysteresisIsThreeSigmasOfTheSensorsNoise) {
  const double tc = 1e-3;
  auto make_actuator = [] { return plain_regulator(); };
  PamRigParams damped;
  damped.load.damping = 800.0;
  for (const PamRigParams& base : {PamRigParams{}, damped})
    for (double noise_scale : {1.0, 3.0}) {
      PamRigParams rig = base;
      rig.sensors.displacement_noise *= noise_scale;
      RigDynamics d;
      experiment::position_relay_test(rig, 7, tc, make_actuator, d, kPaperMax, kPaperMax);
      ASSERT_GT(d.position_relay_gain, 0.0);
      EXPECT_NEAR(d.position_relay_hysteresis_m / (3.0 * rig.sensors.displacement_noise), 1.0, 0.15)
          << "damping " << rig.load.damping << ", noise " << rig.sensors.displacement_noise;
    }
}

// The learning variant reduces the error from period to period, on the nominal rig and on
// a slow regulator (100 ms lag, 12 ms dead time), up to the sensor-noise floor.
TEST(ExperimentTuning, LearningReducesTheErrorMonotonically) {
  PamRigParams slow;
  slow.regulator.time_constant = 0.1;
  slow.regulator.dead_time = 0.012;
  for (const PamRigParams& rig : {PamRigParams{}, slow}) {
    const ExperimentResult r = run_gpi_pid(rig, 6);
    const TrackingRun& l = find_run(r, "learning");
    ASSERT_EQ(l.periods.size(), 6u);
    for (std::size_t j = 1; j < l.periods.size(); ++j)
      EXPECT_LE(l.periods[j].rms_error_mm, l.periods[j - 1].rms_error_mm + 0.01) << "period " << j;
    EXPECT_LT(l.periods.back().rms_error_mm, 0.3 * l.periods.front().rms_error_mm);
    EXPECT_LT(l.errors.rms_error_mm, find_run(r, "compensated").errors.rms_error_mm);
  }
}

// On a rig whose load mode rings (load damping 200 N s/m instead of 400) no filter contracts on
// the identified loop and its neighbours with L = 0.5, 0.3 or 0.2 (before the smaller gains
// there was no learning run on it); a smaller gain does, and the error falls every period; the
// supervisor raises L while it does.
TEST(ExperimentTuning, LearningFallsBackToASmallerGainWhereTheLoopRings) {
  PamRigParams ringing;
  ringing.load.damping = 200.0;
  const ExperimentResult r = run_gpi_pid(ringing, 3);
  const TrackingRun& l = find_run(r, "learning");
  const auto at = l.description.find("(L = ");
  ASSERT_NE(at, std::string::npos) << l.description;
  const double gain = std::stod(l.description.substr(at + 5));
  EXPECT_LT(gain, 0.2) << l.description;
  EXPECT_GE(gain, 0.05) << l.description;
  ASSERT_EQ(l.periods.size(), 3u);
  for (std::size_t j = 1; j < l.periods.size(); ++j)
    EXPECT_LT(l.periods[j].rms_error_mm, l.periods[j - 1].rms_error_mm) << "period " << j;
  for (const auto& m : r.messages) EXPECT_EQ(m.find("learning (sine) not run"), std::string::npos) << m;
  // this slow design ends above the compensated loop after 3 periods (0.544 vs 0.424 mm; L =
  // 0.1), and the result says so, with the error still falling
  const TrackingRun& c = find_run(r, "compensated");
  ASSERT_GT(l.errors.rms_error_mm, c.errors.rms_error_mm);
  bool said = false;
  for (const auto& m : r.messages)
    said = said || (m.rfind("learning (sine): after 3 periods its RMS error", 0) == 0 &&
                    m.find("is above the compensated run's") != std::string::npos &&
                    m.find("it was still falling") != std::string::npos &&
                    m.find("more period(s) would bring it below") != std::string::npos);
  EXPECT_TRUE(said) << r.table();
  // The supervisor doubles L after every new best period (LearningParams::max_gain): within 10
  // periods the run ends well below the compensated loop (0.045 vs 0.424 mm; 0.231 with the
  // design's L = 0.05 before its neighbours' modes were refitted through the relay's point, and
  // 0.488 mm, above it, with L fixed at 0.05).
  EXPECT_NE(l.description.find("L doubled"), std::string::npos) << l.description;
  const ExperimentResult r10 = run_gpi_pid(ringing, 10);
  const TrackingRun& l10 = find_run(r10, "learning");
  ASSERT_TRUE(l10.controller.learning);  // the identified loop itself contracts with the largest gain
  EXPECT_EQ(l10.controller.learning->params.max_gain, experiment::kLearningGains[0]);
  EXPECT_LT(l10.errors.rms_error_mm, 0.75 * find_run(r10, "compensated").errors.rms_error_mm) << l10.description;
  for (const auto& m : r10.messages) EXPECT_EQ(m.find("learning (sine): after"), std::string::npos) << m;
}

// The gain trial (docs/control.md, section 2) picks the scale of the classic PID's gains with
// the least RMS on its trapezoid, and the loops use it. On the worst rig of the documented set
// (35 kg, 25 kPa band, force map -15 %, regulator 100/12 ms, damping 200 N s/m) the relay's
// gains oscillate in tracking (4.6x the nominal RMS before the trial); the trial lowers them and
// the compensated loop meets the issue's 2x-nominal target there.
TEST(ExperimentTuning, GainTrialDetunesTheLoopWhereItWouldOscillate) {
  PamRigParams worst;
  for (const auto& v : documented_variants())
    if (v.name == "worst") worst = apply_overrides(PamRigParams{}, v.overrides, "worst");
  ASSERT_NE(worst.load.mass, PamRigParams{}.load.mass);
  std::vector<ExperimentResult> rs;
  for (const PamRigParams& rig : {PamRigParams{}, worst}) {
    rs.push_back(run_experiment(gpi_pid_options(rig, 0, true)));
    const ExperimentResult& r = rs.back();
    ASSERT_EQ(r.gain_trials.size(), 1u);
    const GainTrial& g = r.gain_trials[0];
    ASSERT_EQ(g.scales.size(), g.rms_mm.size());
    ASSERT_GE(g.scales.size(), 5u);
    // the least RMS of every trial, unshaped first (ties: unshaped, then the smaller scale)
    std::size_t best = 0;
    bool best_shaped = false;
    for (std::size_t i = 0; i < g.rms_mm.size(); ++i)
      if (g.rms_mm[i] < g.rms_mm[best]) best = i;
    ASSERT_TRUE(g.rms_shaped_mm.empty() || g.rms_shaped_mm.size() == g.scales.size());
    double least = g.rms_mm[best];
    for (std::size_t i = 0; i < g.rms_shaped_mm.size(); ++i)
      if (g.rms_shaped_mm[i] < least) least = g.rms_shaped_mm[i], best = i, best_shaped = true;
    EXPECT_EQ(g.scale, g.scales[best]);
    EXPECT_EQ(g.shaped, best_shaped);
    EXPECT_LT(g.scales.back() * 0.6, 1.0);  // K_p stays below the relay's ultimate gain
    // the compensated loop's PID is the classic one times the chosen scale
    const TrackingRun& c = find_run(r, "compensated");
    const auto at = c.description.find("Kp = ");
    ASSERT_NE(at, std::string::npos) << c.description;
    EXPECT_NEAR(std::stod(c.description.substr(at + 5)), 0.6 * r.dynamics.position_relay_gain * g.scale,
                0.002 * r.dynamics.position_relay_gain);
  }
  EXPECT_LT(rs[1].gain_trials[0].scale, 1.0);
  EXPECT_LT(rs[1].gain_trials[0].scale, rs[0].gain_trials[0].scale);
  EXPECT_LT(find_run(rs[1], "compensated").errors.rms_error_mm, 2.0 * find_run(rs[0], "compensated").errors.rms_error_mm);

  // Stopped early (what hysteron sweep does): the same choice and the same tracking runs; a
  // stopped candidate's RMS is a lower bound of its complete one, above the chosen one's.
  std::size_t stopped = 0;
  for (std::size_t i = 0; i < rs.size(); ++i) {
    ExperimentOptions o = gpi_pid_options(i == 0 ? PamRigParams{} : worst, 0, true);
    o.complete_gain_trials = false;
    const ExperimentResult e = run_experiment(o);
    ASSERT_EQ(e.gain_trials.size(), 1u);
    const GainTrial &full = rs[i].gain_trials[0], &g = e.gain_trials[0];
    EXPECT_FALSE(full.early_stop);
    EXPECT_EQ(g.scale, full.scale);
    EXPECT_EQ(g.shaped, full.shaped);
    EXPECT_EQ(g.scales, full.scales);
    const double chosen = (full.shaped ? full.rms_shaped_mm : full.rms_mm)[static_cast<std::size_t>(
        std::find(full.scales.begin(), full.scales.end(), full.scale) - full.scales.begin())];
    auto compare = [&](const std::vector<double>& a, const std::vector<double>& b) {
      ASSERT_EQ(a.size(), b.size());
      for (std::size_t k = 0; k < a.size(); ++k) {
        if (a[k] == b[k]) continue;  // run to its end
        ++stopped;
        EXPECT_LT(a[k], b[k]) << k;
        EXPECT_GT(a[k], chosen) << k;
      }
    };
    compare(g.rms_mm, full.rms_mm);
    compare(g.rms_shaped_mm, full.rms_shaped_mm);
    for (const char* kind : {"compensated", "baseline", "faithful"})
      EXPECT_EQ(find_run(e, kind).errors.rms_error_mm, find_run(rs[i], kind).errors.rms_error_mm) << kind;
  }
  EXPECT_GT(stopped, 4u);  // it saves time: most candidates stop
}

// The zero-vibration shaper at an identified mode: a ramp to a hold, passed through it, leaves
// the mode (w_n^2 / (s^2 + 2 zeta w_n s + w_n^2), simulated with 20 substeps per sample) without residual
// vibration, and its advance keeps the ramp's timing (zero mean delay).
TEST(ExperimentTuning, ZeroVibrationShaperCancelsTheIdentifiedMode) {
  using experiment::shaped;
  using experiment::zv_shaper;
  const double tc = 1e-3;
  RigDynamics d;
  EXPECT_FALSE(zv_shaper(d, tc).active());  // no mode identified
  d.mode_frequency_hz = 3.5;
  d.mode_damping = 1.2;
  EXPECT_FALSE(zv_shaper(d, tc).active());  // overdamped: nothing rings
  d.mode_damping = 0.25;
  const auto z = zv_shaper(d, tc);
  ASSERT_TRUE(z.active());
  EXPECT_NEAR(z.a1 + z.a2, 1.0, 1e-15);
  const double wn = 2.0 * std::numbers::pi * d.mode_frequency_hz, wd = wn * std::sqrt(1.0 - 0.25 * 0.25);
  EXPECT_NEAR(static_cast<double>(z.delay) * tc, std::numbers::pi / wd, tc);
  std::vector<double> r;
  for (int k = 0; k < 4000; ++k) r.push_back(std::clamp((k - 500) / 1000.0, 0.0, 1.0));  // ramp 0.5..1.5 s
  const std::vector<double> rs = shaped(r, z);
  ASSERT_EQ(rs.size(), r.size());
  // the mode, x'' = wn^2 (u - x) - 2 zeta wn x', by small substeps; the residual vibration once
  // both inputs hold (the shaped one ends D - advance samples after the ramp, at 1.5 s)
  const std::size_t settled = 1500 + z.delay;
  auto residual = [&](const std::vector<double>& u) {
    double x = 0.0, v = 0.0, worst = 0.0;
    for (std::size_t k = 0; k < u.size(); ++k) {
      for (int i = 0; i < 20; ++i) {
        v += tc / 20 * (wn * wn * (u[k] - x) - 2.0 * 0.25 * wn * v);
        x += tc / 20 * v;
      }
      if (k >= settled) worst = std::max(worst, std::abs(x - 1.0));
    }
    return worst;
  };
  const double plain = residual(r), with = residual(rs);
  EXPECT_GT(plain, 0.01);
  EXPECT_LT(with, 0.1 * plain) << plain;
  // zero mean delay: the shaped ramp crosses 0.5 where the ramp does (within a sample or two)
  auto crossing = [](const std::vector<double>& u) {
    std::size_t k = 0;
    while (k < u.size() && u[k] < 0.5) ++k;
    return static_cast<double>(k);
  };
  EXPECT_NEAR(crossing(rs), crossing(r), 2.0);
}

// The learning design's neighbours (docs/control.md, section 3): every one with a load mode
// passes through the relay's point, G(i w_u) = F(i w_u) H(i w_u) = -1 / K_u, as the identified
// loop does; the identified loop is among them; the slope, dead time and lag are scaled as
// before. With the identified mode kept (the rule before 2026-11-26) a neighbour with 1.5x the
// dead time misses the point by far more than the tolerance.
// The note of a learning run that ends above the loop it learns on says whether it was still
// falling and, at the last period's rate, whether more periods would bring it below: a run
// that falls by 0.2 % per period must not read as "more periods continue it".
TEST(ExperimentTuning, LearningAboveItsLoopSaysHowFarItIsFromBelow) {
  auto run = [](std::vector<double> rms) {
    TrackingRun r;
    r.variant = "learning";
    r.reference = "sine";
    for (double x : rms) {
      TrackingErrors e;
      e.rms_error_mm = x;
      r.periods.push_back(e);
    }
    r.errors = r.periods.back();
    return r;
  };
  TrackingRun base = run({0.4});
  base.variant = "compensated";
  // 0.6 -> 0.5 mm: q = 5/6, ln(0.4 / 0.5) / ln(5/6) = 1.22, so 2 more periods
  const std::string fast = experiment::learning_above_note(run({0.9, 0.6, 0.5}), base);
  EXPECT_EQ(fast.rfind("learning (sine): after 3 periods its RMS error, 0.500 mm, is above the compensated run's "
                       "0.400 mm",
                       0),
            0u)
      << fast;
  EXPECT_NE(fast.find("it was still falling (0.600 mm the period before; at that rate about 2 more period(s)"),
            std::string::npos)
      << fast;
  // 5.057 -> 5.048 mm against 3.790: 143 periods at that rate, beyond the horizon
  base.errors.rms_error_mm = 3.790;
  const std::string slow = experiment::learning_above_note(run({6.4, 5.057, 5.048}), base);
  EXPECT_NE(slow.find("it was still falling, but by only 0.18 % per period (5.057 mm the period before): at that "
                      "rate it would not come below within 100 more periods"),
            std::string::npos)
      << slow;
  EXPECT_EQ(slow.find("about"), std::string::npos) << slow;
  const std::string risen = experiment::learning_above_note(run({6.4, 5.0, 5.1}), base);
  EXPECT_NE(risen.find("it was no longer falling"), std::string::npos) << risen;
  EXPECT_EQ(risen.find("still falling"), std::string::npos) << risen;
  // the cause, from the periods: never below the base run, and its first period says how far
  // its loop started above
  EXPECT_NE(risen.find("(it learns on a more robust, slower loop: its first period, before any correction, was "
                       "6.400 mm, and no period came below)"),
            std::string::npos)
      << risen;
  // below the base run in one period, and above it after: which period, and that it rose
  const std::string back = experiment::learning_above_note(run({6.4, 3.5, 3.7, 3.9}), base);
  EXPECT_NE(back.find("(it was below in period 2, 3.500 mm, and rose after it); it was no longer falling"),
            std::string::npos)
      << back;
  EXPECT_EQ(back.find("slower loop"), std::string::npos) << back;
  // risen above an earlier period and falling a little at the end (1.054 -> 2.857 -> 2.835 mm
  // on a 2 kg load, against 2.509): no extrapolation of the last fall
  base.errors.rms_error_mm = 2.509;
  const std::string rose = experiment::learning_above_note(run({1.054, 2.857, 2.835}), base);
  EXPECT_NE(rose.find("its last period fell a little (2.857 mm the period before), but period 1 was lower, 1.054 mm: "
                      "it is not converging, and more periods would not bring it below"),
            std::string::npos)
      << rose;
  EXPECT_EQ(rose.find("--learning-periods"), std::string::npos) << rose;
  EXPECT_EQ(rose.find("still falling"), std::string::npos) << rose;
}

// The learning loop's PID follows the gain trial where the trial detunes the classic rule's
// gains (scale < 1: the relay overstated the loop's margin), and keeps the robust rule where the
// trial chose 1 or more. Rig w07 of `bench/variants_random.py 7 30 --wide` (a 42 kPa band
// nearly as wide as the relay's +-0.05 MPa, K_u 50 MPa/m against the nominal 13, a 28 kPa
// pressure offset, a weak muscle) chose x0.63 with mpi-asym pinned, and gpi-pid's learning on
// the unscaled rule rang at 2.451 mm RMS after 10 periods, 5.8x its compensated run's 0.423 mm
// (0.179 mm scaled).
TEST(ExperimentTuning, LearningPidFollowsTheGainTrialWhereItDetunes) {
  ExperimentOptions o;
  ExperimentResult res;
  const RigDynamics d = relay_identified(0.021, 0.056, 0.197e-3, 13.0, 0.239);
  experiment::Context c{o, res, d, 1e-3, 76, PidParams{}};
  c.learning = true;
  const PidParams rule = experiment::learning_pid(d, 1e-3, kPaperMax);
  for (double scale : {0.5, 0.79, 1.0, 1.26, 1.59}) {
    c.gain_scale = scale;
    const PidParams p = experiment::position_pid(c);
    const double s = std::min(1.0, scale);
    EXPECT_DOUBLE_EQ(p.kp, s * rule.kp) << scale;
    EXPECT_DOUBLE_EQ(p.ki, s * rule.ki) << scale;
    EXPECT_DOUBLE_EQ(p.kd, s * rule.kd) << scale;
    EXPECT_EQ(p.derivative_filter, rule.derivative_filter);
  }
  // end to end on that rig: the learning run ends below the compensated one
  PamRigParams rig;
  rig.regulator.time_constant = 0.066189389;
  rig.sensors.pressure_noise = 1368.2;
  rig.hysteresis.pressure_band = 42063.9;
  rig.hysteresis.transition_strain = 0.010168872;
  rig.sensors.pressure_offset = 27721.1;
  rig.muscle.force_620 = 708.67;
  ExperimentOptions eo = gpi_pid_options(rig, 10, true);
  const ExperimentResult r = run_experiment(eo);
  ASSERT_EQ(r.gain_trials.size(), 1u);
  ASSERT_LT(r.gain_trials[0].scale, 1.0) << "the trial no longer detunes on this rig: the test's premise";
  const TrackingRun& learning = find_run(r, "learning");
  EXPECT_LT(learning.errors.rms_error_mm, find_run(r, "compensated").errors.rms_error_mm);
  EXPECT_NE(learning.description.find(fmt::format("x{:.2f} as the gain trial scaled", r.gain_trials[0].scale)),
            std::string::npos)
      << learning.description;
}

namespace {
// A tracking run of the sine by `variant` with an RMS error of `rms_mm`, for the notes' tests.
TrackingRun sine_run(const char* variant, double rms_mm) {
  TrackingRun r;
  r.variant = variant;
  r.reference = "sine";
  r.errors.rms_error_mm = rms_mm;
  return r;
}
}  // namespace

// A compensated loop that does no better than the baseline (65 kg before the position relay
// moved to mid-stroke: 16.2 against 7.4 mm) says so; one below it says nothing.
TEST(ExperimentTuning, LoopNotBelowTheBaselineSaysSo) {
  const TrackingRun base = sine_run("baseline", 7.403);
  TrackingRun run = sine_run("compensated", 16.177);
  const std::string note = experiment::above_baseline_note(run, base);
  EXPECT_EQ(note.rfind("compensated (sine): its RMS error, 16.177 mm, is not below the baseline's 7.403 mm", 0), 0u)
      << note;
  EXPECT_NE(note.find("does no better than no compensation"), std::string::npos) << note;
  EXPECT_NE(note.find("relay tests above are suspect"), std::string::npos) << note;
  // on a rig that changed after its identification, the note names that as the cause
  const std::string changed = experiment::above_baseline_note(run, base, true);
  EXPECT_EQ(changed.rfind("compensated (sine): its RMS error, 16.177 mm, is not below the baseline's 7.403 mm", 0), 0u);
  EXPECT_NE(changed.find("differs from it"), std::string::npos) << changed;
  EXPECT_EQ(changed.find("suspect"), std::string::npos) << changed;
  EXPECT_NE(changed.find("or use the learning variant"), std::string::npos) << changed;
  TrackingRun learning = run;
  learning.variant = "learning";  // it does not advise itself
  EXPECT_EQ(experiment::above_baseline_note(learning, base, true).find("learning variant"), std::string::npos);
  run.errors.rms_error_mm = 7.403;  // equal is not below
  EXPECT_FALSE(experiment::above_baseline_note(run, base).empty());
  run.errors.rms_error_mm = 0.446;
  EXPECT_TRUE(experiment::above_baseline_note(run, base).empty());
}

// An adaptive run above the compensated one says so (a pressure sensor's offset of 30 kPa after
// the identification: gpi-pid adaptive 0.731 against 0.363 mm, 2026-11-29), and names a changed
// tracking rig; one below, or equal, says nothing.
TEST(ExperimentTuning, AdaptiveAboveTheCompensatedRunSaysSo) {
  const TrackingRun comp = sine_run("compensated", 0.363);
  TrackingRun run = sine_run("adaptive", 0.731);
  const std::string note = experiment::adaptive_above_note(run, comp);
  EXPECT_EQ(note.rfind("adaptive (sine): its RMS error, 0.731 mm, is above the compensated run's 0.363 mm (+101.4 %)", 0),
            0u) << note;
  EXPECT_EQ(note.find("--tracking-plant"), std::string::npos) << note;
  const std::string changed = experiment::adaptive_above_note(run, comp, true);
  EXPECT_NE(changed.find("(--tracking-plant) differs from the identified one"), std::string::npos) << changed;
  run.errors.rms_error_mm = 0.363;
  EXPECT_TRUE(experiment::adaptive_above_note(run, comp, true).empty());
  run.errors.rms_error_mm = 0.2;
  EXPECT_TRUE(experiment::adaptive_above_note(run, comp).empty());
  // the changed rig's note lists every parameter that differs, and only those
  PamRigParams a, b;
  b.load.mass = 35.0;
  b.sensors.pressure_offset = 3e4;
  const std::string rig = experiment::changed_rig_note(a, b);
  EXPECT_NE(rig.find("in 2 parameter(s): load.mass: 20.0 -> 35.0; sensors.pressure_offset: 0.0 -> 30000.0;"),
            std::string::npos) << rig;
}

// A fit of the rig's dynamics on the grid's bound says so (a 1 s dead time fitted as 300 ms
// dead time and 300 ms lag, silently: audit of 2026-11-29); one inside it says nothing.
TEST(ExperimentTuning, DynamicsOnTheSearchBoundAreNamed) {
  RigDynamics d;
  d.dead_time_s = 0.3;
  d.lag_s = 0.3;
  const std::string note = experiment::dynamics_bound_note(d, 0.12, 1e-3);
  EXPECT_NE(note.find("sit on the search's bound of 300 ms (dead time 300 ms, lag 300 ms)"), std::string::npos) << note;
  d.dead_time_s = 0.012;
  EXPECT_NE(experiment::dynamics_bound_note(d, 0.3, 1e-3).find("(lag 300 ms, the feedforward's lead 300 ms)"),
            std::string::npos);
  d.lag_s = 0.299;  // inside by more than half a sample
  EXPECT_TRUE(experiment::dynamics_bound_note(d, 0.076, 1e-3).empty());
  d.lag_s = 0.2995;  // at a 0.5 ms period the grid's last point is 300 ms, and this its last but one
  EXPECT_TRUE(experiment::dynamics_bound_note(d, 0.076, 0.5e-3).empty());
  d.lag_s = 0.3;
  EXPECT_FALSE(experiment::dynamics_bound_note(d, 0.076, 0.5e-3).empty());
}

// A compensated run above the faithful one (the paper's loop and published gains) says so: an
// 80 kg load gave gpi-pid compensated 0.654 mm against faithful 0.585 mm, silently (audit of
// 2026-11-29); one below or equal says nothing.
TEST(ExperimentTuning, CompensatedAboveTheFaithfulRunSaysSo) {
  const TrackingRun faithful = sine_run("faithful", 0.585);
  TrackingRun comp = sine_run("compensated", 0.654);
  const std::string note = experiment::faithful_below_note(comp, faithful);
  EXPECT_EQ(note.rfind("compensated (sine): its RMS error, 0.654 mm", 0), 0u) << note;
  EXPECT_NE(note.find("above the faithful run's 0.585 mm"), std::string::npos) << note;
  EXPECT_NE(note.find("+11.8 %"), std::string::npos) << note;
  EXPECT_EQ(note.find("--tracking-plant"), std::string::npos) << note;
  EXPECT_NE(experiment::faithful_below_note(comp, faithful, true).find("--tracking-plant"), std::string::npos);
  comp.errors.rms_error_mm = 0.585;
  EXPECT_TRUE(experiment::faithful_below_note(comp, faithful).empty());
  comp.errors.rms_error_mm = 0.3;
  EXPECT_TRUE(experiment::faithful_below_note(comp, faithful).empty());
}

// A pressure that levels off below the command at the top is named as capped (a 4 bar supply on
// the rig tracked on); one still rising through the regulator's lag at the end of a short
// stretch, or levelling off at the top, is not.
TEST(ExperimentTuning, PressureLevelledOffBelowTheTopIsNamedAsCapped) {
  const auto run_with = [](double level_mpa, double lag_s, std::size_t stretch) {
    TrackingRun r = sine_run("compensated", 5.0);
    const double dt = 1e-3;
    double p = 0.0;
    for (std::size_t k = 0; k < 2 * stretch; ++k) {
      const bool top = k >= stretch / 2 && k < stretch / 2 + stretch;
      const double cmd = top ? kPaperMax : 0.2;
      p += dt / lag_s * (std::min(cmd, level_mpa) - p);  // a first-order lag to what the actuator gives
      r.t.push_back(static_cast<double>(k) * dt);
      r.pressure_command_mpa.push_back(cmd);
      r.pressure_measured_mpa.push_back(p);
      r.reference_mm.push_back(50.0);
      r.measured_mm.push_back(top ? 40.0 : 50.0);
    }
    return r;
  };
  // capped at 0.3 MPa: named, with the identification run's reach and the changed rig
  const TrackingRun capped = run_with(0.3, 0.05, 2000);
  const std::optional<experiment::CappedTop> c = experiment::capped_top(capped, 0, capped.t.size(), kPaperMax);
  ASSERT_TRUE(c.has_value());
  EXPECT_NEAR(c->level_mpa, 0.3, 1e-3);
  EXPECT_NEAR(c->stretch_s, 1.999, 1e-9);
  const std::string note = experiment::saturation_note(capped, 0, capped.t.size(), 0.59, true, kPaperMax);
  EXPECT_NE(note.find("levelled off at 0.300 MPa, where the identification run reached 0.590 MPa"), std::string::npos)
      << note;
  EXPECT_NE(note.find("identify on the rig as it is now"), std::string::npos) << note;
  // the same cap where the identification run saw it too: no claim about the identified rig
  const std::string same = experiment::saturation_note(capped, 0, capped.t.size(), 0.3, false, kPaperMax);
  EXPECT_NE(same.find("levelled off at 0.300 MPa:"), std::string::npos) << same;
  EXPECT_EQ(same.find("identification run reached"), std::string::npos) << same;
  // the actuator reaches the top: the generic wording
  const TrackingRun full = run_with(1.0, 0.05, 2000);
  EXPECT_FALSE(experiment::capped_top(full, 0, full.t.size(), kPaperMax).has_value());
  EXPECT_NE(experiment::saturation_note(full, 0, full.t.size(), 0.59, true, kPaperMax).find("no authority left"),
            std::string::npos);
  // a stretch too short for a 300 ms lag to settle: still rising, not capped
  const TrackingRun rising = run_with(1.0, 0.3, 300);
  EXPECT_FALSE(experiment::capped_top(rising, 0, rising.t.size(), kPaperMax).has_value());
}

// The learning variant's feedforward goes through the shaper the gain trial chose for the
// compensated loop of the same reference (docs/control.md, section 3, "The feedforward's
// shaper"): said in its description exactly where the trial chose shaping, and on mpi-pwm's
// triangle, where the valves saturate at the top reversal and the load mode rings, its largest
// error after 10 periods is below the same run's without the shaper. Without shaping the runs
// are the same.
TEST(ExperimentTuning, LearningFeedforwardGoesThroughTheTrialsShaper) {
  ExperimentOptions o;
  o.name = "mpi-pwm";
  o.adaptive = false;
  o.model = FitModel::mpi_asym;
  o.learning_periods = 10;
  const ExperimentResult with = run_experiment(o);
  const bool before = experiment::set_learning_shaper(false);
  ExperimentResult without;
  try {
    without = run_experiment(o);
  } catch (...) {
    experiment::set_learning_shaper(before);
    throw;
  }
  experiment::set_learning_shaper(before);
  ASSERT_EQ(with.gain_trials.size(), 2u);
  int shaped = 0;
  for (const GainTrial& g : with.gain_trials) {
    const TrackingRun *a = nullptr, *b = nullptr;
    for (const TrackingRun& r : with.runs)
      if (r.variant == "learning" && r.reference == g.reference) a = &r;
    for (const TrackingRun& r : without.runs)
      if (r.variant == "learning" && r.reference == g.reference) b = &r;
    ASSERT_TRUE(a && b) << g.reference;
    const bool says = a->description.find("gain trial's zero-vibration shaper") != std::string::npos;
    EXPECT_EQ(says, g.shaped) << g.reference << ": " << a->description;
    EXPECT_EQ(b->description.find("zero-vibration shaper"), std::string::npos) << b->description;
    if (!g.shaped) {
      EXPECT_EQ(a->errors.rms_error_mm, b->errors.rms_error_mm) << g.reference;
      continue;
    }
    ++shaped;
    EXPECT_NE(a->errors.rms_error_mm, b->errors.rms_error_mm) << g.reference;
    if (g.reference == "triangle") {
      EXPECT_LT(a->errors.max_error_mm, b->errors.max_error_mm);
    }
  }
  EXPECT_GE(shaped, 1);
  // every loop of the cascade says its valves' pressure loop (result.json "controller"): the
  // paper's P loop (20 duty/MPa) in the faithful and baseline loops, the relay's PI in the others
  for (const TrackingRun& r : with.runs) {
    ASSERT_TRUE(r.controller.pressure_pid) << r.variant;
    EXPECT_EQ(r.controller.pressure_gain, 0.0);
    const PidParams& q = *r.controller.pressure_pid;
    if (r.variant == "faithful" || r.variant == "baseline") {
      EXPECT_EQ(q.kp, 20.0) << r.variant;
      EXPECT_EQ(q.ki, 0.0) << r.variant;
    } else {
      EXPECT_NE(r.description.find(fmt::format("PI pressure loop by a relay test (Kp = {:.3g}/MPa, Ki = {:.3g}/(MPa s))",
                                               q.kp, q.ki)),
                std::string::npos)
          << r.variant << ": " << r.description;
      EXPECT_GT(q.ki, 0.0) << r.variant;
    }
  }
}

// A run's "controller" (result.json; docs/deploy.md) holds every number its loop needs: the
// compensated loop rebuilt from it and the fitted model (make_controller: FeedforwardPidController,
// feedforward_preview: through the shaper, lead samples ahead) gives the run's pressure commands, and an
// IterativeLearning built from the learning run's parameters, fed the run's errors, gives the
// corrections the run applied and ends where its supervisor ended. Both survive the output
// directory (result.json and the tracking CSVs, read back by read_experiment_dir).
TEST(ExperimentTuning, ControllerNumbersReproduceTheRunsLoops) {
  const ExperimentResult r = run_experiment(gpi_pid_options(PamRigParams{}, 3, true));
  const double tc = 1e-3;
  const TrackingRun& comp = find_run(r, "compensated");
  const LoopDesign& d = comp.controller;
  ASSERT_TRUE(d.pid);
  ASSERT_TRUE(d.shaper);  // the gain trial shapes gpi-pid's nominal sine (docs/control.md, section 2)
  EXPECT_GT(d.feedforward_lead, 0u);
  EXPECT_EQ(d.sample_time, tc);
  EXPECT_NEAR(static_cast<double>(d.feedforward_lead) * d.sample_time, r.lead_s, 1e-12);
  EXPECT_NE(comp.description.find(fmt::format("Kp = {:.3g} MPa/m", d.pid->kp)), std::string::npos) << comp.description;
  {
    const std::size_t n = comp.t.size();
    std::vector<double> ref(n);
    for (std::size_t k = 0; k < n; ++k) ref[k] = comp.reference_mm[k] * 1e-3;
    const std::vector<double> preview = feedforward_preview(d, ref);
    EXPECT_EQ(d.kind, LoopDesign::Kind::feedforward_pid);
    Controller c = make_controller(d, r.best_fit.model);
    ASSERT_TRUE(std::holds_alternative<FeedforwardPidController>(c));
    auto& loop = std::get<FeedforwardPidController>(c);
    double worst = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const double u = loop.step(ref[k], preview[k], comp.measured_mm[k] * 1e-3);
      worst = std::max(worst, std::abs(std::clamp(u, 0.0, kPaperMax) - comp.pressure_command_mpa[k]));
    }
    EXPECT_LT(worst, 1e-9) << "MPa";
  }
  const TrackingRun& lr = find_run(r, "learning");
  ASSERT_TRUE(lr.controller.learning);
  const LoopDesign::Learning& l = *lr.controller.learning;
  EXPECT_EQ(l.params.lookahead, lr.controller.feedforward_lead);
  EXPECT_NE(lr.description.find(fmt::format("half-width {}", l.params.half_width)), std::string::npos);
  ASSERT_EQ(lr.correction_mm.size(), lr.t.size());
  IterativeLearning ilc(l.params);
  double worst = 0.0, largest = 0.0;
  for (std::size_t k = 0; k < lr.t.size(); ++k) {
    const double c = ilc.correction(0) * 1e3;
    worst = std::max(worst, std::abs(c - lr.correction_mm[k]));
    largest = std::max(largest, std::abs(c));
    const double cmd = lr.pressure_command_mpa[k];
    const bool saturated = cmd <= 0.0 || cmd >= kPaperMax;
    ilc.step(saturated ? 0.0 : (lr.reference_mm[k] - lr.measured_mm[k]) * 1e-3);
  }
  EXPECT_LT(worst, 1e-9) << "mm";
  EXPECT_GT(largest, 0.05) << "mm: the run learnt a correction";
  EXPECT_EQ(ilc.iteration(), 3u);
  EXPECT_EQ(ilc.gain(), l.final_gain);
  EXPECT_EQ(ilc.gain_cuts(), l.gain_cuts);
  EXPECT_EQ(ilc.gain_raises(), l.gain_raises);
  EXPECT_EQ(ilc.held(), l.held);
  // the output directory's writer and reader (result.json and the tracking CSVs)
  test::TempDir dir;
  r.write(dir.file("out"));
  const ExperimentResult back = report::read_experiment_dir(dir.file("out"));
  ASSERT_EQ(back.runs.size(), r.runs.size());
  for (std::size_t i = 0; i < r.runs.size(); ++i)
    EXPECT_EQ(io::to_json(back.runs[i].controller), io::to_json(r.runs[i].controller)) << r.runs[i].variant;
  EXPECT_FALSE(find_run(back, "faithful").controller.shaper);
  EXPECT_TRUE(find_run(back, "learning").controller.learning);
  EXPECT_EQ(find_run(back, "learning").correction_mm, lr.correction_mm);
  EXPECT_TRUE(find_run(back, "compensated").correction_mm.empty());
}

// The learning loop's derivative time (docs/control.md, section 2): of T_u / 3 (the "some
// overshoot" rule's), T_u / 2 and 2 T_u / 3, the one whose identified feedback loop has the least
// complementary sensitivity peak among those whose sensitivity peak is at most the rule's. The
// regulator rig's well-damped loop keeps T_u / 3; the valve rig's lightly damped mode gets a
// longer one; the 5 kg valve rig, whose complementary peak a longer T_d lowers a little but whose
// sensitivity peak it raises, keeps T_u / 3. K_c and T_i stay the rule's.
TEST(ExperimentTuning, LearningDerivativeTimeDampsTheIdentifiedLoop) {
  const double tc = 1e-3;
  const RigDynamics regulator = relay_identified(0.021, 0.056, 0.197, 13.0, 0.239);  // gpi-pid's nominal
  const RigDynamics valves = relay_identified(0.0, 0.008, 0.200, 12.3, 0.238);       // mpi-pwm's nominal
  const RigDynamics light = relay_identified(0.0, 0.013, 0.248, 30.7, 0.172);        // mpi-pwm, 5 kg load
  ASSERT_GT(regulator.mode_damping, 0.5);
  ASSERT_GT(valves.mode_frequency_hz, 0.0);
  ASSERT_LT(valves.mode_damping, 0.2);
  const auto with_td = [](PidParams p, double td, double Tu) {
    p.kd = p.kp * td * Tu;
    return p;
  };
  for (const RigDynamics* d : {&regulator, &valves, &light}) {
    const PidParams rule =
        experiment::relay_pid(*d, tc, -kPaperMax, kPaperMax, experiment::PidRule::some_overshoot);
    const PidParams p = experiment::learning_pid(*d, tc, kPaperMax);
    EXPECT_DOUBLE_EQ(p.kp, rule.kp);
    EXPECT_DOUBLE_EQ(p.ki, rule.ki);
    EXPECT_DOUBLE_EQ(p.derivative_filter, rule.derivative_filter);
    const experiment::LoopPeaks chosen = experiment::loop_peaks(*d, p, tc), at_rule = experiment::loop_peaks(*d, rule, tc);
    EXPECT_GT(chosen.complementary, 1.0);  // a peak: |T| reaches 1 at low frequencies
    EXPECT_LE(chosen.sensitivity, at_rule.sensitivity);
    for (double td : {1.0 / 3.0, 0.5, 2.0 / 3.0}) {
      const experiment::LoopPeaks q = experiment::loop_peaks(*d, with_td(rule, td, d->position_relay_period_s), tc);
      if (q.sensitivity <= at_rule.sensitivity) {
        EXPECT_LE(chosen.complementary, q.complementary) << td;
      }
    }
  }
  const PidParams reg = experiment::learning_pid(regulator, tc, kPaperMax);
  EXPECT_NEAR(reg.kd / reg.kp, regulator.position_relay_period_s / 3.0, 1e-12);
  const PidParams val = experiment::learning_pid(valves, tc, kPaperMax);
  EXPECT_GT(val.kd / val.kp, valves.position_relay_period_s / 3.0 * 1.2);
  // the light rig: a longer T_d would lower the complementary peak, but raise the sensitivity's
  const PidParams rule_light =
      experiment::relay_pid(light, tc, -kPaperMax, kPaperMax, experiment::PidRule::some_overshoot);
  const experiment::LoopPeaks half = experiment::loop_peaks(light, with_td(rule_light, 0.5, light.position_relay_period_s), tc);
  const experiment::LoopPeaks third = experiment::loop_peaks(light, rule_light, tc);
  EXPECT_LT(half.complementary, third.complementary);
  EXPECT_GT(half.sensitivity, third.sensitivity);
  EXPECT_DOUBLE_EQ(experiment::learning_pid(light, tc, kPaperMax).kd, rule_light.kd);
}

TEST(ExperimentTuning, LearningNeighboursPassThroughTheRelaysPoint) {
  using C = std::complex<double>;
  const RigDynamics d = relay_identified(0.021, 0.056, 0.197, 13.0, 0.239);  // gpi-pid's nominal loop
  ASSERT_GT(d.mode_frequency_hz, 0.0);
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const auto G = [&](const RigDynamics& v) {
    C g = v.gain_m_per_mpa * std::polar(1.0, -wu * v.dead_time_s) / C(1.0, wu * v.lag_s);
    if (v.mode_frequency_hz > 0.0) {
      const double wn = 2.0 * std::numbers::pi * v.mode_frequency_hz;
      g *= wn * wn / C(wn * wn - wu * wu, 2.0 * v.mode_damping * wn * wu);
    }
    return g;
  };
  EXPECT_NEAR(std::abs(G(d) * d.position_relay_gain + 1.0), 0.0, 1e-9);
  const std::vector<RigDynamics> nb = experiment::learning_neighbours(d);
  std::size_t with_mode = 0, without = 0;
  bool identified = false;
  for (const RigDynamics& v : nb) {
    identified = identified || v == d;
    if (v.mode_frequency_hz > 0.0) {
      ++with_mode;
      EXPECT_NEAR(std::abs(G(v) * v.position_relay_gain + 1.0), 0.0, 1e-9)
          << v.dead_time_s << " " << v.lag_s << " " << v.gain_m_per_mpa;
    } else {
      ++without;
    }
    const double ft = v.dead_time_s / d.dead_time_s, fl = v.lag_s / d.lag_s, fk = v.gain_m_per_mpa / d.gain_m_per_mpa;
    EXPECT_TRUE(std::abs(ft - 1.0) < 1e-12 || std::abs(ft - 1.5) < 1e-12) << ft;
    for (double f : {fl, fk})
      EXPECT_TRUE(std::abs(f - 0.67) < 1e-12 || std::abs(f - 1.0) < 1e-12 || std::abs(f - 1.5) < 1e-12) << f;
  }
  EXPECT_TRUE(identified);
  EXPECT_EQ(without, 18u);
  EXPECT_GT(with_mode, 9u);
  EXPECT_LE(with_mode, 18u);
  // Neighbours::with_mode: the same neighbours with the mode, none of the twins without it
  const std::vector<RigDynamics> kept_mode = experiment::learning_neighbours(d, experiment::Neighbours::with_mode);
  EXPECT_EQ(kept_mode.size(), with_mode);
  for (const RigDynamics& v : kept_mode) {
    EXPECT_GT(v.mode_frequency_hz, 0.0);
    EXPECT_NE(std::find(nb.begin(), nb.end(), v), nb.end());
  }
  RigDynamics kept = d;  // the identified mode on a 1.5x dead time
  kept.dead_time_s *= 1.5;
  EXPECT_GT(std::abs(G(kept) * kept.position_relay_gain + 1.0), 0.1);
  // no mode identified: no neighbour has one
  RigDynamics plain = d;
  plain.mode_frequency_hz = plain.mode_damping = 0.0;
  for (const RigDynamics& v : experiment::learning_neighbours(plain)) EXPECT_EQ(v.mode_frequency_hz, 0.0);
  EXPECT_EQ(experiment::learning_neighbours(plain).size(), 18u);
  EXPECT_EQ(experiment::learning_neighbours(plain, experiment::Neighbours::with_mode),
            experiment::learning_neighbours(plain));
}

// A FOPDT with more phase lag at the relay's frequency than the relay measured (beyond -180
// degrees at w_u), which no load mode can explain: its dead time and lag are split again, their
// sum kept, so that it reaches -180 degrees at w_u. The numbers are gpi-pid's on a regulator of
// 300 ms / 40 ms (docs/plant.md's extreme set): there the least squares gave 145 / 215 ms, and
// the learning loop, designed on it, took the longest derivative time and rang (3.24 mm RMS
// after 10 periods, 4x the compensated loop's).
TEST(ExperimentTuning, FopdtReachesTheRelaysPhaseWhereNoModeCan) {
  RigDynamics d = relay_identified(0.145, 0.215, 0.1755, 33.0, 0.391);
  ASSERT_EQ(d.mode_frequency_hz, 0.0);  // the premise: no mode fits
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const auto phase_lag = [&](const RigDynamics& v) { return wu * v.dead_time_s + std::atan(wu * v.lag_s); };  // -arg F
  ASSERT_GT(phase_lag(d), std::numbers::pi + 0.3);  // and it is beyond -180 degrees
  ASSERT_TRUE(experiment::fit_fopdt_to_relay_phase(d));
  EXPECT_NEAR(phase_lag(d), std::numbers::pi, 1e-9);
  EXPECT_NEAR(d.dead_time_s + d.lag_s, 0.36, 1e-12);
  EXPECT_EQ(d.gain_m_per_mpa, 0.1755);
  EXPECT_GT(d.dead_time_s, 0.0);
  EXPECT_LT(d.dead_time_s, 0.145);
  // a loop with a mode through the point, and one without a mode whose FOPDT stays short of
  // -180 degrees (gpi-pid on rig w03 of variants_random.py 7 30 --wide: K_u 56.8 MPa/m, 4x the
  // nominal rig's, so the FOPDT's gain at w_u is too high for a mode), are left as they are
  for (RigDynamics v : {relay_identified(0.021, 0.056, 0.197, 13.0, 0.239), relay_identified(0.07, 0.14, 0.181, 56.8, 0.297)}) {
    const RigDynamics before = v;
    EXPECT_FALSE(experiment::fit_fopdt_to_relay_phase(v)) << before.mode_frequency_hz;
    EXPECT_EQ(v, before);
  }
  // end to end on that rig: the note, and learning that ends below the compensated loop
  PamRigParams slow;
  slow.regulator.time_constant = 0.3;
  slow.regulator.dead_time = 0.04;
  const ExperimentResult r = run_experiment(gpi_pid_options(slow, 10, true));
  bool noted = false;
  for (const std::string& m : r.messages) noted = noted || m.find("split again, their sum kept") != std::string::npos;
  EXPECT_TRUE(noted) << r.table();
  const double wr = 2.0 * std::numbers::pi / r.dynamics.position_relay_period_s;
  EXPECT_NEAR(wr * r.dynamics.dead_time_s + std::atan(wr * r.dynamics.lag_s), std::numbers::pi, 1e-9);
  EXPECT_LT(find_run(r, "learning").errors.rms_error_mm, find_run(r, "compensated").errors.rms_error_mm) << r.table();
}

// Where no learning filter contracts on the identified loop and its neighbours, the design is
// tried again on models that agree with the position relay's point. Without a mode, where the
// FOPDT has more gain at the relay's frequency than the relay measured, on the FOPDT put through
// the point, gain and phase (fit_fopdt_through_relay_point): rig w16 of `bench/variants_random.py
// 10 20 --wide` (a 0.53 m muscle, a 221 ms regulator, the band's transition at 1.8 % strain),
// whose FOPDT of 95 ms dead time and 152 ms lag has 1.4x the relay's gain at w_u; no filter
// contracted (rho >= 1.40) and gpi-pid ran no learning; through the point the lag is 220 ms, the
// regulator's own. With a mode, on the neighbours that keep it (Neighbours::with_mode): the 0.4 m
// muscle of the outside set, where a twin without the mode sat at the edge of stability.
TEST(ExperimentTuning, LearningIsDesignedOnModelsThroughTheRelaysPointWhereNoFilterContracts) {
  RigDynamics d = relay_identified(0.095, 0.152, 0.197, 21.9, 0.331);
  ASSERT_EQ(d.mode_frequency_hz, 0.0);  // the premise: no mode fits
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const auto at_wu = [&](const RigDynamics& v) {  // F(i w_u) K_u
    return v.gain_m_per_mpa * v.position_relay_gain * std::polar(1.0, -wu * v.dead_time_s) /
           std::complex<double>(1.0, wu * v.lag_s);
  };
  ASSERT_GT(std::abs(at_wu(d)), 1.3);  // the FOPDT's gain at w_u is too high for the relay's point
  ASSERT_TRUE(experiment::fit_fopdt_through_relay_point(d));
  EXPECT_NEAR(std::abs(at_wu(d)), 1.0, 1e-9);
  EXPECT_NEAR(std::arg(-at_wu(d)), 0.0, 1e-9);  // -180 degrees
  EXPECT_EQ(d.gain_m_per_mpa, 0.197);
  EXPECT_NEAR(d.lag_s, 0.220, 0.002);
  // a loop with a mode, and one without whose slope is below 1 / K_u (no lag reaches the relay's
  // gain), are left as they are
  for (RigDynamics v : {relay_identified(0.021, 0.056, 0.197, 13.0, 0.239), relay_identified(0.15, 0.2, 0.05, 15.0, 0.3)}) {
    const RigDynamics before = v;
    EXPECT_TRUE(v.mode_frequency_hz > 0.0 || v.gain_m_per_mpa * v.position_relay_gain < 1.0);
    EXPECT_FALSE(experiment::fit_fopdt_through_relay_point(v));
    EXPECT_EQ(v, before);
  }
  // end to end, where no learning ran before: the fallback's note, and a learning run whose
  // error falls in every period to below half the compensated loop's
  const auto learns = [](const PamRigParams& rig, bool mode, const char* note) {
    const ExperimentResult r = run_experiment(gpi_pid_options(rig, 10, true));
    EXPECT_EQ(r.dynamics.mode_frequency_hz > 0.0, mode);
    EXPECT_TRUE(test::said(r, note)) << r.table();
    EXPECT_FALSE(test::said(r, "learning (sine) not run")) << r.table();
    const TrackingRun& learning = find_run(r, "learning");
    EXPECT_LT(learning.errors.rms_error_mm, 0.5 * find_run(r, "compensated").errors.rms_error_mm) << r.table();
    for (std::size_t j = 1; j < learning.periods.size(); ++j)
      EXPECT_LT(learning.periods[j].rms_error_mm, learning.periods[j - 1].rms_error_mm) << "period " << j + 1;
  };
  PamRigParams w16;
  w16.muscle.rest_length = 0.532981844;
  w16.hysteresis.transition_strain = 0.017600375;
  w16.regulator.time_constant = 0.221107866;
  learns(w16, false, "designed on the FOPDT put through the position relay's point");
  PamRigParams short_muscle;  // with a mode: the 0.4 m muscle
  short_muscle.muscle.rest_length = 0.4;
  learns(short_muscle, true, "designed on the neighbours that keep the load mode");
}

// Where no filter whose whole window (2h + 1 taps) fits in the period contracts, on the identified
// models or the relay's, the design tries the narrower filters whose summed taps fit
// (FilterWindow::summed_taps): their band ends further below the loop's resonance. gpi-pid on a
// 95 kg load (its mode 2.46 Hz, damping 0.04) ran no learning (least bound 1.48 at the widest
// half-width that fitted, 2377); with a half-width above half the period it learns, period after
// period, to below the compensated loop.
TEST(ExperimentTuning, LearningBandEndsBelowALightlyDampedModeWithANarrowerFilter) {
  PamRigParams heavy;
  heavy.load.mass = 95.0;
  ExperimentOptions o = gpi_pid_options(heavy, 10);
  o.adaptive = false;
  o.model = FitModel::gpi;
  const ExperimentResult r = run_experiment(o);
  EXPECT_GT(r.dynamics.mode_frequency_hz, 0.0);
  EXPECT_LT(r.dynamics.mode_damping, 0.1);
  EXPECT_TRUE(test::said(r, "with a narrower Q-filter, one whose summed taps, not its whole window, fit")) << r.table();
  const TrackingRun& learning = find_run(r, "learning");
  ASSERT_TRUE(learning.controller.learning && learning.controller.pid);
  const LearningParams& lp = learning.controller.learning->params;
  EXPECT_GE(lp.lead + 2 * lp.half_width + lp.lookahead, lp.period);  // its whole window does not fit
  EXPECT_LT(learning.controller.learning->contraction_bound, 0.98);
  // the design on the run's loop: nothing with the whole window, this filter with the summed taps
  double rho = 0.0;
  const PidParams& pid = *learning.controller.pid;
  const double tc = learning.controller.sample_time;
  EXPECT_THROW(experiment::design_learning(r.dynamics, pid, lp.lookahead, lp.period, tc, rho), Error);
  const LearningParams narrow = experiment::design_learning(r.dynamics, pid, lp.lookahead, lp.period, tc, rho,
                                                            experiment::Neighbours::all,
                                                            experiment::FilterWindow::summed_taps);
  EXPECT_EQ(narrow.half_width, lp.half_width);
  EXPECT_EQ(narrow.lead, lp.lead);
  EXPECT_EQ(narrow.gain, lp.gain);
  EXPECT_LT(learning.errors.rms_error_mm, 0.75 * find_run(r, "compensated").errors.rms_error_mm) << r.table();
  for (std::size_t j = 1; j < learning.periods.size(); ++j)
    EXPECT_LT(learning.periods[j].rms_error_mm, learning.periods[j - 1].rms_error_mm) << "period " << j + 1;
}

// The supervisor doubles L only as far as the identified loop itself promises a monotone
// decrease (experiment::learning_growth_limit): a 63 kg load with creep 3.7x as stiff as the
// default (w08 of the wide seed-31 draw of bench/variants_random.py) has its design at L = 0.05
// and its limit at 0.1. Doubled to 0.5, as before, its error fell for 5 periods, then grew at the
// load mode (2.2-3.2 Hz) and ended at 0.741 mm, above the compensated 0.509 mm.
TEST(ExperimentTuning, LearningGainGrowsOnlyWhereTheIdentifiedLoopContracts) {
  PamRigParams creep;
  creep.load.mass = 63.192337366;
  creep.hysteresis.creep_stiffness = 552.610274228;
  creep.hysteresis.creep_time = 6.133478514;
  ExperimentOptions o = gpi_pid_options(creep, 10);
  o.adaptive = false;
  o.model = FitModel::gpi;
  const ExperimentResult r = run_experiment(o);
  const TrackingRun& learning = find_run(r, "learning");
  ASSERT_TRUE(learning.controller.learning && learning.controller.pid);
  const LearningParams& lp = learning.controller.learning->params;
  EXPECT_GT(lp.max_gain, lp.gain);
  EXPECT_LT(lp.max_gain, 0.5);
  // the limit against the bound on the identified loop, computed here: it contracts, the next
  // larger gain the design tries does not
  const PidParams& pid = *learning.controller.pid;
  const double tc = learning.controller.sample_time;
  std::vector<double> w;
  std::vector<std::complex<double>> T;
  const double w0 = 2.0 * std::numbers::pi / static_cast<double>(lp.period);
  for (int l = 0; l < 600; ++l) {
    w.push_back(w0 * std::pow(std::numbers::pi / w0, l / 599.0));
    T.push_back(experiment::closed_loop(r.dynamics, pid, lp.lookahead, tc, w.back()));
  }
  LearningParams at = lp;
  at.gain = lp.max_gain;
  EXPECT_LT(learning_contraction(at, w, T), 1.0);
  const double* next = std::find(std::begin(experiment::kLearningGains), std::end(experiment::kLearningGains),
                                 lp.max_gain);
  ASSERT_NE(next, std::begin(experiment::kLearningGains));
  at.gain = *(next - 1);
  EXPECT_GE(learning_contraction(at, w, T), 1.0);
  EXPECT_NE(learning.description.find(fmt::format("L may grow to {}, the largest gain whose bound holds on the "
                                                  "identified loop itself)",
                                                  lp.max_gain)),
            std::string::npos)
      << learning.description;
  EXPECT_NE(learning.description.find("L doubled 1 time(s) after periods that were the best so far"),
            std::string::npos)
      << learning.description;
  for (std::size_t j = 1; j < learning.periods.size(); ++j)
    EXPECT_LT(learning.periods[j].rms_error_mm, learning.periods[j - 1].rms_error_mm) << "period " << j + 1;
  EXPECT_LT(learning.errors.rms_error_mm, find_run(r, "compensated").errors.rms_error_mm) << r.table();
}

// Where no filter contracts, the design's error says how near it came: the least bound it found,
// with its gain, lead and half-width, against the 0.98 it needs. A loop with 0.1 s dead time and
// a 0.15 s period, of which the feedforward's preview takes 0.1 s: the filter can be at most 24
// samples wide and passes the frequencies where the loop's phase has turned (the same loop with a
// 5 s period contracts).
TEST(ExperimentTuning, LearningDesignThatFindsNoFilterSaysHowNearItCame) {
  const RigDynamics d = relay_identified(0.1, 0.1, 0.2, 12.0, 0.5);
  const PidParams pid = experiment::relay_pid(d, 1e-3, -0.6, 0.6, experiment::PidRule::some_overshoot);
  double rho = 0.0;
  ASSERT_NO_THROW(experiment::design_learning(d, pid, 100, 5000, 1e-3, rho));
  EXPECT_LT(rho, 0.98);
  try {
    experiment::design_learning(d, pid, 100, 150, 1e-3, rho);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    const auto at = m.find("the least bound found is rho = ");
    ASSERT_NE(at, std::string::npos) << m;
    EXPECT_GE(std::stod(m.substr(at + 31)), 0.98) << m;
    EXPECT_NE(m.find("0.98 needed"), std::string::npos) << m;
  }
}

// The learning band ends at the position loop's ultimate frequency from its relay test
// (|Q(w_u)| <= 1/sqrt(2)), and with it mpi-openloop's learning (references with reversals at
// 40/35/30 mm) converges period after period on both references. With the
// widest band the identified linear loop allowed (|Q(w_u)| = 0.94) it stalled after the
// second period and grew again (0.418 0.242 0.267 0.266 0.235 ... 0.301 mm on the triangle).
TEST(ExperimentTuning, LearningBandEndsAtTheRelaysUltimateFrequency) {
  const ExperimentOptions o = test::quick_experiment("mpi-openloop", 5);
  const ExperimentResult r = run_experiment(o);
  const double wu = 2.0 * std::numbers::pi * o.control_period / r.dynamics.position_relay_period_s;
  int learning_runs = 0;
  for (const auto& run : r.runs) {
    if (run.variant != "learning") continue;
    ++learning_runs;
    const auto at = run.description.find("half-width ");
    ASSERT_NE(at, std::string::npos) << run.description;
    const auto h = static_cast<std::size_t>(std::stoul(run.description.substr(at + 11)));
    EXPECT_LE(binomial_response(h, wu), 1.0 / std::sqrt(2.0) + 1e-12) << run.reference << ": h = " << h;
    ASSERT_EQ(run.periods.size(), 5u);
    for (std::size_t j = 1; j < run.periods.size(); ++j)
      EXPECT_LT(run.periods[j].rms_error_mm, run.periods[j - 1].rms_error_mm) << run.reference << " period " << j;
    EXPECT_LT(run.periods.back().rms_error_mm, 0.5 * run.periods.front().rms_error_mm) << run.reference;
  }
  EXPECT_EQ(learning_runs, 2);
  // every loop says the paper's proportional pressure loop (k_p = 0.5) and has no valves' PI
  for (const auto& run : r.runs) {
    EXPECT_EQ(run.controller.pressure_gain, 0.5) << run.variant;
    EXPECT_FALSE(run.controller.pressure_pid) << run.variant;
    EXPECT_EQ(run.controller.pid.has_value(), run.variant != "faithful" && run.variant != "baseline") << run.variant;
  }
}

// The learning design at another control period designs the same Q-filter in seconds. Its band
// ends at the position relay's frequency w_u = 2 pi T_s / T_u [rad/sample], |Q(w_u)| =
// cos^(2h)(w_u / 2) <= 1/sqrt(2) (docs/control.md, section 3), so h grows as 1 / T_s^2 (the
// binomial filter's sigma, sqrt(h / 2) samples, is a fixed time). Counting its whole window,
// 2h + 1 taps, in the loop's own samples capped h at half the period, 1 / T_s: at 0.5 ms (gpi-pid's
// identified loop, a 5 s period) the floor no longer fitted, the band passed w_u (|Q(w_u)| =
// 0.82) and the learning run was 2x worse than at 1 ms (0.073 against 0.034 mm RMS).
TEST(ExperimentTuning, LearningFilterIsTheSameInSecondsAtEveryControlPeriod) {
  const RigDynamics d = relay_identified(0.021, 0.056, 0.197, 13.05, 0.239);
  const double q_limit = 1.0 / std::numbers::sqrt2;
  double band_hz_1ms = 0.0;
  for (const double tc : {1e-3, 5e-4, 2e-4}) {
    SCOPED_TRACE(fmt::format("T_s = {} s", tc));
    const PidParams pid = experiment::relay_pid(d, tc, -0.6, 0.6, experiment::PidRule::some_overshoot);
    const auto samples = [tc](double s) { return static_cast<std::size_t>(std::lround(s / tc)); };
    double rho = 0.0;
    const LearningParams lp = experiment::design_learning(d, pid, samples(0.076), samples(5.0), tc, rho);
    EXPECT_LT(rho, 0.98);
    const double wu = 2.0 * std::numbers::pi * tc / d.position_relay_period_s;
    const double h = static_cast<double>(lp.half_width);
    EXPECT_LE(std::pow(std::cos(0.5 * wu), 2.0 * h), q_limit * (1.0 + 1e-12)) << "h = " << lp.half_width;
    // the band's edge |Q| = 1/sqrt(2) in Hz: cos^(2h)(pi f T_s) = 1/sqrt(2)
    const double band_hz = std::acos(std::pow(q_limit, 1.0 / (2.0 * h))) / (std::numbers::pi * tc);
    if (tc == 1e-3) band_hz_1ms = band_hz;
    // the design steps h by a quarter: the band's edge within sqrt(1.25) of the 1 ms one
    EXPECT_NEAR(band_hz / band_hz_1ms, 1.0, std::sqrt(1.25) - 1.0) << band_hz << " Hz at 1 ms: " << band_hz_1ms;
  }
}

// The reach is read from a centred moving mean over 11 ms of the identification run (11 samples
// at 1 ms), at every control period: a unit step at 1 s shows in the mean from 5 ms before it
// (the window's half) and not 6 ms before. An 11-sample mean at 0.5 ms reached only 2.5 ms.
TEST(ExperimentReach, SmoothingWindowIsTheSameInSecondsAtEveryControlPeriod) {
  for (const double tc : {1e-3, 5e-4, 2e-4}) {
    SCOPED_TRACE(fmt::format("T_s = {} s", tc));
    IdentificationRun id;
    const auto at = [tc](double s) { return static_cast<std::size_t>(std::lround(s / tc)); };
    for (std::size_t k = 0; k < at(2.0); ++k) {
      id.t.push_back(static_cast<double>(k) * tc);
      id.contraction_mm.push_back(k >= at(1.0) ? 1.0 : 0.0);
      id.pressure_mpa.push_back(k >= at(1.0) ? 0.3 : 0.0);
      id.pressure_command_mpa.push_back(id.pressure_mpa.back());
    }
    const experiment::SmoothedRun sm(id, tc);
    EXPECT_GT(sm.x_mm[at(1.0 - 0.004)], 0.0);
    EXPECT_EQ(sm.x_mm[at(1.0 - 0.006)], 0.0);
    EXPECT_GT(sm.p[at(1.0 - 0.004)], 0.0);
    EXPECT_DOUBLE_EQ(sm.x_mm[at(1.5)], 1.0);
  }
}
