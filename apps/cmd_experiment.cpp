// hysteron experiment NAME (the registry's names, experiment.hpp) and hysteron demo.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

namespace {

struct ExperimentArgs {
  std::string name;
  std::string plant;
  std::string tracking_plant;
  bool no_adaptive = false;
  std::uint64_t seed = 1;
  int learning_periods = 10;
  double control_period = ExperimentOptions{}.control_period;  // [s]
  bool json = false;
  std::string out;
  std::string model = "auto";
  bool paper_references = false;
  std::vector<std::string> references;  // --reference SPEC (experiment only)
};

// "auto" and every kind fit() identifies (the registry, identify.hpp).
std::vector<std::string> model_choices() {
  std::vector<std::string> names{std::string(fit_model_name(FitModel::automatic))};
  for (FitModel m : fit_model_kinds) names.emplace_back(fit_model_name(m));
  return names;
}

std::string model_help() {
  std::string kinds;
  for (FitModel m : fit_model_kinds) kinds += (kinds.empty() ? "" : ", ") + std::string(fit_model_name(m));
  return fmt::format("Kind of hysteron's model, the one the compensated, learning and adaptive variants invert: auto "
                     "(default: every kind fitted on the identification run, the least RMS on a second run chosen) "
                     "or one of {} (only that one; an error if it cannot be fitted or inverted). The adaptive "
                     "variant needs the PI family and is skipped, with a note, for another kind.",
                     kinds);
}

void add_model_options(CLI::App* cmd, ExperimentArgs& args) {
  add_control_period_option(cmd, args.control_period);
  cmd->add_option("--model", args.model, model_help())->check(one_of(model_choices()))->default_val("auto");
  cmd->add_flag("--paper-references", args.paper_references,
                "Track the papers' references as published (or --reference's as given) even where they leave the "
                "contraction range this rig reached in its identification run (default: such a reference is mapped "
                "into the rig's reach, with a note; docs/control.md, section 5)");
}

ExperimentOptions options_from(const ExperimentArgs& a) {
  ExperimentOptions o;
  o.name = a.name;
  o.seed = a.seed;
  o.learning_periods = a.learning_periods;
  o.control_period = a.control_period;
  if (!a.plant.empty()) o.rig = load_rig_params(a.plant);
  if (!a.tracking_plant.empty()) o.tracking_rig = load_rig_params(a.tracking_plant);
  o.adaptive = !a.no_adaptive;
  o.model = fit_model_from_name(a.model);
  o.fit_references = !a.paper_references;
  o.references = parse_references(a.references, "--reference");
  return o;
}

std::string join_args(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

std::string g_command;  // the command line, shown in reports

// The run's input files (--plant, --tracking-plant, the --reference records) must not be files
// it writes into `dir` or removes there as stale (ExperimentResult::check_inputs_not_outputs).
void check_inputs_not_outputs(const ExperimentArgs& a, const std::string& dir) {
  std::vector<std::pair<std::string, std::string>> inputs;
  if (!a.plant.empty()) inputs.emplace_back("--plant", a.plant);
  if (!a.tracking_plant.empty()) inputs.emplace_back("--tracking-plant", a.tracking_plant);
  for (const UserReference& u : parse_references(a.references, "--reference"))
    if (u.kind == UserReference::Kind::file) inputs.emplace_back("--reference", u.path);
  ExperimentResult::check_inputs_not_outputs(dir, inputs);
}

// exit_poor_fit (3), with the runs named on stderr, where one of hysteron's loops ended at or above the
// baseline: the results are written and printed, but a compensation no better than a straight line
// must not exit as a success (README, Exit codes).
int not_below_baseline_exit(const ExperimentResult& r) {
  const std::vector<std::string> useless = r.not_below_baseline();
  if (useless.empty()) return exit_ok;
  fmt::print(stderr, "experiment: {}: not below the baseline's RMS error: {} (its notes say why; exit {})\n", r.name,
             fmt::join(useless, ", "), exit_poor_fit);
  return exit_poor_fit;
}

}  // namespace

void set_command_line(int argc, char** argv) { g_command = join_args(argc, argv); }
const std::string& command_line() { return g_command; }

void add_experiment(CLI::App& app, Action& action) {
  auto args = std::make_shared<ExperimentArgs>();
  auto* cmd = app.add_subcommand("experiment", "Run one of the papers' experiments end to end on the simulated rig");
  std::string names_help;
  for (const auto& e : experiments()) names_help += fmt::format("\n  {:<14}{}", e.name, e.title);
  cmd->add_option("name", args->name, "The experiment:" + names_help)
      ->required()
      ->check(one_of(experiment_names()));
  cmd->add_option("--learning-periods", args->learning_periods,
                  "Periods of the learning variant (0: no learning runs; default 10)")
      ->check(CLI::Range(0, 1000));
  cmd->add_option("--plant", args->plant, "Rig parameters (JSON; unknown keys are an error)");
  cmd->add_option("--tracking-plant", args->tracking_plant,
                  "Rig parameters of the tracking runs (JSON), if the rig changed after its identification on "
                  "--plant (default: the same rig)");
  cmd->add_option("--reference", args->references,
                  "A reference of your own, tracked instead of the paper's (repeatable; default: the paper's): "
                  "sine:amplitude=MM,offset=MM,frequency=HZ,periods=N (offset - amplitude cos(2 pi f t), the "
                  "papers' sine), triangle:amplitude=MM,offset=MM,frequency=HZ,periods=N (offset -+ amplitude), or "
                  "file:PATH[,time=COL][,contraction=COL][,time_unit=s|ms|us][,unit=mm|m|um][,periodic][,periods=N] "
                  "(a record (PATH without commas), time and contraction in the units their header names or the keys "
                  "give, else s and mm; columns 0 and 1 by default; interpolated at the control period; periodic: the "
                  "record is one period). Each takes name=NAME (default: its kind, or refN). docs/control.md, "
                  "section 8")
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--no-adaptive", args->no_adaptive, "Do not run the adaptive variant");
  add_model_options(cmd, *args);
  cmd->add_option("--seed", args->seed, "Seed of the rig's noise (default 1)")
      ->check(non_negative_integer());
  cmd->add_flag("--json", args->json, "Print one JSON object instead of the table");
  cmd->add_option("--out", args->out, "Directory for the time series (CSV), models and result.json");
  cmd->callback([args, &action] {
    action = [args] {
      // a bad spec: nothing checked, read or run before; an input that is an output: nothing run
      check_inputs_not_outputs(*args, args->out);
      io::check_output_directory({"--out", args->out});  // before the run, not after it
      const ExperimentResult r = run_experiment(options_from(*args));
      if (!args->out.empty())  // the files and the report replaced together
        ExperimentResult::write_all({&r}, {args->out}, [&](std::size_t, const std::string& dir) {
          report::write_experiment_report(r, dir + "/report.html", g_command);
          return std::vector<std::string>{"report.html"};
        });
      if (args->json)
        fmt::print("{}\n", io::to_json(r).dump(2));
      else
        fmt::print("{}", r.table());
      return not_below_baseline_exit(r);
    };
  });

  auto dargs = std::make_shared<ExperimentArgs>();
  auto* demo = app.add_subcommand("demo", "The main job: the three experiments beside the papers' figures");
  demo->add_option("--plant", dargs->plant, "Rig parameters (JSON)");
  demo->add_option("--seed", dargs->seed, "Seed of the rig's noise (default 1)")
      ->check(non_negative_integer());
  demo->add_option("--learning-periods", dargs->learning_periods,
                   "Periods of the learning variant (0: no learning runs; default 10)")
      ->check(CLI::Range(0, 1000));
  add_model_options(demo, *dargs);
  demo->add_option("--out", dargs->out, "Directory for every experiment's outputs (default out/demo)")
      ->default_val("out/demo");
  demo->callback([dargs, &action] {
    action = [dargs] {
      for (const auto& name : experiment_names()) check_inputs_not_outputs(*dargs, dargs->out + "/" + name);
      io::check_output_directory({"--out", dargs->out});
      for (const auto& name : experiment_names()) {  // every option checked before the first run writes
        ExperimentArgs a = *dargs;
        a.name = name;
        options_from(a).validate();
      }
      // every experiment run before any directory is written, then all written together: an
      // interrupted demo (Ctrl-C) leaves the previous one whole, never a mix of two runs
      int code = exit_ok;
      std::vector<ExperimentResult> results;
      std::vector<std::string> dirs;
      for (const auto& name : experiment_names()) {
        ExperimentArgs a = *dargs;
        a.name = name;
        results.push_back(run_experiment(options_from(a)));
        dirs.push_back(dargs->out + "/" + name);
        fmt::print("{}\n", results.back().table());  // progress: the outputs are written at the end
        std::fflush(stdout);
        code = std::max(code, not_below_baseline_exit(results.back()));
      }
      std::vector<const ExperimentResult*> all;
      for (const auto& r : results) all.push_back(&r);
      ExperimentResult::write_all(all, dirs, [&](std::size_t i, const std::string& dir) {
        report::write_experiment_report(results[i], dir + "/report.html", g_command);
        return std::vector<std::string>{"report.html"};
      });
      for (const auto& dir : dirs) fmt::print("outputs: {}/   report: {}/report.html\n", dir, dir);
      return code;
    };
  });
}

}  // namespace hysteron::cli
