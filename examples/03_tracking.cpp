// Compensated tracking on the simulated rig (GPI paper, Fig. 10): identify a
// GPI model from the Fig. 4 pressure input, then track the Eq. 18 sinusoid
// with inverse-GPI feedforward + the PID of Table 3. Fails if the maximum
// tracking error after the first second exceeds 8 mm.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <hysteron/compensation.hpp>
#include <hysteron/identify.hpp>
#include <hysteron/plant.hpp>
#include <hysteron/signals.hpp>

int main() {
  const double ts = 1e-3;  // control period [s]
  hysteron::PamRig rig(hysteron::PamRigParams{}, 1);
  const auto every = hysteron::control_steps(ts, rig.dt(), "example");  // rig steps per control period

  // 1. identification run, logged at 100 Hz: measured pressure [MPa] -> contraction [mm]
  std::vector<double> p, x;
  const std::vector<double> u = hysteron::gpi_identification_pressure(ts);
  hysteron::RigOutputs out;
  for (std::size_t k = 0; k < u.size(); ++k) {
    for (int s = 0; s < every; ++s) out = rig.step({u[k], 0.0, hysteron::Actuation::regulator});
    if (k % 10 == 0) {
      p.push_back(out.pressure_measured * 1e-6);
      x.push_back(out.contraction_measured * 1e3);
    }
  }
  rig.check();
  hysteron::FitOptions o;
  o.num_operators = 10;
  const hysteron::FitReport fit = hysteron::fit(p, x, o);
  fmt::print("identification: {}\n", fit.brief_report());
  if (fit.status == hysteron::FitStatus::invalid_input || fit.status == hysteron::FitStatus::failed) return 1;

  // 2. tracking: inverse feedforward + PID, pressure command clamped to the muscle's rating
  // (0..0.6 MPa); left unset, the limits would be the model's input range (the fit's measured pressures)
  hysteron::FeedforwardParams ff;
  ff.sample_time = ts;
  ff.pressure_limits = {0.0, rig.params().muscle.max_pressure * 1e-6};  // [MPa]
  hysteron::FeedforwardPidController ctl(fit.model, ff, hysteron::gpi_paper_pid(ts));
  const std::vector<double> ref = hysteron::gpi_sinusoid_reference(ts, 10.0);  // contraction [m]
  rig.reset();
  double max_err = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < ref.size(); ++k) {
    const double cmd = ctl.step(ref[k], ref[k], out.contraction_measured);
    for (int s = 0; s < every; ++s) out = rig.step({cmd, 0.0, hysteron::Actuation::regulator});
    if (k * ts >= 1.0 && k + 1 < ref.size()) {
      const double e = (ref[k + 1] - out.contraction_measured) * 1e3;
      max_err = std::max(max_err, std::abs(e));
      sum2 += e * e;
      ++n;
    }
  }
  rig.check();
  const double rms = std::sqrt(sum2 / static_cast<double>(n));
  fmt::print("tracking the Eq. 18 sinusoid for 10 s: max error {:.3f} mm, RMS {:.3f} mm (paper: 2.659, 0.8701)\n",
             max_err, rms);
  return max_err < 8.0 ? 0 : 1;
}
