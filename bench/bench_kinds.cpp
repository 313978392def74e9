// ns per sample of Model::step and Inverse::step for every model kind (fit_model_kinds) at
// the sizes a fit uses, on one input signal. bench/kinds_speed.sh runs them and prints the
// table; by hand: ./build/hysteron-bench --benchmark_filter='BM_Kind'
//
// Input: a sine of 400 samples' period (25 Hz at 10 kHz) around 0.3 whose amplitude changes at
// every zero crossing (20 half periods, amplitudes 0.05..0.28 in a fixed shuffled order), so
// the reversals have every size; 4000 samples inside the model range [0, 0.6] (MPa-like, the
// papers' pressures). The inverse is fed the model's output on that input (reachable desired
// outputs, once the model's state repeats from pass to pass) and must give the input back
// (checked on two passes before timing; counter "max_err"). Counter "worst_ns": the
// inverse's slowest sample (see BM_KindInverse).
// Parameters are set by hand with plausible values (identity units map, input limits
// [0, 0.6], every invertibility condition of models.hpp met).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "hysteron/inverse.hpp"
#include "hysteron/models.hpp"
#include "bench_params.hpp"

using namespace hysteron;

namespace {

constexpr std::size_t kPeriod = 400;
constexpr std::size_t kSamples = 10 * kPeriod;
constexpr Limits kRange{0.0, 0.6};

const std::vector<double>& input_signal() {
  static const std::vector<double> x = [] {
    // amplitude of each half period (changes where the sine crosses 0.3: continuous input)
    constexpr double amp[20] = {0.28, 0.10, 0.22, 0.05, 0.16, 0.26, 0.08, 0.19, 0.12, 0.24,
                                0.06, 0.27, 0.14, 0.09, 0.21, 0.17, 0.07, 0.25, 0.11, 0.20};
    std::vector<double> v(kSamples);
    for (std::size_t k = 0; k < kSamples; ++k)
      v[k] = 0.3 + amp[k / (kPeriod / 2)] * std::sin(2 * std::numbers::pi * static_cast<double>(k) / kPeriod);
    return v;
  }();
  return x;
}

using bench::pi_operators;

// Preisach / KP grid over the range: density decaying with the loop width alpha - beta,
// total hysteron weight 0.4 whatever the number of levels, q = 0.6.
template <class G>
G grid(int levels) {
  G g;
  g.q = 0.6;
  g.lo = kRange.lo;
  g.hi = kRange.hi;
  g.levels = levels;
  g.input_limits = kRange;
  const double h = (g.hi - g.lo) / levels;
  double sum = 0.0;
  for (int i = 0; i < levels; ++i)
    for (int j = 0; j <= i; ++j) {
      const double width = (i + 1 - j) * h;  // alpha_i - beta_j
      g.w.push_back(std::exp(-width / 0.2));
      sum += g.w.back();
    }
  for (double& w : g.w) w *= 0.4 / sum;
  return g;
}

ModelParams make_params(const std::string& kind, int n) {
  std::vector<double> r, p;
  pi_operators(n, r, p);
  if (kind == "pi" || kind == "gpi" || kind == "mpi-deadzone" || kind == "mpi-asym")
    return bench::pi_family_model(kind, n, kRange);
  if (kind == "preisach") return grid<PreisachParams>(n);
  if (kind == "kp") return grid<KpParams>(n);
  if (kind == "bouc-wen") {
    // clockwise loops, w saturating over about 1/rho = 0.125 of input; min slope kx = 1 > 0
    return BoucWenParams{1.0, 0.3, 8.0, 0.5, 1.0, kRange, {}};
  }
  if (kind == "maxwell-slip") {
    MaxwellSlipParams m;  // slip deflections up to half the range, stiffness 0.5 + 10 x 0.06
    m.k0 = 0.5;
    for (int i = 0; i < n; ++i) {
      m.delta.push_back(0.3 * (i + 1) / n);
      m.k.push_back(0.06);
    }
    m.input_limits = kRange;
    return m;
  }
  if (kind == "rate-pi") {
    // 10 kHz loop, rate filtered over 10 ms; at the sine's top speed (about 44 /s) the
    // thresholds grow by about 40 %. c max(r) = 0.0049 <= (tau + dt) / 2 = 0.00505.
    RatePiParams rp;
    rp.q = 0.5;
    rp.r = r;
    rp.p = p;
    rp.dt = 1e-4;
    rp.tau = 0.01;
    rp.c = 0.009;
    rp.input_limits = kRange;
    return rp;
  }
  std::fprintf(stderr, "bench_kinds: unknown kind %s\n", kind.c_str());
  std::abort();
}

void set_ns_per_sample(benchmark::State& st) {
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_KindStep(benchmark::State& st, const std::string& kind, int n) {
  Model m(make_params(kind, n));
  const auto& x = input_signal();
  for (auto _ : st) {
    for (double xk : x) benchmark::DoNotOptimize(m.step(xk));
  }
  set_ns_per_sample(st);
}

void BM_KindInverse(benchmark::State& st, const std::string& kind, int n) {
  const ModelParams params = make_params(kind, n);
  const auto& x = input_signal();
  // Reachable desired outputs: the model's output over one pass of the input once its state
  // repeats from pass to pass (from the virgin state it takes one pass, rate-pi two), and
  // the inverse started from that forward state: the timed loop's passes are then all the
  // same desired outputs, consistent with the inverse's memory.
  Model m(params);
  m.simulate(x);
  ModelState start = m.state();
  std::vector<double> yd;
  for (int pass = 0;; ++pass) {
    yd = m.simulate(x);
    if (m.state().y == start.y && m.state().u == start.u) break;
    if (pass == 20) {
      st.SkipWithError("the model's state does not repeat from pass to pass");
      return;
    }
    start = m.state();
  }
  Inverse inv(params);
  inv.reset(start);
  // The inverse must give the input back (two passes: the timed loop runs on from the end).
  double err = 0.0;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t k = 0; k < kSamples; ++k) err = std::max(err, std::abs(inv.step(yd[k]) - x[k]));
  if (!(err < 1e-9)) {
    st.SkipWithError(("inverse does not give the input back: max error " + std::to_string(err)).c_str());
    return;
  }
  // The slowest sample (a bracketing inverse's cost varies from sample to sample): each
  // sample timed alone over 3 passes, its fastest time kept (drops preemptions), then the
  // largest over the samples; includes one clock reading (about 20-30 ns).
  std::vector<double> best(kSamples, 1e300);
  for (int pass = 0; pass < 3; ++pass)
    for (std::size_t k = 0; k < kSamples; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(inv.step(yd[k]));
      const auto t1 = std::chrono::steady_clock::now();
      best[k] = std::min(best[k], std::chrono::duration<double, std::nano>(t1 - t0).count());
    }
  const double worst = *std::max_element(best.begin(), best.end());
  for (auto _ : st) {
    for (double y : yd) benchmark::DoNotOptimize(inv.step(y));
  }
  set_ns_per_sample(st);
  st.counters["max_err"] = err;
  st.counters["worst_ns"] = worst;
}

// Every kind, at the sizes of the task: PI kinds and grids at 10 and 20, bouc-wen,
// maxwell-slip and rate-pi at 10 elements. Short runs: 30 benchmarks x 5 repetitions in
// well under 30 s.
const bool registered = [] {
  struct Case {
    const char* kind;
    int n;
    bool sized;  // n in the name
  };
  const Case cases[] = {{"pi", 10, true},         {"pi", 20, true},           {"gpi", 10, true},
                        {"gpi", 20, true},        {"mpi-deadzone", 10, true}, {"mpi-deadzone", 20, true},
                        {"mpi-asym", 10, true},   {"mpi-asym", 20, true},     {"preisach", 10, true},
                        {"preisach", 20, true},   {"kp", 10, true},           {"kp", 20, true},
                        {"bouc-wen", 0, false},   {"maxwell-slip", 10, true}, {"rate-pi", 10, true}};
  for (const Case& c : cases) {
    std::string suffix = "/";
    suffix += c.kind;
    if (c.sized) {
      suffix += '/';
      suffix += std::to_string(c.n);
    }
    const std::string kind = c.kind;
    const int n = c.n;
    benchmark::RegisterBenchmark(("BM_KindStep" + suffix).c_str(),
                                 [kind, n](benchmark::State& st) { BM_KindStep(st, kind, n); })
        ->MinTime(0.05);
    benchmark::RegisterBenchmark(("BM_KindInverse" + suffix).c_str(),
                                 [kind, n](benchmark::State& st) { BM_KindInverse(st, kind, n); })
        ->MinTime(0.05);
  }
  return true;
}();

}  // namespace
