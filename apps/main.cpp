// hysteron command-line tool: simulate, invert, fit, evaluate, experiment, report, demo, export.
//
// Exit codes (README, "Command line"): 0 success; 1 error: bad input, bad usage (CLI11's
// parse errors, which CLI11 itself would report as 105-109, are mapped to 1), unreadable
// or unwritable files; fit: 2 no_convergence or failed, 3 poor_fit; 4 internal error.
#include <fmt/format.h>
#include <glog/logging.h>

#include <csignal>
#include <cstdio>
#include <exception>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"

namespace {
// SIGINT, SIGTERM, SIGHUP: remove the temporary files of the writes in progress, then die of
// the signal (default action, re-raised) so that the exit status says so.
extern "C" void on_fatal_signal(int sig) {
  hysteron::io::remove_temporary_files();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void install_signal_handlers() {
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    if (sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;  // e.g. nohup: keep ignoring
    struct sigaction sa {};
    sa.sa_handler = on_fatal_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(sig, &sa, nullptr);
  }
}
}  // namespace

int main(int argc, char** argv) {
  install_signal_handlers();
  // Ceres logs through glog; its lines (e.g. "W0102 12:00:00 ... covariance.cc") must never
  // reach the user's terminal: hysteron reports what matters itself. Only FATAL is kept.
  FLAGS_minloglevel = google::GLOG_FATAL;
  FLAGS_logtostderr = false;
  FLAGS_stderrthreshold = google::GLOG_FATAL;

  CLI::App app{"hysteron: hysteresis models, exact inverses, identification and control of pneumatic muscles"};
  app.require_subcommand(1);
  hysteron::cli::Action action;
  hysteron::cli::set_command_line(argc, argv);
  hysteron::cli::add_simulate_invert(app, action);
  hysteron::cli::add_fit(app, action);
  hysteron::cli::add_evaluate(app, action);
  hysteron::cli::add_experiment(app, action);
  hysteron::cli::add_report(app, action);
  hysteron::cli::add_export(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help / --version: CLI11 prints them and returns 0; every other parse error
    // (unknown option, missing or invalid value, ...) is a usage error: exit 1.
    const int rc = app.exit(e);
    return rc == 0 ? hysteron::cli::exit_ok : hysteron::cli::exit_error;
  }
  try {
    return action ? action() : hysteron::cli::exit_ok;
  } catch (const hysteron::Error& e) {
    fmt::print(stderr, "hysteron: error: {}\n", e.what());
    return hysteron::cli::exit_error;
  } catch (const std::exception& e) {
    fmt::print(stderr, "hysteron: internal error: {}\n", e.what());
    return hysteron::cli::exit_internal;
  }
}
