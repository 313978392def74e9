// Finite inputs far beyond anything physical (1e300 .. DBL_MAX) through the C ABI: the
// inverse saturates at the limit in the direction of the desired output, the forward model
// never returns inf or NaN with HYSTERON_OK (it refuses, state unchanged), the PID refuses an
// overflowing error with a status, and a refused relaxed start changes nothing.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "hysteron/error.hpp"
#include "hysteron/hysteron.h"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/models.hpp"

namespace {

struct Kind {
  const char* name;
  const char* json;
};

// Output grows with the input unless output_gain < 0; every model has finite input limits.
const Kind kKinds[] = {
    {"pi", R"({"model": "pi", "q": 0.4, "r": [0, 0.1, 0.25, 0.5], "p": [0.3, 0.2, -0.05, 0.1], "input_limits": [-1, 1.5]})"},
    {"pi_negative_gain", R"({"model": "pi", "q": 0.09, "r": [28.8, 57.6, 80], "p": [0.72, -0.04, 0.1],
        "input_origin": 8.18, "output_offset": -40.0, "output_gain": -1, "input_limits": [8.18, 625.86]})"},
    {"gpi", R"({"model": "gpi", "envelope": "tanh", "c": [817.3, 0.00093, -0.62, 419.5], "q": 0.0186, "n": 10,
        "rho": 0.095, "tau": 3.2e-8, "alpha": 1.63, "input_origin": 8.18, "output_offset": 16.5,
        "input_limits": [8.18, 625.86]})"},
    {"gpi_affine", R"({"model": "gpi", "envelope": "affine", "c": [0.13, 0.02], "q": 0.8, "n": 7, "rho": 0.05,
        "tau": 0.02, "alpha": 10, "input_limits": [-120, 110]})"},
    {"mpi_deadzone", R"({"model": "mpi-deadzone", "q": 0.8, "r": [0.1, 0.2, 0.3], "p": [0.3, 0.1, -0.05], "g0": 0.5,
        "z": [-0.5, 0.25, 0.6], "g": [0.2, 0.3, 0.1], "input_limits": [-1.5, 1.5]})"},
    {"mpi_asym", R"({"model": "mpi-asym", "q": 0.6, "r": [0.05, 0.15, 0.3], "p": [0.2, 0.1, 0.1],
        "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]},
        "descending": {"envelope": "affine", "c": [0.9, 0.1]}, "input_limits": [-2, 2]})"},
};

const double kHuge[] = {1e300, 1e307, 1e308, 5e307 * 3, DBL_MAX};

struct Handles {
  hysteron_params* p = nullptr;
  hysteron_model* m = nullptr;
  hysteron_inverse* inv = nullptr;
  explicit Handles(const char* json) {
    EXPECT_EQ(hysteron_params_from_json(json, &p), HYSTERON_OK) << hysteron_last_error();
    EXPECT_EQ(hysteron_model_create(p, &m), HYSTERON_OK) << hysteron_last_error();
    EXPECT_EQ(hysteron_inverse_create(p, -HUGE_VAL, HUGE_VAL, &inv), HYSTERON_OK) << hysteron_last_error();
  }
  ~Handles() {
    hysteron_inverse_free(inv);
    hysteron_model_free(m);
    hysteron_params_free(p);
  }
};

bool decreasing(const char* json) { return std::string(json).find("\"output_gain\": -") != std::string::npos; }

// f(kind, v) for every kind and every huge input v of either sign, each on fresh handles
template <class F>
void each_kind_and_huge_input(F f) {
  for (const Kind& k : kKinds)
    for (double h : kHuge)
      for (double sign : {1.0, -1.0}) f(k, sign * h);
}

