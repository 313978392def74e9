// Core models and inverses: operator properties, models against independent
// evaluations of their defining equations, exact inverses, invalid parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/models.hpp"

#include "test_util.hpp"

using namespace hysteron;

namespace {

using hysteron::test::random_walk;

std::vector<double> sorted_thresholds(std::mt19937_64& rng, int n, double rmax) {
  std::uniform_real_distribution<double> u(0.01 * rmax, rmax);
  std::vector<double> r(n);
  for (auto& v : r) v = u(rng);
  return r;  // unsorted on purpose: the model sorts
}

GpiParams random_gpi(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GpiParams g;
  g.envelope = Envelope::tanh(0.5 + u(rng), 0.5 + 2 * u(rng), -0.5 + u(rng), -0.2 + 0.4 * u(rng));
  g.q = 0.2 + u(rng);
  g.n = 10;
  g.alpha = 0.02 + 0.05 * u(rng);
  g.rho = 0.1 + u(rng);
  g.tau = 1 + 5 * u(rng);
  g.input_limits = {-1.0, 1.0};
  return g;
}

PiParams random_pi(std::mt19937_64& rng, bool allow_negative) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PiParams p;
  p.q = 0.5 + u(rng);
  p.r = sorted_thresholds(rng, 12, 0.8);
  for (std::size_t i = 0; i < p.r.size(); ++i) p.p.push_back(allow_negative ? -0.03 + 0.2 * u(rng) : 0.2 * u(rng));
  return p;
}

MpiDeadzoneParams random_mpi_dz(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  MpiDeadzoneParams m;
  auto pi = random_pi(rng, false);
  m.q = pi.q;
  m.r = pi.r;
  m.p = pi.p;
  m.g0 = 0.8 + 0.4 * u(rng);
  m.z = {0.3, -0.25, 0.6, -0.7, 1.0};
  m.g = {0.3 * u(rng), 0.2 * u(rng), -0.1 * u(rng), 0.4 * u(rng), -0.2 * u(rng)};
  return m;
}

MpiAsymParams random_mpi_asym(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  MpiAsymParams m;
  m.ascending = Envelope::tanh(1.0 + u(rng), 1.0 + u(rng), 0.2 * u(rng), 0.0);
  m.descending = Envelope::atan(0.8 + u(rng), 1.0 + u(rng), -0.2 * u(rng), 0.1 * u(rng));
  m.q = 0.2 + u(rng);
  m.r = sorted_thresholds(rng, 10, 0.5);
  for (std::size_t i = 0; i < m.r.size(); ++i) m.p.push_back(0.3 * u(rng));
  m.input_limits = {-1.0, 1.0};
  return m;
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double e : v) m = std::max(m, std::abs(e));
  return m;
}

}  // namespace

// ---- operators -------------------------------------------------------------

TEST(Operators, PlayFollowsEq1AndEq2) {
  // Eq. 2: the initial state is clamped into [x0 - r, x0 + r].
  EXPECT_DOUBLE_EQ(ops::play(1.0, 0.25, 0.0), 0.75);
  EXPECT_DOUBLE_EQ(ops::play(-1.0, 0.25, 0.0), -0.75);
  EXPECT_DOUBLE_EQ(ops::play(0.1, 0.25, 0.0), 0.0);  // inside the band: output held
  // Stop is the complement of the play: s = x - play(x) for a shared history.
  std::mt19937_64 rng(7);
  auto x = random_walk(rng, 2000, -2, 2);
  double y = 0, s = 0, xp = 0;
  for (double xk : x) {
    y = ops::play(xk, 0.3, y);
    s = ops::stop(xk, xp, 0.3, s);
    xp = xk;
    ASSERT_NEAR(s, xk - y, 1e-12);
  }
}

TEST(Operators, WipingOutProperty) {
  // After the input passes above every earlier maximum and below every earlier
  // minimum, the play outputs no longer depend on the history before.
  std::mt19937_64 rng(11);
  const std::vector<double> r = {0.05, 0.1, 0.2, 0.4, 0.7};
  for (int trial = 0; trial < 50; ++trial) {
    auto h1 = random_walk(rng, 200, -1, 1);
    auto h2 = random_walk(rng, 300, -1, 1);
    std::vector<double> y1(r.size(), 0.3), y2(r.size(), -0.2);
    for (double x : h1) for (std::size_t i = 0; i < r.size(); ++i) y1[i] = ops::play(x, r[i], y1[i]);
    for (double x : h2) for (std::size_t i = 0; i < r.size(); ++i) y2[i] = ops::play(x, r[i], y2[i]);
    // A sweep to 2.5, down to -2.5 and back to 0.3 dominates both histories.
    std::vector<double> tail;
    for (int k = 0; k <= 100; ++k) tail.push_back(2.5 * k / 100.0);
    for (int k = 0; k <= 200; ++k) tail.push_back(2.5 - 5.0 * k / 200.0);
    for (int k = 0; k <= 100; ++k) tail.push_back(-2.5 + 2.8 * k / 100.0);
    for (double x : tail)
      for (std::size_t i = 0; i < r.size(); ++i) {
        y1[i] = ops::play(x, r[i], y1[i]);
        y2[i] = ops::play(x, r[i], y2[i]);
      }
    for (std::size_t i = 0; i < r.size(); ++i) ASSERT_DOUBLE_EQ(y1[i], y2[i]);
  }
}

