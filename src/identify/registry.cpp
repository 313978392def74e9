// The registry of model kinds fitted by detail::fit_core (see kinds.hpp).
#include "kinds.hpp"

namespace hysteron::fitting {

const Parametrization* find_parametrization(const FitOptions& o) {
  static const Parametrization* const kinds[] = {&gpi_kind(),      &gpi_free_kind(),     &pi_kind(),
                                                 &mpi_deadzone_kind(), &mpi_asym_kind(),  &preisach_kind(),
                                                 &kp_kind(),        &maxwell_slip_kind(), &rate_pi_kind(),
                                                 &bouc_wen_kind()};
  for (const Parametrization* k : kinds)
    if (k->handles(o)) return k;
  return nullptr;
}

}  // namespace hysteron::fitting