TEST(HugeInputs, InverseSaturatesAtTheLimitInTheDirectionOfTheDesiredOutput) {
  each_kind_and_huge_input([](const Kind& k, double huge) {
    const double sign = huge > 0 ? 1.0 : -1.0, h = std::abs(huge);
    Handles a(k.json), twin(k.json);
    double lo = 0, hi = 0;
    ASSERT_EQ(hysteron_inverse_limits(a.inv, &lo, &hi), HYSTERON_OK);
    ASSERT_TRUE(std::isfinite(lo) && std::isfinite(hi)) << k.name;
    // a normal walk first, so that the state is not the virgin one
    double x = 0, xt = 0;
    int sat = -1, sat_t = -1;
    for (int i = 0; i < 50; ++i) {
      const double y = 0.3 * std::sin(0.2 * i);
      ASSERT_EQ(hysteron_inverse_step(a.inv, y, &x, &sat), HYSTERON_OK);
      ASSERT_EQ(hysteron_inverse_step(twin.inv, y, &xt, &sat_t), HYSTERON_OK);
    }
    const bool up = (sign > 0) != decreasing(k.json);
    ASSERT_EQ(hysteron_inverse_step(a.inv, sign * h, &x, &sat), HYSTERON_OK) << k.name << " " << sign * h;
    EXPECT_EQ(x, up ? hi : lo) << k.name << ": y_desired = " << sign * h;
    EXPECT_EQ(sat, 1) << k.name << ": y_desired = " << sign * h;
    // the memory follows that limit: as after any other unreachable desired output on that side
    const double y_far = sign * 1e6;
    ASSERT_EQ(hysteron_inverse_step(twin.inv, y_far, &xt, &sat_t), HYSTERON_OK);
    EXPECT_EQ(xt, x) << k.name;
    for (int i = 0; i < 50; ++i) {
      const double y = 0.2 * std::cos(0.3 * i);
      ASSERT_EQ(hysteron_inverse_step(a.inv, y, &x, &sat), HYSTERON_OK);
      ASSERT_EQ(hysteron_inverse_step(twin.inv, y, &xt, &sat_t), HYSTERON_OK);
      ASSERT_EQ(x, xt) << k.name << ": after y_desired = " << sign * h << ", sample " << i;
    }
  });
}

// One limit unbounded: a huge desired output toward the bounded one still saturates there (a
// review found it held instead, with a fault, when the bound was one for both sides); toward
// the unbounded side the input is finite, or held with a status, never inf or NaN.
TEST(HugeInputs, OneSidedLimitsSaturateOnTheBoundedSide) {
  const char* low_only = R"({"model": "pi", "q": 0.5, "r": [0, 0.1, 0.3], "p": [0.3, 0.2, 0.1], "input_limits": [-1, null]})";
  const char* high_only = R"({"model": "pi", "q": 0.5, "r": [0, 0.1, 0.3], "p": [0.3, 0.2, 0.1], "input_limits": [null, 1.5]})";
  for (const char* json : {low_only, high_only}) {
    const bool bounded_low = json == low_only;
    for (double h : kHuge) {
      Handles a(json);
      double lo = 0, hi = 0, x = 0;
      int sat = -1;
      ASSERT_EQ(hysteron_inverse_limits(a.inv, &lo, &hi), HYSTERON_OK);
      ASSERT_EQ(std::isfinite(lo), bounded_low);
      ASSERT_EQ(std::isfinite(hi), !bounded_low);
      for (int i = 0; i < 20; ++i) ASSERT_EQ(hysteron_inverse_step(a.inv, 0.3 * std::sin(0.2 * i), &x, &sat), HYSTERON_OK);
      const double toward_bound = bounded_low ? -h : h;
      ASSERT_EQ(hysteron_inverse_step(a.inv, toward_bound, &x, &sat), HYSTERON_OK) << toward_bound;
      EXPECT_EQ(x, bounded_low ? lo : hi) << "y_desired = " << toward_bound;
      EXPECT_EQ(sat, 1);
      const hysteron_status st = hysteron_inverse_step(a.inv, -toward_bound, &x, &sat);
      EXPECT_TRUE(st == HYSTERON_OK || st == HYSTERON_ERROR_INVALID_ARGUMENT) << st;
      EXPECT_TRUE(std::isfinite(x)) << "y_desired = " << -toward_bound << ": " << x;
    }
  }
}

