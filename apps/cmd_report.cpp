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
  cmd->callback([args, &action] {
    action = [args] {
      std::string command_line = fmt::format("hysteron report {} --out {}", args->input, args->out);
      if (!args->data.input_file.empty())
        command_line += fmt::format(" --data {} --input {} --output {}", args->data.input_file,
                                    args->data.input_column, args->data.output_column);
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