TEST(Operators, CongruencyOfMinorLoops) {
  // Classical PI: minor loops traced between the same input extrema after
  // different histories are congruent (they differ by a constant shift).
  std::mt19937_64 rng(3);
  auto params = random_pi(rng, false);
  for (int trial = 0; trial < 20; ++trial) {
    Model a(params), b(params);
    auto h1 = random_walk(rng, 150, -1, 1);
    auto h2 = random_walk(rng, 170, -1, 1);
    a.simulate(h1);
    b.simulate(h2);
    // Drive both to the loop start, then twice around a minor loop [0.1, 0.35].
    std::vector<double> cyc;
    for (int k = 0; k <= 50; ++k) cyc.push_back(0.1 + 0.25 * k / 50.0);
    for (int k = 0; k <= 50; ++k) cyc.push_back(0.35 - 0.25 * k / 50.0);
    for (double x : cyc) { a.step(x); b.step(x); }  // first cycle settles the loop
    const double shift = a.output() - b.output();
    for (double x : cyc) ASSERT_NEAR(a.step(x) - b.step(x), shift, 1e-12);
  }
}

TEST(Operators, DeadZoneDefinition) {
  EXPECT_DOUBLE_EQ(ops::dead_zone(1.0, 0.4), 0.6);
  EXPECT_DOUBLE_EQ(ops::dead_zone(0.3, 0.4), 0.0);
  EXPECT_DOUBLE_EQ(ops::dead_zone(-1.0, -0.4), -0.6);
  EXPECT_DOUBLE_EQ(ops::dead_zone(-0.3, -0.4), 0.0);
  EXPECT_DOUBLE_EQ(ops::dead_zone(-0.3, 0.0), -0.3);
}

// ---- envelopes ---------------------------------------------------------------

