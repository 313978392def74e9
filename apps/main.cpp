// hysteron command-line tool: simulate, invert, fit, evaluate, experiment, report, demo, export, sweep, rig.
//
// Exit codes (README, "Command line"): 0 success; 1 error: bad input, bad usage (CLI11's
// parse errors, which CLI11 itself would report as 105-109, are mapped to 1), unreadable
// or unwritable files; fit: 2 no_convergence or failed, 3 poor_fit or a useless validation
// (validation_useless, or a validation record the model cannot be run on); evaluate: 3 a useless
// evaluation (validation_useless against the model file's "training" error); experiment, demo: 3 a
// loop not below the baseline; 4 internal error.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glog/logging.h>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/io/names.hpp"
#include "hysteron/version.hpp"
#include "hysteron/io/numbers.hpp"

namespace {
// SIGINT, SIGTERM, SIGHUP: remove the temporary files of the writes in progress, then die of
// the signal (default action, re-raised) so that the exit status says so.
extern "C" void on_fatal_signal(int sig) {
  hysteron::io::remove_temporary_files();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// " (did you mean X?)" for the closest candidate within a third of the word's length.
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(1, word.size() / 3) + 1;
  for (const std::string& c : candidates) {
    const std::size_t dist = hysteron::io::edit_distance(word, c);
    if (dist < best_d) best_d = dist, best = c;
  }
  return best.empty() ? std::string() : fmt::format(" (did you mean {}?)", best);
}

bool is_number(std::string_view s) {
  double v = 0.0;
  const auto p = hysteron::io::parse_number(s, v);
  return p != hysteron::io::NumberParse::empty && p != hysteron::io::NumberParse::malformed;
}

// Unknown subcommands and options are reported before CLI11 parses, so that
// `simulate --foo` says "unknown option --foo" (not "--model is required"), with
// the closest known name. Returns an exit code, or -1 to go on.
int check_names(CLI::App& app, int argc, char** argv) {
  if (argc < 2) return -1;
  const std::string_view first = argv[1];
  if (first.empty() || first[0] == '-') return -1;  // --help, --version: CLI11's
  std::vector<std::string> commands;
  CLI::App* sub = nullptr;
  for (CLI::App* s : app.get_subcommands({})) {
    commands.push_back(s->get_name());
    if (s->get_name() == first) sub = s;
  }
  if (!sub) {
    fmt::print(stderr, "hysteron: unknown command \"{}\"{}; commands: {}\n", first, suggestion(first, commands),
               fmt::join(commands, ", "));
    return hysteron::cli::exit_error;
  }
  std::vector<std::string> names;
  for (const CLI::Option* o : sub->get_options()) {
    for (const std::string& n : o->get_lnames()) names.push_back("--" + n);
    for (const std::string& n : o->get_snames()) names.push_back("-" + n);
  }
  for (CLI::App* s : sub->get_subcommands({})) names.push_back(s->get_name());
  for (int i = 2; i < argc; ++i) {
    std::string_view a = argv[i];
    if (a == "--") break;
    // values: "-", numbers, "-1,1" (a negative first number of a list)
    if (a.size() < 2 || a[0] != '-' || is_number(a) || std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.')
      continue;
    if (a.substr(0, 2) == "--") a = a.substr(0, a.find('='));
    else a = a.substr(0, 2);  // -xVALUE
    if (std::find(names.begin(), names.end(), a) != names.end()) continue;
    fmt::print(stderr, "hysteron {}: unknown option {}{}; see hysteron {} --help\n", first, a, suggestion(a, names),
               first);
    return hysteron::cli::exit_error;
  }
  return -1;
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
  app.set_version_flag("--version", fmt::format("hysteron {}", hysteron::version), "Print the version and exit");
  hysteron::cli::Action action;
  hysteron::cli::set_command_line(argc, argv);
  hysteron::cli::add_simulate_invert(app, action);
  hysteron::cli::add_fit(app, action);
  hysteron::cli::add_evaluate(app, action);
  hysteron::cli::add_experiment(app, action);
  hysteron::cli::add_report(app, action);
  hysteron::cli::add_export(app, action);
  hysteron::cli::add_sweep(app, action);
  hysteron::cli::add_rig(app, action);
  hysteron::cli::check_float_options(app);
  if (const int rc = check_names(app, argc, argv); rc >= 0) return rc;
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
