// Placeholder: the report subcommand is not implemented yet (registers nothing).
#include "commands.hpp"

namespace hysteron::cli {
void add_report(CLI::App&, Action&) {}
}  // namespace hysteron::cli
