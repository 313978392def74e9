// ns per number of the CSV side's two conversions, on the input of bench/io_speed.sh and
// bench/numpy_compare.sh (x_k = 0.3 + 0.25 sin(2e-4 k) cos(3e-6 k), 17 significant digits):
// shortest round-trip formatting (std::to_chars, what CsvRowWriter uses; fmt's Dragonbox for
// comparison) and parsing (std::from_chars, what the text reader uses). The floor of a CSV
// simulate: 1M numbers parsed, 2M formatted. Run:
//   ./build/hysteron-bench --benchmark_filter=TextNumber
#include <benchmark/benchmark.h>
#include <fmt/compile.h>
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <string>
#include <system_error>
#include <vector>

namespace {

constexpr std::size_t kNumbers = 1 << 16;

std::vector<double> values() {
  std::vector<double> x(kNumbers);
  for (std::size_t k = 0; k < kNumbers; ++k) {
    const double kk = static_cast<double>(k) * 15.0;  // spread over the 1M-sample signal
    x[k] = 0.3 + 0.25 * std::sin(2e-4 * kk) * std::cos(3e-6 * kk);
  }
  return x;
}

void BM_TextNumberFormatToChars(benchmark::State& st) {
  const std::vector<double> x = values();
  std::vector<char> buf(32 * kNumbers);
  for (auto _ : st) {
    char* p = buf.data();
    for (double v : x) {
      p = std::to_chars(p, p + 32, v).ptr;
      *p++ = '\n';
    }
    benchmark::DoNotOptimize(p);
  }
  st.counters["ns/number"] = benchmark::Counter(static_cast<double>(kNumbers),
                                                benchmark::Counter::kIsIterationInvariantRate |
                                                    benchmark::Counter::kInvert);
}
BENCHMARK(BM_TextNumberFormatToChars)->Unit(benchmark::kMicrosecond);

void BM_TextNumberFormatFmt(benchmark::State& st) {
  const std::vector<double> x = values();
  std::vector<char> buf(32 * kNumbers);
  for (auto _ : st) {
    char* p = buf.data();
    for (double v : x) {
      p = fmt::format_to(p, FMT_COMPILE("{}"), v);
      *p++ = '\n';
    }
    benchmark::DoNotOptimize(p);
  }
  st.counters["ns/number"] = benchmark::Counter(static_cast<double>(kNumbers),
                                                benchmark::Counter::kIsIterationInvariantRate |
                                                    benchmark::Counter::kInvert);
}
BENCHMARK(BM_TextNumberFormatFmt)->Unit(benchmark::kMicrosecond);

void BM_TextNumberParseFromChars(benchmark::State& st) {
  const std::vector<double> x = values();
  std::string text;
  for (double v : x) {
    char b[32];
    text.append(b, std::to_chars(b, b + 32, v).ptr);
    text.push_back('\n');
  }
  for (auto _ : st) {
    const char* p = text.data();
    const char* end = p + text.size();
    double sum = 0.0;
    while (p < end) {
      double v = 0.0;
      const auto r = std::from_chars(p, end, v);
      if (r.ec != std::errc()) st.SkipWithError("from_chars failed");
      sum += v;
      p = r.ptr + 1;  // the '\n'
    }
    benchmark::DoNotOptimize(sum);
  }
  st.counters["ns/number"] = benchmark::Counter(static_cast<double>(kNumbers),
                                                benchmark::Counter::kIsIterationInvariantRate |
                                                    benchmark::Counter::kInvert);
}
BENCHMARK(BM_TextNumberParseFromChars)->Unit(benchmark::kMicrosecond);

}  // namespace
