#pragma once
// Small helpers shared by the tests: a file's bytes, the message of an expected error, a
// random input path with reversals, a note in an experiment's result, a GPI of the rig's magnitude
// and the options of a quick experiment run.
#include <gtest/gtest.h>

#include <cstddef>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"

namespace hysteron::test {

// The whole content of a file ("" if it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The message of the hysteron::Error f throws; "" and a test failure if it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const hysteron::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no hysteron::Error thrown";
  return {};
}

// Random input with reversals of random amplitude inside [lo, hi]: straight segments of
// 3..40 samples from the middle of the range to uniformly drawn targets.
inline std::vector<double> random_walk(std::mt19937_64& rng, std::size_t n, double lo, double hi) {
  std::uniform_real_distribution<double> target(lo, hi);
  std::uniform_int_distribution<int> len(3, 40);
  std::vector<double> x;
  double cur = 0.5 * (lo + hi);
  while (x.size() < n) {
    const double t = target(rng);
    const int m = len(rng);
    for (int k = 1; k <= m && x.size() < n; ++k) x.push_back(cur + (t - cur) * k / m);
    cur = t;
  }
  return x;
}

inline bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Whether one of the result's messages (its `note:` lines) contains `part`.
inline bool said(const ExperimentResult& r, const std::string& part) {
  for (const auto& m : r.messages)
    if (has(m, part)) return true;
  return false;
}

// A quick run of experiment `name` on the nominal rig: mpi-asym pinned (no auto fits of every
// kind), no adaptive variant, `learning_periods` periods of the learning variant.
// A GPI in MPa -> mm of the DMSP-20-500 rig's magnitude (about 100 mm at 0.6 MPa), with the given
// input_limits [MPa] (unset: unbounded).
inline GpiParams rig_like_gpi(Limits input_limits = {0.0, 0.6}) {
  GpiParams g;
  g.envelope = Envelope::tanh(60.0, 3.0, -0.9, 45.0);
  g.q = 0.8;
  g.n = 10;
  g.alpha = 1.0;
  g.rho = 0.05;
  g.tau = 0.1;
  g.input_limits = input_limits;
  return g;
}

inline ExperimentOptions quick_experiment(const std::string& name, int learning_periods = 0) {
  ExperimentOptions o;
  o.name = name;
  o.learning_periods = learning_periods;
  o.adaptive = false;
  o.model = FitModel::mpi_asym;
  return o;
}

}  // namespace hysteron::test