TEST(Envelopes, ValueDerivativeInverse) {
  const std::vector<Envelope> envs = {Envelope::identity(), Envelope::affine(2.0, -1.0),
                                      Envelope::tanh(0.9, 0.418, -0.604, 0.637), Envelope::atan(1.2, 3.0, 0.5, -0.1)};
  for (const auto& e : envs) {
    e.validate("test");
    for (double x = -2; x <= 2; x += 0.01) {
      const double h = 1e-6;
      const double fd = (e.value(x + h) - e.value(x - h)) / (2 * h);
      ASSERT_NEAR(e.derivative(x), fd, 1e-6 * std::max(1.0, std::abs(fd))) << envelope_name(e.kind) << " x=" << x;
      ASSERT_NEAR(e.inverse(e.value(x)), x, 1e-12 * std::max(1.0, std::abs(x))) << envelope_name(e.kind);
      ASSERT_GT(e.derivative(x), 0.0);
    }
  }
  const auto t = Envelope::tanh(1.0, 1.0, 0.0, 0.5);
  EXPECT_THROW(t.inverse_checked(1.5, "here"), Error);  // range (-0.5, 1.5) is open
  EXPECT_EQ(t.inverse(2.0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(t.inverse(-1.0), -std::numeric_limits<double>::infinity());
  // the range's ends themselves are outside the open range: -inf / +inf (atan's tan(pi / 2) would be a
  // finite 1.6e16)
  for (const Envelope& b : {t, Envelope::atan(1.0, 1.0, 0.0, 0.0), Envelope::atan(1.2, 3.0, 0.5, -0.1)}) {
    EXPECT_EQ(b.inverse(b.range_hi()), std::numeric_limits<double>::infinity()) << envelope_name(b.kind);
    EXPECT_EQ(b.inverse(b.range_lo()), -std::numeric_limits<double>::infinity()) << envelope_name(b.kind);
  }
  try {
    Envelope::tanh(-1.0, 1.0, 0.0, 0.0).validate("gpi: c");
    FAIL() << "negative c0 accepted";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("c0 > 0"), std::string::npos) << err.what();
  }
}

// The hand-written tanh and atanh of the per-sample paths against long double
// references: a few ulp everywhere, odd symmetry, saturation, NaN propagation.
TEST(Envelopes, FastTanhAndAtanhAreAccurateToAFewUlp) {
  auto ulps = [](double got, long double ref) {
    const long double r = static_cast<long double>(static_cast<double>(ref));  // ref rounded to double
    const double ulp = std::nextafter(static_cast<double>(std::abs(r)), INFINITY) - static_cast<double>(std::abs(r));
    return static_cast<double>(std::abs(static_cast<long double>(got) - ref) / (ulp > 0 ? ulp : 1e-300));
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> expo(-300.0, 1.5), unit(0.0, 1.0);
  double worst_tanh = 0, worst_atanh = 0;
  for (int k = 0; k < 200000; ++k) {
    const double z = std::pow(10.0, expo(rng)) * (k % 2 ? -1.0 : 1.0);  // |z| from 1e-300 to 31.6
    const double t = detail::tanh_fast(z);
    worst_tanh = std::max(worst_tanh, ulps(t, std::tanh(static_cast<long double>(z))));
    ASSERT_EQ(detail::tanh_fast(-z), -t) << "odd symmetry at z=" << z;
    // atanh(d / c0) for d inside (-c0, c0), including d next to the edges
    const double c0 = 0.1 + 2.0 * unit(rng);
    const double d = (k % 3 == 0 ? 1.0 - std::pow(10.0, -15.0 * unit(rng)) : unit(rng)) * c0 * (k % 2 ? -1.0 : 1.0);
    const double a = detail::atanh_ratio(d, c0);
    // reference atanh(w) = log1p(2w / (1 - w)) / 2 with c0 - |d| exact: d / c0 itself, even in
    // long double, would lose the digits that matter next to the edge
    const long double ad = std::abs(static_cast<long double>(d));
    const long double ref = std::copysign(0.5L * std::log1p(2.0L * ad / (static_cast<long double>(c0) - ad)), d);
    worst_atanh = std::max(worst_atanh, ulps(a, ref));
    ASSERT_EQ(detail::atanh_ratio(-d, c0), -a) << "odd symmetry at d=" << d;
  }
  EXPECT_LE(worst_tanh, 3.0);
  EXPECT_LE(worst_atanh, 4.0);
  EXPECT_EQ(detail::tanh_fast(25.0), 1.0);
  EXPECT_EQ(detail::tanh_fast(-1e300), -1.0);
  EXPECT_EQ(std::signbit(detail::tanh_fast(-0.0)), true);
  EXPECT_TRUE(std::isnan(detail::tanh_fast(NAN)));
  EXPECT_TRUE(std::isnan(detail::atanh_ratio(NAN, 1.0)));
  EXPECT_TRUE(std::isfinite(detail::atanh_ratio(1.0, 1.0)));  // the edge is finite, not inf
  EXPECT_GT(detail::atanh_ratio(1.0, 1.0), 300.0);
  // the double Envelope and FastEnvelope agree bit for bit on value()
  const auto e = Envelope::tanh(0.9, 0.418, -0.604, 0.637);
  const FastEnvelope f(e);
  for (double x = -3; x <= 3; x += 0.001) ASSERT_EQ(f.value(x), e.value(x)) << x;
  RecordProperty("worst_tanh_ulp", std::to_string(worst_tanh));
  RecordProperty("worst_atanh_ulp", std::to_string(worst_atanh));
  std::printf("worst tanh %.2f ulp, atanh %.2f ulp\n", worst_tanh, worst_atanh);
}

// ---- models against their definitions -------------------------------------------

TEST(Models, GpiMatchesDirectEvaluationOfEqs4to8) {
  std::mt19937_64 rng(42);
  for (int trial = 0; trial < 20; ++trial) {
    const GpiParams g = random_gpi(rng);
    Model model(g);
    const auto x = random_walk(rng, 3000, -1, 1);
    const auto y = model.simulate(x);
    // Independent evaluation written out from the paper.
    std::vector<double> yi(g.n, 0.0);  // virgin state y_i0 = 0
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double gamma = g.envelope.c[0] * std::tanh(g.envelope.c[1] * x[k] + g.envelope.c[2]) + g.envelope.c[3];
      double out = g.q * gamma;
      for (int i = 1; i <= g.n; ++i) {
        const double ri = g.alpha * i;
        const double pi = g.rho * std::exp(-g.tau * ri);
        yi[i - 1] = std::max(gamma - ri, std::min(gamma + ri, yi[i - 1]));
        out += pi * yi[i - 1];
      }
      ASSERT_NEAR(y[k], out, 1e-13) << "sample " << k;
    }
  }
}

TEST(Models, DeadZoneMpiMatchesDefinition) {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const auto m = random_mpi_dz(rng);
    Model model(m);
    const auto x = random_walk(rng, 2000, -1.5, 1.5);
    const auto y = model.simulate(x);
    std::vector<double> yi(m.r.size(), 0.0);
    for (std::size_t k = 0; k < x.size(); ++k) {
      double v = m.q * x[k];
      for (std::size_t i = 0; i < m.r.size(); ++i) {
        yi[i] = std::max(x[k] - m.r[i], std::min(x[k] + m.r[i], yi[i]));
        v += m.p[i] * yi[i];
      }
      double out = m.g0 * v;
      for (std::size_t j = 0; j < m.z.size(); ++j)
        out += m.g[j] * (m.z[j] > 0 ? std::max(v - m.z[j], 0.0) : std::min(v - m.z[j], 0.0));
      ASSERT_NEAR(y[k], out, 1e-13);
    }
  }
}