TEST(HugeInputs, ForwardStepNeverReturnsInfOrNanWithOk) {
  each_kind_and_huge_input([](const Kind& k, double huge) {
    const double sign = huge > 0 ? 1.0 : -1.0, h = std::abs(huge);
    Handles a(k.json), twin(k.json);
    double y = 0, yt = 0;
    for (int i = 0; i < 30; ++i) {
      const double x = 0.5 * std::sin(0.3 * i);
      ASSERT_EQ(hysteron_model_step(a.m, x, &y), HYSTERON_OK);
      ASSERT_EQ(hysteron_model_step(twin.m, x, &yt), HYSTERON_OK);
    }
    const double before = y;
    const hysteron_status st = hysteron_model_step(a.m, sign * h, &y);
    if (st == HYSTERON_OK) {
      EXPECT_TRUE(std::isfinite(y)) << k.name << ": x = " << sign * h << " -> " << y;
      return;
    }
    EXPECT_EQ(st, HYSTERON_ERROR_INVALID_ARGUMENT) << k.name;
    EXPECT_EQ(y, before) << k.name << ": the previous output held";
    EXPECT_NE(std::string(hysteron_last_error()).find("hysteron_model_step"), std::string::npos);
    for (int i = 0; i < 30; ++i) {  // the state unchanged: as if the sample never came
      const double x = 0.4 * std::cos(0.2 * i);
      ASSERT_EQ(hysteron_model_step(a.m, x, &y), HYSTERON_OK);
      ASSERT_EQ(hysteron_model_step(twin.m, x, &yt), HYSTERON_OK);
      ASSERT_EQ(y, yt) << k.name << ": after x = " << sign * h;
    }
    // the batch refuses it before stepping anything, relaxed starts change nothing
    std::vector<double> xs = {0.1, sign * h}, ys(2, -7.0);
    EXPECT_EQ(hysteron_model_simulate(a.m, xs.data(), 2, ys.data(), 2), HYSTERON_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(ys[0], -7.0);
    EXPECT_EQ(hysteron_model_reset_relaxed(a.m, sign * h), HYSTERON_ERROR_INVALID_ARGUMENT) << k.name;
    EXPECT_EQ(hysteron_inverse_reset_relaxed(a.inv, sign * h), HYSTERON_ERROR_INVALID_ARGUMENT) << k.name;
    ASSERT_EQ(hysteron_model_step(a.m, 0.25, &y), HYSTERON_OK);
    ASSERT_EQ(hysteron_model_step(twin.m, 0.25, &yt), HYSTERON_OK);
    EXPECT_EQ(y, yt) << k.name;
  });
}

TEST(HugeInputs, AnOverflowingPidErrorIsRefusedWithAStatus) {
  Handles h(kKinds[0].json);
  hysteron_ff_pid_params fp;
  ASSERT_EQ(hysteron_ff_pid_default_params(&fp), HYSTERON_OK);
  fp.kp = 5;
  fp.ki = 30;
  fp.kd = 0.2;
  fp.pressure_min = -1;
  fp.pressure_max = 1.5;
  for (int aw = 0; aw < 3; ++aw) {
    fp.anti_windup = aw;
    for (double big : {1e308, DBL_MAX}) {
      hysteron_ff_pid *a = nullptr, *twin = nullptr;
      ASSERT_EQ(hysteron_ff_pid_create(h.p, &fp, &a), HYSTERON_OK) << hysteron_last_error();
      ASSERT_EQ(hysteron_ff_pid_create(h.p, &fp, &twin), HYSTERON_OK);
      double pa = 0, pt = 0, r_last = 0;
      for (int k = 0; k < 200; ++k) {
        const double r = 0.2 * std::sin(0.05 * k), y = 0.9 * r;
        r_last = r;
        ASSERT_EQ(hysteron_ff_pid_step(a, r, r, y, &pa), HYSTERON_OK);
        ASSERT_EQ(hysteron_ff_pid_step(twin, r, r, y, &pt), HYSTERON_OK);
      }
      const double before = pa;
      // the error reference - measured is inf: refused, the command held (the preview repeated,
      // so that the feedforward's inverse stays where the twin's is)
      EXPECT_EQ(hysteron_ff_pid_step(a, big, r_last, -big, &pa), HYSTERON_ERROR_INVALID_ARGUMENT) << "aw " << aw;
      EXPECT_EQ(pa, before);
      for (int k = 200; k < 400; ++k) {  // no NaN in the integrator: the twin that never saw it
        const double r = 0.2 * std::sin(0.05 * k), y = 0.9 * r;
        ASSERT_EQ(hysteron_ff_pid_step(a, r, r, y, &pa), HYSTERON_OK);
        ASSERT_EQ(hysteron_ff_pid_step(twin, r, r, y, &pt), HYSTERON_OK);
        ASSERT_TRUE(std::isfinite(pa));
        ASSERT_EQ(pa, pt) << "aw " << aw << " sample " << k;
      }
      hysteron_ff_pid_free(a);
      hysteron_ff_pid_free(twin);
    }
  }
}

// x0 outside the inverse's limits (documented): the memory at rest there, the held input the limit.
TEST(HugeInputs, InverseRelaxedOutsideItsLimitsHoldsTheLimit) {
  Handles h(kKinds[0].json);
  double lo = 0, hi = 0, x = 0;
  int sat = 0;
  ASSERT_EQ(hysteron_inverse_limits(h.inv, &lo, &hi), HYSTERON_OK);
  ASSERT_EQ(hysteron_inverse_reset_relaxed(h.inv, lo - 5.0), HYSTERON_OK);
  EXPECT_EQ(hysteron_inverse_step(h.inv, NAN, &x, &sat), HYSTERON_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(x, lo);
}

// (name, model file) of the PI family above, rate-pi and bouc-wen, and with `kernels` also kp,
// preisach and maxwell-slip: every kind whose state a user can read and set
std::vector<std::pair<std::string, std::string>> kinds_with_state(bool kernels) {
  std::vector<std::pair<std::string, std::string>> kinds;
  for (const Kind& k : kKinds) kinds.emplace_back(k.name, k.json);
  kinds.emplace_back("rate-pi", R"({"model": "rate-pi", "q": 0.3, "r": [0.1, 0.2], "p": [0.4, 0.3], "c": 0.12,
      "tau": 0.1, "dt": 0.001, "input_limits": [-1, 1]})");
  kinds.emplace_back("bouc-wen", R"({"model": "bouc-wen", "kx": 1.0, "kw": -0.05, "rho": 4, "sigma": 1, "n": 1.5,
      "input_limits": [-1, 1]})");
  if (kernels) {
    kinds.emplace_back("kp", R"({"model": "kp", "q": 0.5, "lo": -1, "hi": 1, "levels": 2, "w": [0.2, 0.1, 0.3],
        "input_limits": [-1.5, 1.5]})");
    kinds.emplace_back("preisach", R"({"model": "preisach", "q": 0.5, "lo": -1, "hi": 1, "levels": 2,
        "w": [0.2, 0.1, 0.3], "input_limits": [-1.5, 1.5]})");
    kinds.emplace_back("maxwell-slip", R"({"model": "maxwell-slip", "k0": 0.4, "k": [0.3, 0.5], "delta": [0.1, 0.25],
        "input_limits": [-1.5, 1.5]})");
  }
  return kinds;
}

}  // namespace

