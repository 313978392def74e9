// Placeholder: the experiment subcommand is not implemented yet (registers nothing).
#include "commands.hpp"

namespace hysteron::cli {
void add_experiment(CLI::App&, Action&) {}
}  // namespace hysteron::cli
