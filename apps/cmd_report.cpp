// hysteron report INPUT --out report.html: one self-contained HTML file from the
// output of `experiment --out DIR` (a directory) or `fit --report FILE.json`.
#include <fmt/format.h>

#include <memory>
#include <string>

#include "commands.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

namespace {
struct ReportArgs {
  std::string input;
  std::string out = "report.html";
};
}  // namespace

void add_report(CLI::App& app, Action& action) {
  auto args = std::make_shared<ReportArgs>();
  auto* cmd = app.add_subcommand(
      "report", "Write one self-contained HTML report (plots, tables, published figures) from the output of "
                "`experiment --out DIR` or `fit --report FILE.json`");
  cmd->add_option("input", args->input, "Experiment output directory or fit report JSON file")->required();
  cmd->add_option("-o,--out", args->out, "HTML file to write (atomically)")->capture_default_str();
  cmd->callback([args, &action] {
    action = [args] {
      const std::string command_line = fmt::format("hysteron report {} --out {}", args->input, args->out);
      report::write_report_from(args->input, args->out, command_line);
      fmt::print(stderr, "report: wrote {}\n", args->out);
      return 0;
    };
  });
}

}  // namespace hysteron::cli
