#pragma once
// Reference and excitation signals of the papers, sampled at a fixed step.
// Every sampled signal has samples at t_k = k dt, k = 0 .. N - 1 with
// N = round(duration / dt) (so the duration is covered half-open, [0, T)).
// Units: pressure in MPa gauge (the regulator command of RigInputs), lengths
// and contractions in metres, time in seconds.
#include <cstddef>
#include <vector>

namespace hysteron {

enum class Waveform { triangle, sine };

// One segment of a generic periodic signal: `periods` full periods of period
// `period` [s] oscillating between `offset` and `offset + amplitude` (the
// waveform starts at its minimum and rises, e.g. 0 -> A -> 0 for a triangle;
// the sine is offset + A (1 - cos(2 pi t / period)) / 2).
struct WaveSegment {
  Waveform waveform = Waveform::triangle;
  double amplitude = 1.0;  // peak-to-peak excursion above offset (> 0 or 0)
  double period = 5.0;     // [s], > 0
  int periods = 1;         // >= 1
  double offset = 0.0;
};

// Concatenation of segments (each starting at its minimum). Throws
// hysteron::Error on dt <= 0, period <= 0, periods < 1 or non-finite values, and (as
// every signal here) where duration / dt exceeds 1e8 samples.
std::vector<double> wave_sequence(const std::vector<WaveSegment>& segments, double dt);
// Value of the same sequence at time t (0 after the end).
double wave_sequence_at(const std::vector<WaveSegment>& segments, double t) noexcept;

// GPI paper (gpi-lm-feedforward-pid.txt, Sec. 1, Fig. 4): triangle pressure,
// 0.2 Hz, amplitudes 0.6, 0.5, 0.4, 0.3, 0.2, 0.1 MPa, one period each from 0:
// 30 s. [MPa gauge]
std::vector<double> gpi_identification_pressure(double dt);
// Asymmetric MPI paper (mpi-asymmetric-openloop.txt, Methods): triangle pressure
// 0.5, 0.45, 0.4, 0.35, 0.3 MPa. The paper gives no frequency; we use the GPI
// paper's 0.2 Hz (5 s per period): 25 s. [MPa gauge]
std::vector<double> mpi_identification_pressure(double dt);

// GPI paper Eq. 18 with Table 4: y_d(t) = A sin(2 pi f t + phi) + L.
struct SinusoidParams {
  double amplitude = 0.045;              // A [m]  (Table 4: 45 mm)
  double frequency = 0.2;                // f [Hz]
  double phase = 1.5707963267948966;     // phi [rad] (pi/2)
  double offset = 0.450;                 // L [m]  (Table 4: 450 mm)
};
// Desired muscle LENGTH [m] at time t (Eq. 18).
double gpi_sinusoid_length(double t, const SinusoidParams& p = {}) noexcept;
// The same as a contraction x = L0 - y_d [m]: 5..95 mm for L0 = 0.5 m.
double gpi_sinusoid_contraction(double t, double rest_length = 0.5, const SinusoidParams& p = {}) noexcept;
// Sampled contraction reference [m] over `duration` seconds.
std::vector<double> gpi_sinusoid_reference(double dt, double duration, double rest_length = 0.5,
                                           const SinusoidParams& p = {});

// Asymmetric MPI paper (Fig. 8): contraction references with amplitudes 40, 35,
// 30 mm from 0. The paper gives no period; we use 5 s per period (0.2 Hz, as the
// GPI paper) and `periods_each` periods per amplitude (1 or 2): 15 or 30 s. [m]
std::vector<double> mpi_triangle_contraction(double dt, int periods_each = 1);
std::vector<double> mpi_sine_contraction(double dt, int periods_each = 1);

}  // namespace hysteron
