// ns per sample of step (forward), batch simulate, and inverse step for every
// model at n = 10, 20, 50 operators. Run: ./build/hysteron-bench --benchmark_filter=Model
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "hysteron/inverse.hpp"
#include "hysteron/models.hpp"
#include "bench_params.hpp"

using namespace hysteron;

namespace {

constexpr std::size_t kSamples = 4096;

std::vector<double> input_signal(double lo, double hi) {
  // Decaying triangle-ish random walk: reversals of every size, like a rig record.
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> x;
  double cur = 0.5 * (lo + hi);
  while (x.size() < kSamples) {
    const double t = u(rng);
    for (int k = 1; k <= 25 && x.size() < kSamples; ++k) x.push_back(cur + (t - cur) * k / 25.0);
    cur = t;
  }
  return x;
}

const char* kNames[] = {"pi", "gpi", "mpi-deadzone", "mpi-asym"};

// pi and mpi-deadzone with input limits [0, 1], gpi and mpi-asym [0, 0.6] (as measured so far).
ModelParams make_model(int kind, int n) {
  return bench::pi_family_model(kNames[kind], n, kind == 0 || kind == 2 ? Limits{0.0, 1.0} : Limits{0.0, 0.6});
}

void BM_ModelStep(benchmark::State& st) {
  const auto params = make_model(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  Model m(params);
  const auto x = input_signal(0.0, 0.6);
  for (auto _ : st) {
    for (double xk : x) benchmark::DoNotOptimize(m.step(xk));
  }
  st.SetItemsProcessed(st.iterations() * kSamples);
  st.SetLabel(kNames[st.range(0)]);
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_ModelSimulate(benchmark::State& st) {
  const auto params = make_model(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  Model m(params);
  const auto x = input_signal(0.0, 0.6);
  std::vector<double> y(x.size());
  for (auto _ : st) {
    m.simulate(x, y);
    benchmark::DoNotOptimize(y.data());
  }
  st.SetLabel(kNames[st.range(0)]);
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_InverseStep(benchmark::State& st) {
  const auto params = make_model(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  Model m(params);
  const auto yd = m.simulate(input_signal(0.0, 0.6));  // reachable desired outputs
  Inverse inv(params);
  for (auto _ : st) {
    for (double y : yd) benchmark::DoNotOptimize(inv.step(y));
  }
  st.SetLabel(kNames[st.range(0)]);
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// Forward + inverse per sample, chained: the inverse on a desired output, the forward model on its
// input. kind: make_model's index (0 pi, 1 gpi).
void forward_plus_inverse(benchmark::State& st, int kind) {
  const auto params = make_model(kind, static_cast<int>(st.range(0)));
  Model m(params);
  const auto yd = Model(params).simulate(input_signal(0.0, 0.6));
  Inverse inv(params);
  for (auto _ : st) {
    for (double y : yd) benchmark::DoNotOptimize(m.step(inv.step(y)));
  }
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The real-time budget of the issue: GPI forward + inverse per sample.
void BM_GpiForwardPlusInverse(benchmark::State& st) { forward_plus_inverse(st, 1); }

// Where BM_GpiForwardPlusInverse's time goes (README, "GPI forward + inverse"):
// - the same steps with the dependency cut: the inverse on the desired output, the forward model on the
//   input that produced it (the steps of BM_GpiForwardPlusInverse on inputs of the same range, but a
//   sample's forward step no longer waits for its inverse step);
// - the chained steps of a pi (identity envelope, no tanh / atanh), same thresholds and weights;
// - the envelope functions alone on the benchmark's arguments: throughput (independent calls) and
//   latency (each call's argument waits for the previous result).
void BM_GpiForwardPlusInverseUnchained(benchmark::State& st) {
  const auto params = make_model(1, static_cast<int>(st.range(0)));
  Model m(params);
  const auto x = input_signal(0.0, 0.6);
  const auto yd = Model(params).simulate(x);
  Inverse inv(params);
  for (auto _ : st) {
    for (std::size_t k = 0; k < kSamples; ++k) {
      benchmark::DoNotOptimize(inv.step(yd[k]));
      benchmark::DoNotOptimize(m.step(x[k]));
    }
  }
  st.counters["ns/sample"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                                benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_PiForwardPlusInverse(benchmark::State& st) { forward_plus_inverse(st, 0); }

// range(0): 0 tanh_fast, 1 atanh_ratio; range(1): 0 throughput, 1 latency. ns per call.
void BM_EnvelopeFunction(benchmark::State& st) {
  const bool atanh = st.range(0) == 1, chained = st.range(1) == 1;
  std::vector<double> a = input_signal(0.0, 0.6);  // the GPI's envelope tanh(2 x - 0.6) + 0.6, c0 = 1
  for (double& v : a) v = atanh ? detail::tanh_fast(2.0 * v - 0.6) : 2.0 * v - 0.6;
  for (auto _ : st) {
    double carry = 0.0;  // carry * 1e-300 (below 1e-300) orders the calls without changing their work
    if (chained && atanh) {
      for (double v : a) carry = detail::atanh_ratio(v + carry * 1e-300, 1.0);
    } else if (chained) {
      for (double v : a) carry = detail::tanh_fast(v + carry * 1e-300);
    } else if (atanh) {
      for (double v : a) benchmark::DoNotOptimize(detail::atanh_ratio(v, 1.0));
    } else {
      for (double v : a) benchmark::DoNotOptimize(detail::tanh_fast(v));
    }
    benchmark::DoNotOptimize(carry);
  }
  st.SetLabel(std::string(atanh ? "atanh_ratio" : "tanh_fast") + (chained ? " latency" : " throughput"));
  st.counters["ns/call"] = benchmark::Counter(static_cast<double>(st.iterations() * kSamples),
                                              benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// Constructing an inverse (Eq. 11's parameters; the C ABI's hysteron_inverse_create does the same) at n = 10^3 ..
// 10^5 operators: ms per construction. Run: ./build/hysteron-bench --benchmark_filter=InverseConstruct
void BM_InverseConstruct(benchmark::State& st) {
  const auto params = make_model(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  for (auto _ : st) {
    Inverse inv(params);
    benchmark::DoNotOptimize(inv.limits());
  }
  st.SetLabel(kNames[st.range(0)]);
}

void model_args(benchmark::internal::Benchmark* b) {
  for (int kind = 0; kind < 4; ++kind)
    for (int n : {10, 20, 50}) b->Args({kind, n});
}

}  // namespace

BENCHMARK(BM_ModelStep)->Apply(model_args);
BENCHMARK(BM_ModelSimulate)->Apply(model_args);
BENCHMARK(BM_InverseStep)->Apply(model_args);
BENCHMARK(BM_GpiForwardPlusInverse)->Arg(10)->Arg(20)->Arg(50);
BENCHMARK(BM_GpiForwardPlusInverseUnchained)->Arg(10);
BENCHMARK(BM_PiForwardPlusInverse)->Arg(10);
BENCHMARK(BM_EnvelopeFunction)->ArgsProduct({{0, 1}, {0, 1}});
BENCHMARK(BM_InverseConstruct)
    ->ArgsProduct({{0, 1, 2, 3}, {1000, 10000, 100000}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.2);