// A state set by hand (Model::reset(ModelState), Inverse::reset) so large that the next step
// could overflow to inf or NaN, e.g. 1e308 in an operator output (rate-pi returned NaN), is
// refused with hysteron::Error. A state read back from a run is taken, and the run continues
// from it sample for sample.
TEST(HugeInputs, AStateNoInputReachesIsRefused) {
  for (const auto& [name, json] : kinds_with_state(false)) {
    const hysteron::ModelParams params = hysteron::io::model_from_json(nlohmann::json::parse(json), name);
    hysteron::Model a(params), b(params);
    for (int i = 0; i < 40; ++i) (void)a.step(0.5 * std::sin(0.3 * i));
    const hysteron::ModelState reached = a.state();
    ASSERT_NO_THROW(b.reset(reached)) << name;
    for (int i = 0; i < 20; ++i) {
      const double x = 0.4 * std::cos(0.2 * i);
      ASSERT_EQ(a.step(x), b.step(x)) << name << ": from the state read back";
    }
    for (std::size_t j = 0; j <= reached.y.size(); ++j)
      for (double huge : {1e308, -1e308, DBL_MAX}) {
        hysteron::ModelState s = reached;
        (j < s.y.size() ? s.y[j] : s.u) = huge;
        if (j == s.y.size() && (name == "rate-pi" || name == "bouc-wen")) continue;  // their u is the input, not stored
        hysteron::Model m(params);
        bool refused = false;
        try {
          m.reset(s);
        } catch (const hysteron::Error&) {
          refused = true;
        }
        if (!refused) {  // taken: then it must be a state whose steps stay finite
          for (double x : {0.0, 0.9, -0.9}) EXPECT_TRUE(std::isfinite(m.step(x))) << name << " entry " << j << " = " << huge;
        }
        if (name != "bouc-wen" || j == 0) {
          EXPECT_TRUE(refused) << name << ": entry " << j << " = " << huge << " taken";
        }
      }
    if (hysteron::has_pi_structure(params)) {  // the inverse: every entry huge (deviations 0: reachable in shape)
      hysteron::ModelState s = reached;
      for (double& v : s.y) v = 1e308;
      s.u = 1e308;
      hysteron::Inverse inv(params);
      EXPECT_THROW(inv.reset(s), hysteron::Error) << name;
      EXPECT_THROW(b.reset(s), hysteron::Error) << name;
    }
  }
}

