// Reference signals (signals.hpp).
#include "hysteron/signals.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "hysteron/error.hpp"

namespace hysteron {
namespace {

double segment_value(const WaveSegment& s, double t) noexcept {
  const double phase = t / s.period - std::floor(t / s.period);  // [0, 1)
  const double unit = s.waveform == Waveform::triangle
                          ? 1.0 - std::abs(1.0 - 2.0 * phase)
                          : 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * phase));
  return s.offset + s.amplitude * unit;
}

void check_dt(double dt, const char* where) {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw Error(fmt::format("{}: dt = {} must be > 0", where, dt));
}

// The number of samples of `duration` s at dt, refused above 1e8 (0.8 GB): a dt of 1e-9 s asked
// for 3e10 samples and ended in std::bad_alloc (Python: MemoryError) instead of saying why.
constexpr double kMaxSignalSamples = 1e8;
std::size_t sample_count(double duration, double dt, const char* where) {
  const double n = std::round(duration / dt);
  if (!(n <= kMaxSignalSamples))
    throw Error(fmt::format("{}: {:g} s at dt = {:g} s is {:.3g} samples, more than {:.0e}: choose a larger dt or a "
                            "shorter duration",
                            where, duration, dt, n, kMaxSignalSamples));
  return static_cast<std::size_t>(n);
}

std::vector<double> triangles(std::initializer_list<double> amplitudes, double period, int periods,
                              Waveform w, double dt, const char* where) {
  check_dt(dt, where);
  (void)sample_count(period * periods * static_cast<double>(amplitudes.size()), dt, where);
  std::vector<WaveSegment> segs;
  for (double a : amplitudes) segs.push_back({w, a, period, periods, 0.0});
  return wave_sequence(segs, dt);
}

}  // namespace

std::vector<double> wave_sequence(const std::vector<WaveSegment>& segments, double dt) {
  check_dt(dt, "wave_sequence");
  double duration = 0.0;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const auto& s = segments[i];
    if (!(s.period > 0.0) || !std::isfinite(s.period))
      throw Error(fmt::format("wave_sequence: segment {}: period = {} must be > 0", i, s.period));
    if (s.periods < 1)
      throw Error(fmt::format("wave_sequence: segment {}: periods = {} must be >= 1", i, s.periods));
    if (!std::isfinite(s.amplitude) || !std::isfinite(s.offset))
      throw Error(fmt::format("wave_sequence: segment {}: amplitude and offset must be finite", i));
    duration += s.period * s.periods;
  }
  const std::size_t n = sample_count(duration, dt, "wave_sequence");
  std::vector<double> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = wave_sequence_at(segments, static_cast<double>(k) * dt);
  return out;
}

double wave_sequence_at(const std::vector<WaveSegment>& segments, double t) noexcept {
  if (t < 0.0) return 0.0;
  for (const auto& s : segments) {
    const double len = s.period * s.periods;
    if (t < len) return segment_value(s, t);
    t -= len;
  }
  return 0.0;
}

std::vector<double> gpi_identification_pressure(double dt) {
  return triangles({0.6, 0.5, 0.4, 0.3, 0.2, 0.1}, 5.0, 1, Waveform::triangle, dt, "gpi_identification_pressure");
}

std::vector<double> mpi_identification_pressure(double dt) {
  return triangles({0.5, 0.45, 0.4, 0.35, 0.3}, 5.0, 1, Waveform::triangle, dt, "mpi_identification_pressure");
}

double gpi_sinusoid_length(double t, const SinusoidParams& p) noexcept {
  return p.amplitude * std::sin(2.0 * std::numbers::pi * p.frequency * t + p.phase) + p.offset;
}

double gpi_sinusoid_contraction(double t, double rest_length, const SinusoidParams& p) noexcept {
  return rest_length - gpi_sinusoid_length(t, p);
}

std::vector<double> gpi_sinusoid_reference(double dt, double duration, double rest_length,
                                             const SinusoidParams& p) {
  check_dt(dt, "gpi_sinusoid_reference");
  if (!(duration >= 0.0) || !std::isfinite(duration))
    throw Error(fmt::format("gpi_sinusoid_reference: duration = {} must be >= 0", duration));
  const std::size_t n = sample_count(duration, dt, "gpi_sinusoid_reference");
  std::vector<double> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = gpi_sinusoid_contraction(static_cast<double>(k) * dt, rest_length, p);
  return out;
}

std::vector<double> mpi_triangle_contraction(double dt, int periods_each) {
  return triangles({0.040, 0.035, 0.030}, 5.0, periods_each, Waveform::triangle, dt, "mpi_triangle_contraction");
}

std::vector<double> mpi_sine_contraction(double dt, int periods_each) {
  return triangles({0.040, 0.035, 0.030}, 5.0, periods_each, Waveform::sine, dt, "mpi_sine_contraction");
}

}  // namespace hysteron
