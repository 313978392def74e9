// hysteron command-line tool: simulate, invert, fit, experiment, report, demo.
#include <fmt/format.h>

#include <cstdio>
#include <exception>

#include "commands.hpp"
#include "hysteron/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"hysteron: hysteresis models, exact inverses, identification and control of pneumatic muscles"};
  app.require_subcommand(1);
  hysteron::cli::Action action;
  hysteron::cli::set_command_line(argc, argv);
  hysteron::cli::add_simulate_invert(app, action);
  hysteron::cli::add_fit(app, action);
  hysteron::cli::add_experiment(app, action);
  hysteron::cli::add_report(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return action ? action() : 0;
  } catch (const hysteron::Error& e) {
    fmt::print(stderr, "hysteron: error: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "hysteron: internal error: {}\n", e.what());
    return 2;
  }
}