// The C ABI's state functions for every kind: hysteron_params_num_operators is the length of
// the state vector (it was 0 for kp, preisach, maxwell-slip, rate-pi and bouc-wen, whose
// Model::num_operators() is 0, so their states could be neither read nor set: "initial state
// has 0 entries, the model has 11"); a state read back after a run is taken by a fresh model
// and inverse, which go on sample for sample; a wrong n is refused naming both sizes.
TEST(HugeInputs, CApiStateOfEveryKindRoundTrips) {
  for (const auto& [name, json] : kinds_with_state(true)) {
    SCOPED_TRACE(name);
    const hysteron::ModelParams params = hysteron::io::model_from_json(nlohmann::json::parse(json), name);
    const std::size_t entries = hysteron::Model(params).state().y.size();
    Handles a(json.c_str()), b(json.c_str());
    std::size_t n = 99;
    ASSERT_EQ(hysteron_params_num_operators(a.p, &n), HYSTERON_OK);
    EXPECT_EQ(n, entries);
    EXPECT_GT(n, 0u);
    double out_a = 0, out_b = 0;
    for (int i = 0; i < 40; ++i) ASSERT_EQ(hysteron_model_step(a.m, 0.5 * std::sin(0.3 * i), &out_a), HYSTERON_OK);
    std::vector<double> y(n + 1);
    double u = 0;
    ASSERT_EQ(hysteron_model_get_state(a.m, y.data(), n, &u), HYSTERON_OK) << hysteron_last_error();
    ASSERT_EQ(hysteron_model_reset_state(b.m, y.data(), n, u), HYSTERON_OK) << hysteron_last_error();
    for (int i = 0; i < 20; ++i) {
      const double x = 0.4 * std::cos(0.2 * i);
      ASSERT_EQ(hysteron_model_step(a.m, x, &out_a), HYSTERON_OK);
      ASSERT_EQ(hysteron_model_step(b.m, x, &out_b), HYSTERON_OK);
      ASSERT_EQ(out_a, out_b) << "sample " << i << " from the state read back";
    }
    // a wrong n: refused, naming both sizes
    EXPECT_EQ(hysteron_model_reset_state(b.m, y.data(), n + 1, u), HYSTERON_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(hysteron_last_error()).find(fmt::format("n = {}, but the model's state has {} entries", n + 1, n)),
              std::string::npos) << hysteron_last_error();
    EXPECT_EQ(hysteron_model_get_state(b.m, y.data(), n - 1, &u), HYSTERON_ERROR_INVALID_ARGUMENT);
    // the inverse starts from the forward model's state and gives it back
    ASSERT_EQ(hysteron_model_get_state(a.m, y.data(), n, &u), HYSTERON_OK);
    ASSERT_EQ(hysteron_inverse_reset_state(a.inv, y.data(), n, u), HYSTERON_OK) << hysteron_last_error();
    std::vector<double> back(n);
    double u_back = 0;
    ASSERT_EQ(hysteron_inverse_get_state(a.inv, back.data(), n, &u_back), HYSTERON_OK) << hysteron_last_error();
    for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(back[i], y[i], 1e-12 * (1.0 + std::abs(y[i]))) << "entry " << i;  // through the inverse's coordinates
  }
}