TEST(Models, AsymmetricModelBreaksPointSymmetryOfPiLoops) {
  // A classical PI loop under a symmetric periodic input is point-symmetric about
  // its centre: y_up(c + s) + y_down(c - s) = 2 y_c. The mpi-asym model is not.
  std::mt19937_64 rng(9);
  auto loop_asymmetry = [](const ModelParams& p) {
    Model m(p);
    std::vector<double> up, down;
    for (int c = 0; c < 3; ++c) {
      up.clear();
      down.clear();
      for (int k = 0; k <= 200; ++k) up.push_back(m.step(-0.8 + 1.6 * k / 200.0));
      for (int k = 0; k <= 200; ++k) down.push_back(m.step(0.8 - 1.6 * k / 200.0));
    }
    const double centre = 0.5 * (up.front() + up.back());
    double worst = 0;
    for (int k = 0; k <= 200; ++k) worst = std::max(worst, std::abs(up[k] + down[k] - 2 * centre));
    return worst / (up.back() - up.front());
  };
  EXPECT_LT(loop_asymmetry(random_pi(rng, false)), 1e-12);
  EXPECT_GT(loop_asymmetry(random_mpi_asym(rng)), 1e-3);
}

TEST(Models, ZeroThresholdsFoldIntoQAndOrderDoesNotMatter) {
  PiParams a{0.1, {0.3, 0.0, 0.1}, {0.2, 0.5, 0.4}, {}, {}};
  PiParams b{0.6, {0.1, 0.3}, {0.4, 0.2}, {}, {}};
  Model ma(a), mb(b);
  std::mt19937_64 rng(1);
  for (double x : random_walk(rng, 500, -1, 1)) ASSERT_NEAR(ma.step(x), mb.step(x), 1e-15);
  EXPECT_EQ(ma.num_operators(), 2u);
  // equal thresholds are one play (the same state for every input): their weights add, 0.3 + 0.4 at r = 0.2;
  // so do dead zones at one z (0.25 + 0.5 at z = 0.3)
  PiParams c{1.0, {0.2, 0.5, 0.2}, {0.3, 0.1, 0.4}, {}, {}};
  PiParams d{1.0, {0.2, 0.5}, {0.7, 0.1}, {}, {}};
  MpiDeadzoneParams e{1.0, {0.2}, {0.3}, 1.0, {0.3, -0.4, 0.3}, {0.25, 0.1, 0.5}, {}, {}};
  MpiDeadzoneParams f{1.0, {0.2}, {0.3}, 1.0, {0.3, -0.4}, {0.75, 0.1}, {}, {}};
  Model mc(c), md(d), me(e), mf(f);
  for (double x : random_walk(rng, 500, -1, 1)) {
    ASSERT_NEAR(mc.step(x), md.step(x), 1e-14);
    ASSERT_NEAR(me.step(x), mf.step(x), 1e-14);
  }
  EXPECT_EQ(mc.num_operators(), 2u);
}

// An input beyond the model's input bound (its output could overflow: accepts() false) is a fault: the
// output held, not inf; reset() is a fresh start (output 0, what a fault then holds).
TEST(Models, InputBeyondTheBoundIsHeldAndResetStartsAtZero) {
  Model m(PiParams{1.0, {0.1}, {1.0}, {}, {}});
  EXPECT_EQ(m.step(0.5), 0.5 + 0.4);  // q x + p max(x - r, min(x + r, 0))
  ASSERT_FALSE(m.accepts(1e308));
  EXPECT_EQ(m.step(1e308), 0.9);
  EXPECT_EQ(m.step(-1e308), 0.9);
  EXPECT_EQ(m.faults(), 2u);
  m.reset();
  EXPECT_EQ(m.output(), 0.0);
  EXPECT_EQ(m.step(NAN), 0.0);
}

