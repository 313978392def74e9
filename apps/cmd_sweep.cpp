// hysteron sweep EXPERIMENT... --vary PATH=V1,V2 ... | --grid FILE | --set documented:
// the papers' experiments over plant variants, on all cores (docs/plant.md, "Plant variants").
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/sweep.hpp"

namespace hysteron::cli {

namespace {

struct SweepArgs {
  std::vector<std::string> experiments;
  std::vector<std::string> vary;
  std::string grid;
  std::string set;
  std::string plant;
  std::uint64_t seed = 1;
  int learning_periods = ExperimentOptions{}.learning_periods;
  double control_period = ExperimentOptions{}.control_period;  // [s]
  std::string model = "auto";
  bool paper_references = false;
  std::vector<std::string> references;  // --reference SPEC
  bool identify_on_base = false;
  unsigned jobs = 0;
  std::string out;
  std::string report;
  bool json = false;
};

// Progress on stderr: on a terminal, a bar redrawn in place at every finished run and every
// second (elapsed time); else one line per finished run.
class Progress {
 public:
  explicit Progress(std::size_t total)
      : tty_(::isatty(STDERR_FILENO) == 1), total_(total), start_(std::chrono::steady_clock::now()) {
    if (!tty_) return;
    ticker_ = std::thread([this] {
      std::unique_lock<std::mutex> lock(mutex_);
      while (!stop_) {
        wake_.wait_for(lock, std::chrono::seconds(1));
        if (!stop_) draw();
      }
    });
  }
  ~Progress() { finish(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void operator()(const SweepProgress& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = p.done;
    last_ = fmt::format("{} {}: {}", p.experiment, p.variant, p.ok ? "ok" : "FAILED");
    if (tty_) {
      draw();
    } else {
      fmt::print(stderr, "sweep: {}/{} {} ({:.1f} s)\n", p.done, p.total, last_, p.wall_time_s);
      std::fflush(stderr);
    }
  }
  // Stops the ticker and ends the bar's line.
  void finish() {
    if (!ticker_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    ticker_.join();
    if (drawn_) fmt::print(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  void draw() {  // with mutex_ held
    drawn_ = true;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    constexpr std::size_t width = 30;
    const std::size_t filled = total_ ? width * done_ / total_ : width;
    std::string eta;
    if (done_ > 0 && done_ < total_)
      eta = fmt::format(", ~{:.0f} s left", elapsed * static_cast<double>(total_ - done_) / static_cast<double>(done_));
    fmt::print(stderr, "\r\033[K[{}{}] {}/{} runs, {:.0f} s{}{}{}", std::string(filled, '#'),
               std::string(width - filled, '-'), done_, total_, elapsed, eta, last_.empty() ? "" : "  last: ", last_);
    std::fflush(stderr);
  }

  bool tty_;
  std::size_t total_, done_ = 0;
  std::string last_;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false, drawn_ = false;
  std::thread ticker_;
};

int run_sweep_command(const SweepArgs& a) {
  // outputs must not be inputs; nothing is read before this check
  std::vector<io::NamedPath> outputs, inputs;
  if (!a.out.empty()) outputs.push_back({"--out", a.out});
  if (!a.report.empty()) outputs.push_back({"--report", a.report});
  if (!a.grid.empty()) inputs.push_back({"--grid", a.grid});
  if (!a.plant.empty()) inputs.push_back({"--plant", a.plant});
  for (const std::string& spec : a.references)  // the --reference records (only their paths: nothing read)
    if (const auto path = reference_file_path(spec)) inputs.push_back({"--reference", *path});
  io::check_output_files(outputs, inputs);  // where the table and the page go, before the sweep's runs
  // an output naming stdout (-, /dev/stdout, the file stdout is redirected to) is handled as - is
  const bool out_stdout = names_stdout(a.out);
  if (a.json && out_stdout) throw Error(fmt::format("--json and --out {} both write to stdout: choose one", a.out));
  if (names_stdout(a.report))
    throw Error(fmt::format(
        "--report {}: the HTML page needs a file of its own, not stdout (where the table is printed)", a.report));

  SweepOptions o;
  o.seed = a.seed;
  o.learning_periods = a.learning_periods;
  o.control_period = a.control_period;
  o.model = fit_model_from_name(a.model);
  o.fit_references = !a.paper_references;
  o.references = parse_references(a.references, "--reference");
  o.identify_on_base = a.identify_on_base;
  o.jobs = a.jobs;
  o.experiments = sweep_experiments(a.experiments);
  if (!a.plant.empty()) o.base = load_rig_params(a.plant);
  if (a.vary.empty() && a.grid.empty() && a.set.empty())
    throw Error(fmt::format("sweep: no variants: give --vary PATH=V1,V2,..., --grid FILE.json or --set {}",
                            documented_set_name));
  if (!a.set.empty())
    for (auto& v : variant_set(a.set, "--set")) o.variants.push_back(std::move(v));
  for (const auto& spec : a.vary)
    for (auto& v : parse_vary(spec)) o.variants.push_back(std::move(v));
  if (!a.grid.empty())
    for (auto& v : read_variant_grid(a.grid)) o.variants.push_back(std::move(v));

  // the number of runs: the base rig and every distinct variant rig, for each experiment
  std::size_t rigs = 1;
  {
    std::vector<nlohmann::json> seen = {rig_params_to_json(o.base)};
    for (const auto& v : o.variants) {
      nlohmann::json j = rig_params_to_json(apply_overrides(o.base, v.overrides, fmt::format("variant '{}'", v.name)));
      if (std::find(seen.begin(), seen.end(), j) == seen.end()) seen.push_back(std::move(j)), ++rigs;
    }
  }
  SweepResult r;
  {
    Progress progress(rigs * o.experiments.size());
    o.progress = [&progress](const SweepProgress& p) { progress(p); };
    r = run_sweep(o);
  }

  // the page first (gnuplot may fail), then the files, each written atomically
  std::string html;
  if (!a.report.empty()) html = report::sweep_report_html(r, command_line());
  io::FileBatch batch;  // the table and the page replaced together
  if (!a.out.empty()) io::write_text_file(a.out, r.csv());
  if (!a.report.empty()) io::write_text_file(a.report, html);
  batch.commit();
  if (a.json)
    fmt::print("{}\n", r.to_json().dump(2));
  else if (!out_stdout)
    fmt::print("{}", r.text());
  if (r.failures() > 0) {
    fmt::print(stderr, "hysteron sweep: {} of {} run(s) failed (see the table)\n", r.failures(), r.runs.size());
    return exit_not_converged;  // 2: a run failed (README, Command line; docs/plant.md)
  }
  return exit_ok;
}

}  // namespace

void add_sweep(CLI::App& app, Action& action) {
  auto args = std::make_shared<SweepArgs>();
  auto* cmd = app.add_subcommand("sweep", "Run experiments over plant variants on all cores (docs/plant.md)");
  std::string names;
  for (const auto& n : experiment_names()) { names += (names.empty() ? "" : " | "); names += n; }
  cmd->add_option("experiments", args->experiments, fmt::format("{} | all (one or more)", names))->required();
  cmd->add_option("--vary", args->vary,
                  "PATH=V1,V2,...: one variant per value, everything else nominal (e.g. load.mass=10,20,35, "
                  "muscle.force_620=-15%,+15%; P1/P2=A1/A2,B1/B2 varies two parameters together); repeatable")
      ->allow_extra_args(false);
  cmd->add_option("--grid", args->grid, "JSON file listing explicit variants (docs/plant.md)");
  cmd->add_option("--set", args->set, fmt::format("built-in set of variants: {} (issue 11's list, docs/plant.md)",
                                                  documented_set_name));
  cmd->add_option("--plant", args->plant, "Base rig parameters (JSON; default: the nominal rig)");
  cmd->add_option("--seed", args->seed, "Seed of the rig's noise in every run (default 1)")
      ->check(non_negative_integer());
  cmd->add_option("--learning-periods", args->learning_periods,
                  "Periods of the learning variant in every run (0: no learning runs; default as experiment)")
      ->check(CLI::Range(0, 1000));
  add_control_period_option(cmd, args->control_period);
  {
    std::vector<std::string> choices{std::string(fit_model_name(FitModel::automatic))};
    std::string kinds;
    for (FitModel m : fit_model_kinds) {
      choices.emplace_back(fit_model_name(m));
      kinds += (kinds.empty() ? "" : ", ") + std::string(fit_model_name(m));
    }
    cmd->add_option("--model", args->model,
                    fmt::format("Kind of hysteron's model in every run: auto (default: each run fits every kind and "
                                "chooses on its own rig, about 2.5 s more per run) or one of {} (pinned)",
                                kinds))
        ->check(one_of(choices))
        ->default_val("auto");
  }
  cmd->add_flag("--paper-references", args->paper_references,
                "Every run tracks the papers' references as published, even beyond its rig's reach (then a "
                "target miss); default: mapped into each rig's reach, shown as 'ref xS' (docs/control.md, section 5)");
  cmd->add_option("--reference", args->references,
                  "A reference of your own, tracked in every run instead of the experiments' (repeatable; as "
                  "experiment --reference: sine:..., triangle:..., file:PATH...; docs/control.md, section 8)")
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--identify-on-base", args->identify_on_base,
                "Identify and tune every run on the base rig and track on the variant's: a rig that changed after "
                "its identification (another load, a wider band), the loops not re-tuned (docs/plant.md); default: "
                "each variant identified and tuned on its own rig");
  cmd->add_option("--jobs,-j", args->jobs,
                  "Runs at once, an integer in 1..1024 (default: one per usable CPU: the affinity mask within the "
                  "cgroups' CPU quota)")
      ->check(non_negative_integer(1024, 1));
  cmd->add_option("--out", args->out, "The table (CSV): one row per experiment, variant, reference and kind");
  cmd->add_option("--report", args->report, "HTML page: every error, target misses, RMS against each parameter");
  cmd->add_flag("--json", args->json, "Print one JSON document instead of the text table");
  cmd->callback([args, &action] { action = [args] { return run_sweep_command(*args); }; });
}

}  // namespace hysteron::cli
