#pragma once
// Per-sample kernels of the model kinds without PI structure (preisach, kp, bouc-wen,
// rate-pi; equations in models.hpp and docs/models.md). Internal: Model and Inverse
// hold one behind detail::KernelCopy. All work in model coordinates (UnitsMap applied
// outside). step() and peek() never allocate and never throw.
#include <cmath>
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

#include "hysteron/models.hpp"

namespace hysteron::detail {

class Kernel {
 public:
  virtual ~Kernel() = default;
  virtual std::unique_ptr<Kernel> clone() const = 0;
  // Virgin state: relaxed at x = 0 (the units map's input_origin).
  virtual void reset() noexcept = 0;
  // As if x had been held forever after a demagnetising history (symmetric about x).
  virtual void reset_relaxed(double x) noexcept = 0;
  // The output if x were the next input; the state is unchanged. Nondecreasing in x
  // for every state when the parameters are invertible (the inverse brackets on it).
  virtual double peek(double x) const noexcept = 0;
  // One sample: updates the state, returns the output.
  virtual double step(double x) noexcept = 0;
  virtual std::size_t state_size() const noexcept = 0;
  virtual void get_state(double* out) const noexcept = 0;
  // Validates (size checked by the caller) and sets the state; throws hysteron::Error. An
  // entry beyond what inputs with |x_m| <= x_max (Model::input_bound) reach is refused: the
  // next step could overflow from it.
  virtual void set_state(const double* in, double x_max) = 0;
  // Kinds linear in their weights (identification): the regressors of the state after
  // the last step, out[0] = x for the direct term and then one per weight (preisach:
  // relay outputs, kp: ramp outputs, rate-pi: play outputs), num_features() in all.
  virtual std::size_t num_features() const noexcept { return 0; }
  virtual void features(double x, double* out) const noexcept { (void)x, (void)out; }
  // Empty if the output is strictly increasing in the input for every state, otherwise
  // the condition that fails (e.g. "w[3] = -0.1 must be >= 0").
  virtual std::string invertibility() const = 0;
  // The smallest local slope dy/dx over every state, in model coordinates (the direct
  // term, which every hysteron with a weight >= 0 only adds to; bouc-wen: kx + min(kw, 0)
  // rho max(1, 2 sigma)). The fit reports the inverse's largest slope from it.
  virtual double min_slope() const noexcept = 0;
  // A >= 0 with |step(x)| <= A max(|x|, 1), and every intermediate of step() within the
  // same bound, for |x| and the previous inputs bounded by max(|x|, 1) (Model::input_bound).
  virtual double amplification() const noexcept = 0;
};

// The Bouc-Wen state after an input increment dx (models.hpp), integrated by explicit
// steps of h = 1 / (2 rho n) (the step map is then increasing in w: stable) and one
// remainder step, so that w is continuous and nondecreasing in dx for every state (the
// inverse brackets on it). An increment of more than 1000 steps (500 / n input travels
// of 1 / rho) saturates w at sgn(dx), where the exact solution is to rounding.
// `value(t)` returns the plain double of a T (T = double or a ceres::Jet).
template <class T, class Value>
T bouc_wen_increment(T w, double dx, const T& rho, const T& sigma, const T& n, Value value) {
  using std::abs, std::pow;
  const double h = 0.5 / (value(rho) * value(n));
  const double steps = std::abs(dx) / h;
  if (!(steps <= 1000.0)) return T(dx > 0 ? 1.0 : -1.0);
  const int j = static_cast<int>(steps);
  const double dir = dx >= 0 ? 1.0 : -1.0;
  auto step = [&](const T& w0, double d) {
    const double ws = value(w0);
    // |w|^n; below 1e-150 it is 0 to rounding (pow's derivative would divide by |w|)
    const T a = std::abs(ws) < 1e-150 ? T(0.0) : T(pow(abs(w0), n));
    const T f = d * ws > 0 ? T(1.0) : T(1.0) - 2.0 * sigma;  // sigma sgn(dx w) + 1 - sigma
    T w1 = w0 + rho * d * (T(1.0) - f * a);
    if (value(w1) > 1.0) w1 = T(1.0);
    if (value(w1) < -1.0) w1 = T(-1.0);
    return w1;
  };
  for (int i = 0; i < j; ++i) w = step(w, dir * h);
  return step(w, dx - dir * h * j);
}

// Model::input_bound(): the largest |x_m| whose step keeps the output and every
// intermediate within DBL_MAX / 16 (kernel: its amplification(), else the structure's).
double input_bound(const Structure<double>& s, const Kernel* kernel) noexcept;
// The PI family: a bound on |u| and |y_i| of a state (model coordinates) within which the
// output of every step with |x_m| <= x_max stays within DBL_MAX / 16: the larger of what
// those inputs reach and what the weights can sum without overflow.
double state_bound(const Structure<double>& s, double x_max) noexcept;
// Throws hysteron::Error (message starting with `what`) if the PI family's state u or a y_i
// lies beyond state_bound(s, x_max): its next step could overflow to inf or NaN.
void check_state_bound(std::string_view what, const Structure<double>& s, double x_max, const ModelState& state);

// Validates the parameters and builds the kernel; nullptr for the kinds with PI
// structure. Throws hysteron::Error naming the key.
std::unique_ptr<Kernel> make_kernel(const ModelParams& params);
// Whether make_kernel builds a kernel for this kind (has_pi_structure is its negation).
bool has_kernel(const ModelParams& params) noexcept;

// The structure of any kind: canonical_structure for the PI family, only the units map
// (validated) for the others.
Structure<double> structure_of(const ModelParams& params);

}  // namespace hysteron::detail
