// hysteron report INPUT --out report.html: one self-contained HTML file from the
// output of `experiment --out DIR` (a directory), `fit --report FILE.json` or
// `evaluate --report FILE.json` (told apart by the document's "format").
#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

namespace {
struct ReportArgs {
  std::string input;
  std::string out = "report.html";
  report::FitDataSource data;
};
using report::FitDataSource;
}  // namespace

void add_report(CLI::App& app, Action& action) {
  auto args = std::make_shared<ReportArgs>();
  auto* cmd = app.add_subcommand(
      "report", "Write one self-contained HTML report (plots, tables, published figures) from the output of "
                "`experiment --out DIR`, `fit --report FILE.json` or `evaluate --report FILE.json`");
  cmd->add_option("input", args->input, "Experiment output directory, fit report or evaluation JSON file")->required();
  cmd->add_option("-o,--out", args->out, "HTML file to write (atomically)")->capture_default_str();
  cmd->add_option("--data,-d", args->data.input_file, "Fit and evaluation documents: the data file (.csv or .mat) the fit or evaluation used");
  cmd->add_option("--input,-i", args->data.input_column, "Fit and evaluation documents: input column (name or 0-based index; .mat: NAME:INDEX for a matrix column)");
  cmd->add_option("--output,-y", args->data.output_column, "Fit and evaluation documents: output column (name or 0-based index)");
  auto* time_column = cmd->add_option(
      "--time-column", args->data.time_column,
      "Fit and evaluation documents: time column of the data (default: the document's, looked up in --data's file too)");
  cmd->add_option("--time-unit", args->data.time_unit,
                  "Fit and evaluation documents: unit of the time column, s, ms or us (default: the document's for its "
                  "own column; for --time-column the unit the file gives it, else s)")
      ->check(one_of({"s", "ms", "us"}));
  cmd->add_flag("--no-time", args->data.no_time,
                "Fit and evaluation documents: draw against the sample index, not the document's time column")
      ->excludes(time_column);
  cmd->callback([args, &action] {
    action = [args] {
      // every override given (each replaces only its own part of the document's data)
      std::string command_line = fmt::format("hysteron report {} --out {}", args->input, args->out);
      const FitDataSource& o = args->data;
      for (const auto& [flag, value] : {std::pair{"--data", o.input_file}, {"--input", o.input_column},
                                        {"--output", o.output_column}, {"--time-column", o.time_column},
                                        {"--time-unit", o.time_unit}})
        if (!value.empty()) command_line += fmt::format(" {} {}", flag, value);
      if (o.no_time) command_line += " --no-time";
      {
        std::vector<io::NamedPath> inputs{{"INPUT", args->input}, {"--data", args->data.input_file}};
        std::error_code ec;
        if (std::filesystem::is_directory(args->input, ec))  // an experiment directory: every file in it
          for (const auto& e : std::filesystem::directory_iterator(args->input, ec))
            inputs.push_back({"INPUT", e.path().string()});
        io::check_output_files({{"--out", args->out}}, inputs);
      }
      report::write_report_from(args->input, args->out, command_line, args->data);
      fmt::print(stderr, "report: wrote {}\n", args->out);
      return 0;
    };
  });
}

}  // namespace hysteron::cli
