// Identification benchmarks: GPI Levenberg-Marquardt fit (n = 10) on 10,001
// synthetic samples, constrained LS weights, and one RLS step.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "hysteron/identify.hpp"

namespace {

std::vector<double> triangle_input(std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(n);
    const double amp = 6.0 * (1.0 - 0.8 * t);
    x[k] = amp * std::abs(std::fmod(t * 12.0, 2.0) - 1.0);
  }
  return x;
}

hysteron::GpiParams truth() {
  hysteron::GpiParams g;
  g.envelope = hysteron::Envelope::tanh(2.0, 0.4, -1.2, 1.5);
  g.q = 1.0;
  g.rho = 0.5;
  g.tau = 1.5;
  g.alpha = 0.1;
  return g;
}

void BM_FitGpi10k(benchmark::State& state) {
  const auto x = triangle_input(10001);
  const auto y = hysteron::simulate_record(truth(), x);
  hysteron::FitOptions o;
  o.compute_covariance = false;
  o.num_starts = static_cast<int>(state.range(0));
  o.num_threads = static_cast<int>(state.range(1));
  for (auto _ : state) benchmark::DoNotOptimize(hysteron::fit(x, y, o));
}
// Args: {starts, threads}; wall-clock time (the starts may run on worker threads).
BENCHMARK(BM_FitGpi10k)->Args({1, 1})->Args({2, 1})->Args({2, 2})->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_FitWeightsPi10k(benchmark::State& state) {
  const auto x = triangle_input(10001);
  const auto y = hysteron::simulate_record(truth(), x);
  hysteron::PiParams pi;
  pi.r = hysteron::default_thresholds(x, 10);
  pi.p.assign(pi.r.size(), 0.0);
  for (auto _ : state) benchmark::DoNotOptimize(hysteron::fit_weights(pi, x, y));
}
BENCHMARK(BM_FitWeightsPi10k)->Unit(benchmark::kMillisecond);

void BM_RlsStep(benchmark::State& state) {
  const auto x = triangle_input(10001);
  const auto y = hysteron::simulate_record(truth(), x);
  hysteron::PiParams pi;
  pi.r = hysteron::default_thresholds(x, 10);
  pi.p.assign(pi.r.size(), 0.0);
  hysteron::Rls rls(pi, 0.999);
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rls.step(x[k], y[k]));
    if (++k == x.size()) k = 0;
  }
}
BENCHMARK(BM_RlsStep);

}  // namespace
