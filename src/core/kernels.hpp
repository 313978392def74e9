#pragma once
// Per-sample kernels of the model kinds without PI structure (preisach, kp, bouc-wen,
// rate-pi; equations in models.hpp and docs/models.md). Internal: Model and Inverse
// hold one behind detail::KernelCopy. All work in model coordinates (UnitsMap applied
// outside). step() and peek() never allocate and never throw.
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
  // Validates (size checked by the caller) and sets the state; throws hysteron::Error.
  virtual void set_state(const double* in) = 0;
  // Empty if the output is strictly increasing in the input for every state, otherwise
  // the condition that fails (e.g. "w[3] = -0.1 must be >= 0").
  virtual std::string invertibility() const = 0;
};

// Validates the parameters and builds the kernel; nullptr for the kinds with PI
// structure. Throws hysteron::Error naming the key.
std::unique_ptr<Kernel> make_kernel(const ModelParams& params);

// The structure of any kind: canonical_structure for the PI family, only the units map
// (validated) for the others.
Structure<double> structure_of(const ModelParams& params);

}  // namespace hysteron::detail
