// The stop hook of a fit (check_stop).
#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

void detail::check_stop(const FitOptions& o) {
  if (o.stop_requested && o.stop_requested()) throw Stopped("fit stopped (stop requested)");
}

}  // namespace hysteron