// The batches with arrays that partly overlap (audit2 F5): y = x + 1 stepped sample k from an x[k]
// already overwritten by y[k - 1], and returned wrong outputs with HYSTERON_OK. Now refused with
// nothing written; in place (y == x) and apart are the single steps' outputs, both directions.
TEST(HugeInputs, CApiBatchesRefusePartlyOverlappingArrays) {
  const Kind& k = kKinds[0];
  const std::vector<double> x = {0.1, 0.2, 0.3, 0.2, 0.1, 0.4, 0.5, 0.0};
  const std::size_t n = 7;
  Handles h(k.json);
  std::vector<double> expected(n), inverted(n);
  ASSERT_EQ(hysteron_model_simulate(h.m, x.data(), n, expected.data(), n), HYSTERON_OK);
  ASSERT_EQ(hysteron_inverse_invert(h.inv, expected.data(), n, inverted.data(), n, nullptr), HYSTERON_OK);
  for (const std::ptrdiff_t shift : {1, -1, 3, -6}) {
    std::vector<double> buf(n + 16, -7.0);
    const std::size_t at = 7;  // x at buf[7..14), the output at buf[7 + shift ..)
    std::copy(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n), buf.begin() + static_cast<std::ptrdiff_t>(at));
    const std::vector<double> before = buf;
    ASSERT_EQ(hysteron_model_reset(h.m), HYSTERON_OK);
    EXPECT_EQ(hysteron_model_simulate(h.m, buf.data() + at, n, buf.data() + at + shift, n),
              HYSTERON_ERROR_INVALID_ARGUMENT)
        << "shift " << shift;
    EXPECT_NE(std::string(hysteron_last_error()).find("hysteron_model_simulate: y overlaps x"), std::string::npos)
        << hysteron_last_error();
    EXPECT_EQ(buf, before) << "shift " << shift << ": written";
    std::copy(expected.begin(), expected.end(), buf.begin() + static_cast<std::ptrdiff_t>(at));
    const std::vector<double> before_inv = buf;
    ASSERT_EQ(hysteron_inverse_reset(h.inv), HYSTERON_OK);
    EXPECT_EQ(hysteron_inverse_invert(h.inv, buf.data() + at, n, buf.data() + at + shift, n, nullptr),
              HYSTERON_ERROR_INVALID_ARGUMENT)
        << "shift " << shift;
    EXPECT_NE(std::string(hysteron_last_error()).find("hysteron_inverse_invert: x overlaps y"), std::string::npos)
        << hysteron_last_error();
    EXPECT_EQ(buf, before_inv) << "shift " << shift << ": written";
  }
  // in place: the outputs of separate arrays
  std::vector<double> in_place(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n));
  ASSERT_EQ(hysteron_model_reset(h.m), HYSTERON_OK);
  ASSERT_EQ(hysteron_model_simulate(h.m, in_place.data(), n, in_place.data(), n), HYSTERON_OK) << hysteron_last_error();
  EXPECT_EQ(in_place, expected);
  ASSERT_EQ(hysteron_inverse_reset(h.inv), HYSTERON_OK);
  ASSERT_EQ(hysteron_inverse_invert(h.inv, in_place.data(), n, in_place.data(), n, nullptr), HYSTERON_OK)
      << hysteron_last_error();
  EXPECT_EQ(in_place, inverted);
  // adjacent (y right after x): apart
  std::vector<double> both(2 * n);
  std::copy(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n), both.begin());
  ASSERT_EQ(hysteron_model_reset(h.m), HYSTERON_OK);
  ASSERT_EQ(hysteron_model_simulate(h.m, both.data(), n, both.data() + n, n), HYSTERON_OK) << hysteron_last_error();
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), both.begin() + static_cast<std::ptrdiff_t>(n)));
}

