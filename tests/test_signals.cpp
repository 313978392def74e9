// Reference signals (signals.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "hysteron/error.hpp"
#include "hysteron/signals.hpp"

using namespace hysteron;

namespace {
double max_in(const std::vector<double>& v, double t0, double t1, double dt) {
  double m = -1e300;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const double t = static_cast<double>(k) * dt;
    if (t >= t0 && t < t1) m = std::max(m, v[k]);
  }
  return m;
}
}  // namespace

TEST(Signals, GpiIdentificationPressure) {
  const double dt = 1e-3;
  const auto u = gpi_identification_pressure(dt);
  ASSERT_EQ(u.size(), 30000u);  // six 5 s periods
  EXPECT_DOUBLE_EQ(u[0], 0.0);
  EXPECT_NEAR(u[2500], 0.6, 1e-12);  // peak of the first triangle at 2.5 s
  EXPECT_NEAR(u[1250], 0.3, 1e-12);  // linear ramp
  const double amps[] = {0.6, 0.5, 0.4, 0.3, 0.2, 0.1};
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(max_in(u, 5.0 * i, 5.0 * (i + 1), dt), amps[i], 1e-12) << i;
    EXPECT_NEAR(u[static_cast<std::size_t>(5000 * i)], 0.0, 1e-12) << i;  // each period starts at 0
  }
  EXPECT_TRUE(std::all_of(u.begin(), u.end(), [](double x) { return x >= 0.0 && x <= 0.6; }));
}

TEST(Signals, MpiIdentificationPressure) {
  const double dt = 1e-3;
  const auto u = mpi_identification_pressure(dt);
  ASSERT_EQ(u.size(), 25000u);
  const double amps[] = {0.5, 0.45, 0.4, 0.35, 0.3};
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(max_in(u, 5.0 * i, 5.0 * (i + 1), dt), amps[i], 1e-12) << i;
}

TEST(Signals, GpiSinusoidEq18Table4) {
  // y_d = 45 sin(2 pi 0.2 t + pi/2) + 450 mm: starts at 495 mm length = 5 mm contraction.
  EXPECT_NEAR(gpi_sinusoid_length(0.0), 0.495, 1e-12);
  EXPECT_NEAR(gpi_sinusoid_length(2.5), 0.405, 1e-12);
  EXPECT_NEAR(gpi_sinusoid_contraction(0.0), 0.005, 1e-12);
  EXPECT_NEAR(gpi_sinusoid_contraction(2.5), 0.095, 1e-12);
  EXPECT_NEAR(gpi_sinusoid_contraction(1.25), 0.050, 1e-12);
  const auto r = gpi_sinusoid_reference(1e-3, 10.0);
  ASSERT_EQ(r.size(), 10000u);
  EXPECT_NEAR(*std::max_element(r.begin(), r.end()), 0.095, 1e-9);
  EXPECT_NEAR(*std::min_element(r.begin(), r.end()), 0.005, 1e-9);
}

TEST(Signals, MpiContractionReferences) {
  const double dt = 1e-3;
  const auto tri = mpi_triangle_contraction(dt, 1);
  const auto sine = mpi_sine_contraction(dt, 2);
  ASSERT_EQ(tri.size(), 15000u);
  ASSERT_EQ(sine.size(), 30000u);
  const double amps[] = {0.040, 0.035, 0.030};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(max_in(tri, 5.0 * i, 5.0 * (i + 1), dt), amps[i], 1e-12);
    EXPECT_NEAR(max_in(sine, 10.0 * i, 10.0 * (i + 1), dt), amps[i], 1e-12);
  }
  EXPECT_NEAR(sine[1250], 0.020, 1e-12);  // (1 - cos(pi/2)) / 2 * 40 mm
}

TEST(Signals, GenericSequenceValidates) {
  EXPECT_THROW(wave_sequence({{Waveform::sine, 1.0, 0.0, 1, 0.0}}, 1e-3), Error);
  EXPECT_THROW(wave_sequence({{Waveform::sine, 1.0, 1.0, 0, 0.0}}, 1e-3), Error);
  EXPECT_THROW(wave_sequence({{Waveform::sine, NAN, 1.0, 1, 0.0}}, 1e-3), Error);
  EXPECT_THROW(wave_sequence({}, 0.0), Error);
  const std::vector<WaveSegment> s{{Waveform::triangle, 2.0, 1.0, 2, 1.0}};
  const auto v = wave_sequence(s, 0.25);
  const std::vector<double> expect{1.0, 2.0, 3.0, 2.0, 1.0, 2.0, 3.0, 2.0};
  ASSERT_EQ(v.size(), expect.size());
  for (std::size_t k = 0; k < v.size(); ++k) EXPECT_NEAR(v[k], expect[k], 1e-12) << k;
  EXPECT_EQ(wave_sequence_at(s, 5.0), 0.0);
}
