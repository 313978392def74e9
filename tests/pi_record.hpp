// A record of input/output samples and the PI the fit tests generate their records through
// (test_fit_quality.cpp, test_sensor_faults.cpp).
#pragma once
#include <vector>

#include "hysteron/models.hpp"

namespace hysteron::test {

struct Record {
  std::vector<double> x, y;
};

// q = 0.5, thresholds 0.05..0.3, weights 0.4..0.1
inline PiParams pi_truth() {
  PiParams p;
  p.q = 0.5;
  p.r = {0.05, 0.1, 0.2, 0.3};
  p.p = {0.4, 0.3, 0.2, 0.1};
  return p;
}

}  // namespace hysteron::test
