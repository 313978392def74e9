#pragma once
// One parametrization object per model kind (internal, not installed): its starts,
// bounds, cost, parameter names and its mapping into the report. detail::fit_core
// dispatches over the registry (registry.cpp); a new model kind is one kind_*.cpp file
// and one line of the registry.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "fit_internal.hpp"

namespace hysteron::fitting {

class Parametrization {
 public:
  virtual ~Parametrization() = default;
  // Whether this object fits the kind the options ask for.
  virtual bool handles(const FitOptions& o) const = 0;
  // Number of fitted parameters (the fit needs 10 training samples per parameter).
  virtual int num_parameters(const FitOptions& o) const = 0;
  // Runs LM from the kind's starts within its bounds and fills the report: status,
  // costs, iterations, starts, model (in the coordinates of d) and parameters (named as
  // the keys of the model file, see io::model_to_json) with their standard errors.
  virtual void fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const = 0;
  // The factor by which absorb_scales multiplies the reported parameter `name` (a =
  // input_scale, b = |output_gain|), so that the report reads as the model file.
  virtual double absorbed_factor(std::string_view name, double a, double b) const = 0;
};

// The kinds linear in their weights (cumulative-slope layout, residuals.cpp): LM from
// the kind's starts, bounds by slope_lower, the report through the kind's mapping.
class SlopeParametrization : public Parametrization {
 public:
  void fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const final;

 protected:
  struct Starts {
    std::vector<SlopeLayout> layouts;  // one per start
    std::vector<std::vector<double>> theta;
  };
  virtual Starts starts(const Data& d, const Ranges& rg, const FitOptions& o) const = 0;
  // The model of theta (layout coordinates).
  virtual ModelParams model(const SlopeLayout& L, const double* theta) const = 0;
  // Reported parameters: names and the linear map M from theta to their values.
  virtual std::vector<std::string> names(const SlopeLayout& L) const = 0;
  virtual Eigen::MatrixXd report_map(const SlopeLayout& L) const = 0;
  // ... plus this constant (default none).
  virtual Eigen::VectorXd report_shift(const SlopeLayout& L) const { return Eigen::VectorXd::Zero(L.size()); }
};

// "key[i]": the i-th entry of the model file's array "key".
std::string indexed(std::string_view key, std::size_t i);
// absorbed_factor of a tanh envelope's coefficients "<prefix>c[i]": c[0], c[3] times b,
// c[1] over a; 0 if `name` is not one of them.
double tanh_absorbed_factor(std::string_view name, std::string_view prefix, double a, double b);
// The report map of cumulative slopes s_0..s_n (and the dead-zone slopes per side):
// q = s_0, p_i = s_i - s_{i-1}, g_j = D_j - D_{j-1} (within a side).
Eigen::MatrixXd cumulative_report_map(const SlopeLayout& L);

// The parametrization objects (one per kind, defined in kind_*.cpp).
const Parametrization& pi_kind();
const Parametrization& gpi_kind();
const Parametrization& gpi_free_kind();
const Parametrization& mpi_deadzone_kind();
const Parametrization& mpi_asym_kind();
const Parametrization& preisach_kind();      // kind_linear.cpp
const Parametrization& kp_kind();            // kind_linear.cpp
const Parametrization& maxwell_slip_kind();  // kind_linear.cpp
const Parametrization& rate_pi_kind();       // kind_linear.cpp
const Parametrization& bouc_wen_kind();      // kind_bouc_wen.cpp

// The registry: the parametrization that handles the options, nullptr if none.
const Parametrization* find_parametrization(const FitOptions& o);

}  // namespace hysteron::fitting
