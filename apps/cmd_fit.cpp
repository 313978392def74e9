// Placeholder: the fit subcommand is not implemented yet (registers nothing).
#include "commands.hpp"

namespace hysteron::cli {
void add_fit(CLI::App&, Action&) {}
}  // namespace hysteron::cli