// Units maps whose values are finite but extreme (audit2): output_gain 1e-320 (subnormal, its
// reciprocal inf) or output_offset 1e308 (no input the model accepts) loaded and broke every step.
// Refused at load, by the model's validation (so the C ABI, the CLI, Python and fit alike), naming
// the key; the extremes a fit of records scaled to 1e-300 or 1e300 writes are accepted.
TEST(HugeInputs, ExtremeUnitsMapsAreRefusedAtLoad) {
  const std::string body = R"("model": "gpi", "n": 10, "c": [1, 2, 0, 0], "alpha": 1, "q": 0.1, "rho": 1, "tau": 1,
      "envelope": "tanh")";
  const auto model_json = [&](const std::string& extra) {  // input_limits [0, 0.6] unless extra gives them
    return "{" + body + ", " + extra + (std::string(extra).find("input_limits") != std::string::npos ? "" : R"(, "input_limits": [0, 0.6])") + "}";
  };
  for (const auto& [extra, key] :
       {std::pair{R"("output_gain": 1e-320)", "output_gain = 1e-320"}, std::pair{R"("output_gain": -1e308)", "output_gain = -1e+308"},
        std::pair{R"("input_scale": 4e-310)", "input_scale = 4e-310"}, std::pair{R"("input_scale": 1e308)", "input_scale = 1e+308"},
        std::pair{R"("output_offset": 1e308)", "output_offset = 1e+308"},
        std::pair{R"("output_offset": -1e308, "output_gain": 1e308)", "output_gain = 1e+308"},
        std::pair{R"("input_origin": 1e308)", "input_origin = 1e+308"},
        std::pair{R"("input_origin": 1e306)", "input_limits [0, 0.6] map to"},
        std::pair{R"("input_scale": 1e-300, "input_limits": [-1e10, 1e10])", "input_limits [-1e+10, 1e+10] map to"}}) {
    const std::string json = model_json(extra);
    hysteron_params* p = nullptr;
    EXPECT_EQ(hysteron_params_from_json(json.c_str(), &p), HYSTERON_ERROR_MODEL) << extra;
    EXPECT_EQ(p, nullptr);
    const std::string said = hysteron_last_error();
    EXPECT_NE(said.find(std::string("gpi: ") + key), std::string::npos) << extra << ": " << said;
    try {
      (void)hysteron::io::model_from_json(nlohmann::json::parse(json), "m.json");
      ADD_FAILURE() << extra << ": accepted by io::model_from_json";
    } catch (const hysteron::Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  // large and small but sound maps (a fit of records scaled by 1e300 or 1e-300 writes such)
  for (const char* extra : {R"("output_gain": 1e300, "input_scale": 1e300)", R"("output_gain": 1e-300, "input_scale": 1e-300)",
                            R"("output_offset": 1e300, "output_gain": 1e299)", R"("input_origin": 1e-300)"}) {
    const std::string json = model_json(extra);
    hysteron_params* p = nullptr;
    EXPECT_EQ(hysteron_params_from_json(json.c_str(), &p), HYSTERON_OK) << extra << ": " << hysteron_last_error();
    hysteron_params_free(p);
  }
}