// ---- inverses --------------------------------------------------------------------

namespace {

// inverse(forward(x)) == x from a random reachable state, for one model.
void check_roundtrip(const ModelParams& p, std::mt19937_64& rng, double lo, double hi, double tol = 1e-12) {
  Model fwd(p);
  fwd.simulate(random_walk(rng, 500, lo, hi));  // random reachable state
  const ModelState start = fwd.state();
  const auto x = random_walk(rng, 5000, lo, hi);
  const auto y = fwd.simulate(x);
  InverseOptions opt;
  opt.input_limits = {lo, hi};
  Inverse inv(p, opt);
  inv.reset(start);
  const auto xr = inv.simulate(y);
  const double scale = std::max(max_abs(x), 1e-300);
  for (std::size_t k = 0; k < x.size(); ++k)
    ASSERT_NEAR(xr[k], x[k], tol * scale) << model_name(p) << " sample " << k;
  // The inverse's forward state equals the model's.
  const auto fs = inv.forward_state();
  const auto& ms = fwd.state();
  for (std::size_t i = 0; i < ms.y.size(); ++i) ASSERT_NEAR(fs.y[i], ms.y[i], 1e-10);
}

}  // namespace

TEST(Inverse, RoundTripEveryModelFromRandomStates) {
  std::mt19937_64 rng(2024);
  for (int trial = 0; trial < 25; ++trial) {
    check_roundtrip(random_pi(rng, true), rng, -2, 2);
    check_roundtrip(random_gpi(rng), rng, -1, 1);
    check_roundtrip(random_mpi_dz(rng), rng, -1.5, 1.5);
    check_roundtrip(random_mpi_asym(rng), rng, -1, 1);
  }
}

TEST(Inverse, RoundTripFromVirginState) {
  std::mt19937_64 rng(77);
  for (int trial = 0; trial < 10; ++trial) {
    for (const ModelParams& p : {ModelParams(random_gpi(rng)), ModelParams(random_pi(rng, true)),
                                 ModelParams(random_mpi_dz(rng)), ModelParams(random_mpi_asym(rng))}) {
      Model fwd(p);
      const auto x = random_walk(rng, 2000, -1, 1);
      const auto y = fwd.simulate(x);
      InverseOptions opt;
      opt.input_limits = {-1, 1};
      Inverse inv(p, opt);
      const auto xr = inv.simulate(y);
      for (std::size_t k = 0; k < x.size(); ++k) ASSERT_NEAR(xr[k], x[k], 1e-12) << model_name(p) << " " << k;
    }
  }
}

TEST(Inverse, GpiEq11ParametersMatchPaperFormulas) {
  // The inverse PI of Eqs. 9-11 composed with the forward PI is the identity:
  // check it on the loading curve, where the closed forms are simplest.
  GpiParams g;
  g.envelope = Envelope::identity();
  g.q = 0.7;
  g.n = 5;
  g.alpha = 0.1;
  g.rho = 0.3;
  g.tau = 2.0;
  Model fwd(g);
  Inverse inv(g);
  for (int k = 0; k <= 100; ++k) {
    const double x = 0.01 * k;
    const double y = fwd.step(x);
    // Loading curve: y = q x + sum_i p_i (x - r_i)^+  (independent closed form)
    double ref = g.q * x;
    for (int i = 1; i <= g.n; ++i) ref += g.rho * std::exp(-g.tau * g.alpha * i) * std::max(0.0, x - g.alpha * i);
    ASSERT_NEAR(y, ref, 1e-14);
    ASSERT_NEAR(inv.step(y), x, 1e-14);
  }
}

