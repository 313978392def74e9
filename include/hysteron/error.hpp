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

// Thrown by fit() and run_experiment() when their stop_requested hook returned true (e.g. the
// Python module's Ctrl-C): the work was abandoned and there is no result. Not an Error (the
// input was fine), so the handlers that turn an Error into a status or a note let it through.
class Stopped : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hysteron
