// Placeholder: the simulate subcommand is not implemented yet (registers nothing).
#include "commands.hpp"

namespace hysteron::cli {
void add_simulate_invert(CLI::App&, Action&) {}
}  // namespace hysteron::cli