// Eq. 11's r'_i = q r_i + sum_{j<i} p_j (r_i - r_j) and p'_i = -p_i / ((q + sum_{j<=i} p_j)(q + sum_{j<i} p_j)),
// written here as the paper's sums (O(n^2)), against the O(n) detail::inverse_pi_parameters the inverse uses.
// Dyadic models (thresholds multiples of 1/64, weights of 1/16, small): every operation of both is exact, so the
// bits are equal. Random doubles: within 8 (i + 2) eps (q + sum_j |p_j|) r_i of the sum in long double (both
// are sums of i + 1 rounded terms of that scale; the O(n) one's are nonnegative).
TEST(Inverse, Eq11ParametersInLinearTimeEqualThePapersSums) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto pick = [&](int lo, int hi) { return lo + static_cast<int>(unit(rng) * (hi - lo + 1)); };
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (int t = 0; t < 400; ++t) {
    const bool dyadic = t % 2 == 0;
    const std::size_t n = 1 + static_cast<std::size_t>(unit(rng) * 300);
    std::vector<double> r(n), p(n);
    const double q = dyadic ? pick(1, 64) / 16.0 : 0.01 + 2.0 * unit(rng);
    double last = 0.0, sum = q;
    for (std::size_t i = 0; i < n; ++i) {
      last += dyadic ? pick(1, 64) / 64.0 : 1e-3 + unit(rng);
      r[i] = last;
      // weights of both signs, every partial sum q + p_1 + ... + p_i > 0 (Eq. 11)
      double w = dyadic ? pick(-32, 32) / 16.0 : 2.0 * unit(rng) - 1.0;
      if (!(sum + w > 0)) w = -w;
      if (!(sum + w > 0)) w = dyadic ? 1.0 / 16.0 : 0.01;
      p[i] = w;
      sum += w;
    }
    std::vector<double> ri(n), pi(n);
    detail::inverse_pi_parameters(q, r, p, ri.data(), pi.data());
    double abs_p = q;
    for (std::size_t i = 0; i < n; ++i) {
      double ref = q * r[i], after = q, before = q;  // the paper's sums, in the paper's order
      long double ref_l = static_cast<long double>(q) * r[i];
      for (std::size_t j = 0; j < i; ++j) {
        ref += p[j] * (r[i] - r[j]);
        ref_l += static_cast<long double>(p[j]) * (static_cast<long double>(r[i]) - r[j]);
        before += p[j];
      }
      after = before + p[i];
      abs_p += std::abs(p[i]);
      const double ref_p = -p[i] / (after * before);
      ASSERT_EQ(pi[i], ref_p) << "model " << t << ", operator " << i;  // the same operations in the same order
      if (dyadic) {
        ASSERT_EQ(ri[i], ref) << "model " << t << ", operator " << i;
      } else {
        const double tol = 8.0 * static_cast<double>(i + 2) * eps * abs_p * r[i];
        ASSERT_NEAR(ri[i], static_cast<double>(ref_l), tol) << "model " << t << ", operator " << i;
        ASSERT_NEAR(ref, static_cast<double>(ref_l), tol) << "model " << t << ", operator " << i << " (the sum)";
      }
    }
  }
}

TEST(Inverse, SaturatesAtLimitsAndStaysExact) {
  std::mt19937_64 rng(99);
  for (const ModelParams& p : {ModelParams(random_gpi(rng)), ModelParams(random_pi(rng, false)),
                               ModelParams(random_mpi_dz(rng)), ModelParams(random_mpi_asym(rng))}) {
    InverseOptions opt;
    opt.input_limits = {-0.5, 0.6};
    Inverse inv(p, opt);
    Model fwd(p);
    // Desired outputs far beyond the reachable range, mixed with reachable ones.
    auto yd = random_walk(rng, 3000, -20, 20);
    int saturated = 0, exact = 0;
    for (double y : yd) {
      const double x = inv.step(y);
      ASSERT_TRUE(std::isfinite(x));
      ASSERT_GE(x, -0.5);
      ASSERT_LE(x, 0.6);
      const double out = fwd.step(x);
      if (inv.saturated()) {
        ++saturated;
      } else {
        ASSERT_NEAR(out, y, 1e-10 * std::max(1.0, std::abs(y))) << model_name(p);
        ++exact;
      }
    }
    EXPECT_GT(saturated, 100) << model_name(p);
    EXPECT_GT(exact, 100) << model_name(p);
  }
}

// A desired output the model reaches exactly at an input limit is reached, not saturated (as the numerical
// inverses' y > f(hi)): q = 1, r = 0.5, p = 1 (Eq. 11: q' = 1, r' = 0.5, p' = -1 / 2, all exact) from the
// virgin state outputs 1 + 0.5 = 1.5 at x = 1; just beyond it saturates.
TEST(Inverse, OutputReachedExactlyAtTheLimitIsNotSaturated) {
  const PiParams p{1.0, {0.5}, {1.0}, {}, {}};
  Model fwd(p);
  ASSERT_EQ(fwd.step(1.0), 1.5);
  Inverse inv(p, InverseOptions{{-1.0, 1.0}});
  EXPECT_EQ(inv.step(1.5), 1.0);
  EXPECT_FALSE(inv.saturated());
  Inverse beyond(p, InverseOptions{{-1.0, 1.0}});
  EXPECT_EQ(beyond.step(1.5000001), 1.0);
  EXPECT_TRUE(beyond.saturated());
  // mpi-asym (numerical inverse): ascending x, descending 1.5 x, q = 1, r = 0.5, p = 1 from the virgin
  // state at x = 1: q (1 + 1.5) / 2 + p max(1 - 0.5, min(1.5 + 0.5, 0)) = 1.25 + 0.5 = 1.75
  MpiAsymParams a;
  a.ascending = Envelope::affine(1.0, 0.0);
  a.descending = Envelope::affine(1.5, 0.0);
  a.q = 1.0;
  a.r = {0.5};
  a.p = {1.0};
  Model fwd_a(a);
  ASSERT_EQ(fwd_a.step(1.0), 1.75);
  Inverse inv_a(a, InverseOptions{{-1.0, 1.0}});
  EXPECT_EQ(inv_a.step(1.75), 1.0);
  EXPECT_FALSE(inv_a.saturated());
  EXPECT_EQ(inv_a.step(1.7500001), 1.0);
  EXPECT_TRUE(inv_a.saturated());
}

