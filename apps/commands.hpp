#pragma once
// The hysteron CLI is one executable with subcommands; each lives in its own
// apps/cmd_*.cpp and registers itself here. An action returns the exit code;
// user errors are thrown as hysteron::Error and reported by main() (exit 1).
#include <CLI/CLI.hpp>

#include <functional>

namespace hysteron::cli {

using Action = std::function<int()>;

void add_simulate_invert(CLI::App& app, Action& action);  // cmd_simulate.cpp: simulate, invert
void add_fit(CLI::App& app, Action& action);              // cmd_fit.cpp: fit
void add_experiment(CLI::App& app, Action& action);       // cmd_experiment.cpp: experiment, demo
void add_report(CLI::App& app, Action& action);           // cmd_report.cpp: report
void set_command_line(int argc, char** argv);             // recorded in reports

}  // namespace hysteron::cli
