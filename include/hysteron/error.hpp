#pragma once
// The one exception type of hysteron. Thrown only at set-up and I/O boundaries
// (invalid parameters, malformed files); never by a per-sample step().
#include <stdexcept>
#include <string>

namespace hysteron {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hysteron