// Beyond the reachable range is saturation also where the model reaches its bound |v| <= B(u) at the limit
// (a pure gain, q = 2 on [-1, 1]: v = 2 x reaches B(1) = 2): 100 and -100 saturate, 1 is x = 0.5.
TEST(Inverse, PureGainBeyondItsRangeSaturates) {
  Inverse inv(PiParams{2.0, {}, {}, {}, {}}, InverseOptions{{-1.0, 1.0}});
  EXPECT_EQ(inv.step(100.0), 1.0);
  EXPECT_TRUE(inv.saturated());
  EXPECT_EQ(inv.step(-100.0), -1.0);
  EXPECT_TRUE(inv.saturated());
  EXPECT_EQ(inv.step(1.0), 0.5);
  EXPECT_FALSE(inv.saturated());
}

// A saturated command is the limit itself, also where the units map's round trip does not return it
// (origin 0.1, scale 0.3: 0.41 and 0.04 come back as 0.41 - 1 ulp and 0.04 + 1 ulp).
TEST(Inverse, SaturatedCommandIsTheLimitItself) {
  PiParams p{1.0, {}, {}, {}, {}};
  p.units.input_origin = 0.1;
  p.units.input_scale = 0.3;
  Inverse inv(p, InverseOptions{{0.04, 0.41}});
  EXPECT_EQ(inv.step(100.0), 0.41);
  EXPECT_TRUE(inv.saturated());
  EXPECT_EQ(inv.step(-100.0), 0.04);
  EXPECT_TRUE(inv.saturated());
}

// reset() is the virgin state of a new inverse (matching Model::reset()): after steps that moved the state
// and ended saturated, the same snapshot as a fresh inverse, and from there the same inputs as it and a
// forward model fed them reaching every reachable desired output.
TEST(Inverse, ResetIsTheStateOfANewInverse) {
  std::mt19937_64 rng(31);
  for (const ModelParams& p : {ModelParams(random_gpi(rng)), ModelParams(random_pi(rng, false)),
                               ModelParams(random_mpi_dz(rng)), ModelParams(random_mpi_asym(rng))}) {
    const InverseOptions opt{{-0.5, 0.6}};
    Inverse used(p, opt), fresh(p, opt);
    for (double y : random_walk(rng, 200, -3, 3)) used.step(y);
    used.step(50.0);  // saturated last
    ASSERT_TRUE(used.saturated()) << model_name(p);
    used.reset();
    EXPECT_EQ(used.snapshot(), fresh.snapshot()) << model_name(p);
    Model fwd(p);
    for (double y : {-40.0, 0.3, -0.2, 40.0, 0.1}) {  // saturating first: the state is re-derived
      const double x = used.step(y);
      EXPECT_EQ(x, fresh.step(y)) << model_name(p);
      const double out = fwd.step(x);
      if (!used.saturated()) {
        EXPECT_NEAR(out, y, 1e-10) << model_name(p) << " y " << y;
      }
    }
  }
}

TEST(Inverse, TanhWithoutLimitsNeverReturnsInfinity) {
  GpiParams g;
  g.envelope = Envelope::tanh(1, 1, 0, 0);
  g.n = 3;
  g.alpha = 0.1;
  g.rho = 0.2;
  g.tau = 1;
  Inverse inv(g);
  for (double y : {1e6, -1e6, 0.0, 3.0}) ASSERT_TRUE(std::isfinite(inv.step(y)));
}

TEST(Inverse, NonFiniteDesiredOutputHoldsInput) {
  std::mt19937_64 rng(4);
  Inverse inv(random_gpi(rng));
  const double x1 = inv.step(0.2);
  EXPECT_EQ(inv.step(std::nan("")), x1);
  EXPECT_EQ(inv.step(std::numeric_limits<double>::infinity()), x1);
  EXPECT_EQ(inv.faults(), 2u);
  Model m(random_gpi(rng));
  std::vector<double> bad = {0.1, std::nan(""), 0.2};
  try {
    m.simulate(bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample 1"), std::string::npos) << e.what();
  }
}

TEST(Inverse, RejectsNonInvertibleParameters) {
  auto expect_error = [](const ModelParams& p, const std::string& needle) {
    try {
      Inverse inv(p, InverseOptions{{-1, 1}});
      FAIL() << "accepted: " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error(PiParams{0.5, {0.1, 0.2}, {-0.2, -0.4}, {}, {}}, "q + p_1 + ... + p_2");
  expect_error(PiParams{0.0, {0.1}, {1.0}, {}, {}}, "q (plus the weights");
  expect_error(MpiDeadzoneParams{1.0, {0.1}, {0.1}, 1.0, {0.5}, {-1.5}, {}, {}}, "dead zones in (0, 0.5]");
  expect_error(MpiDeadzoneParams{1.0, {0.1}, {0.1}, -1.0, {}, {}, {}, {}}, "g0");
  MpiAsymParams a;
  a.descending = Envelope::affine(1.5, 0.0);
  a.r = {0.1};
  a.p = {-0.1};
  expect_error(a, "p_i >= 0");
  MpiAsymParams b;
  b.ascending = Envelope::tanh(1, 1, 0, 0);
  b.r = {0.1};
  b.p = {0.1};
  try {
    Inverse inv(b);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("finite input_limits"), std::string::npos) << e.what();
  }
}

TEST(Inverse, RejectsUnreachableStartState) {
  PiParams p{1.0, {0.1, 0.2}, {0.5, 0.5}, {}, {}};
  Inverse inv(p);
  EXPECT_THROW(inv.reset(ModelState{{0.0, 0.5}, 0.0}), Error);  // |d_2| = 0.5 > r_2
  EXPECT_THROW(inv.reset(ModelState{{0.0}, 0.0}), Error);       // wrong size
  // |d_1| = 0.1 <= r_1, but |d_2 - d_1| = 0.15 > r_2 - r_1 = 0.1 (though < r_2): no input path leaves it
  EXPECT_THROW(inv.reset(ModelState{{-0.1, 0.05}, 0.0}), Error);
  EXPECT_NO_THROW(inv.reset(ModelState{{0.05, 0.1}, 0.0}));
}

TEST(Models, RejectInvalidParametersNamingTheKey) {
  auto expect_error = [](const ModelParams& p, const std::string& needle) {
    try {
      Model m(p);
      FAIL() << "accepted: " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error(PiParams{0.5, {0.1, -0.2}, {0.2, 0.4}, {}, {}}, "r[1]");
  expect_error(PiParams{0.5, {0.1, 0.2}, {0.2}, {}, {}}, "p has 1");
  expect_error(PiParams{std::nan(""), {0.1}, {0.2}, {}, {}}, "q must be a finite");
  GpiParams g;
  g.alpha = -1;
  g.rho = 1;
  g.tau = 1;
  expect_error(g, "alpha");
  g.alpha = 0.1;
  g.tau = 0;
  expect_error(g, "tau");
  g.tau = 1;
  g.envelope = Envelope::tanh(1, -0.5, 0, 0);
  expect_error(g, "c1 > 0");
  g.envelope = Envelope::tanh(1, 0.5, 0, 0);
  g.input_limits = {1, 0};
  expect_error(g, "input_limits");
}

// ---- real-time guarantees ----------------------------------------------------------

TEST(RealTime, StepNeverAllocates) {
  std::mt19937_64 rng(8);
  std::vector<ModelParams> all = {random_pi(rng, true), random_gpi(rng), random_mpi_dz(rng), random_mpi_asym(rng)};
  const auto x = random_walk(rng, 2000, -3, 3);  // includes saturation
  for (const auto& p : all) {
    Model m(p);
    Inverse inv(p, InverseOptions{{-1, 1}});
    const std::size_t before = hysteron_test::allocations();
    double acc = 0;
    for (double xk : x) acc += m.step(xk);
    for (double xk : x) acc += inv.step(xk);
    acc += m.step(std::nan("")) + inv.step(std::nan(""));
    EXPECT_EQ(hysteron_test::allocations(), before) << model_name(p);
    EXPECT_TRUE(std::isfinite(acc));
  }
}

TEST(RealTime, StepIsDeterministic) {
  std::mt19937_64 rng(12);
  const auto p = random_mpi_asym(rng);
  const auto x = random_walk(rng, 1000, -1, 1);
  Inverse a(p), b(p);
  for (double xk : x) ASSERT_EQ(a.step(xk), b.step(xk));
}
