// ExperimentResult's files (identification and tracking CSVs, model files, result.json,
// report.html) and its text table.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "detail.hpp"
#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"

namespace hysteron {

using namespace experiment;

bool ExperimentResult::is_output_file(const std::string& f) {
  for (const char* name : {"identification.csv", "model_identification.csv", "model.json", "best_model.json",
                           "result.json", "report.html"})
    if (f == name) return true;
  return f.starts_with("tracking_") && f.ends_with(".csv");
}

void ExperimentResult::check_inputs_not_outputs(const std::string& dir,
                                                const std::vector<std::pair<std::string, std::string>>& inputs) {
  namespace fs = std::filesystem;
  if (dir.empty() || inputs.empty()) return;
  std::vector<io::NamedPath> outputs;
  for (const char* f : {"identification.csv", "model_identification.csv", "model.json", "best_model.json", "result.json",
                        "report.html"})
    outputs.push_back({"--out", (fs::path(dir) / f).string()});
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (is_output_file(e.path().filename().string())) outputs.push_back({"--out", e.path().string()});
  for (const auto& [option, path] : inputs)
    for (const auto& o : outputs) io::check_outputs_distinct({o}, {{option, path}});
}

namespace {

// Writes the run's files into `d`; returns their names.
std::vector<std::string> write_files(const ExperimentResult& r, const std::filesystem::path& d) {
  std::vector<std::string> written = {"model.json", "best_model.json", "result.json"};
  // an identification run's columns (read back by report::read_experiment_dir)
  auto write_id_run = [&](const char* name, const IdentificationRun& run) {
    written.push_back(name);
    io::write_columns((d / name).string(), {"t_s", "pressure_command_mpa", "pressure_mpa", "contraction_mm"},
                      {run.t, run.pressure_command_mpa, run.pressure_mpa, run.contraction_mm});
  };
  write_id_run("identification.csv", r.identification);
  if (!r.model_identification.empty()) write_id_run("model_identification.csv", r.model_identification);
  for (const auto& run : r.runs) {
    std::vector<std::string> names = {"t_s",      "reference_mm", "measured_mm", "actual_mm", "pressure_command_mpa",
                                      "pressure_mpa", "pwm_duty"};
    std::vector<std::vector<double>> columns = {run.t, run.reference_mm, run.measured_mm, run.actual_mm,
                                                run.pressure_command_mpa, run.pressure_mpa, run.duty};
    if (!run.pressure_measured_mpa.empty()) {  // the pressure sensor's reading the loop was given
      names.push_back("pressure_measured_mpa");
      columns.push_back(run.pressure_measured_mpa);
    }
    if (!run.correction_mm.empty()) {  // learning runs: the correction added to the reference
      names.push_back("correction_mm");
      columns.push_back(run.correction_mm);
    }
    written.push_back(fmt::format("tracking_{}_{}.csv", run.variant, run.reference));
    io::write_columns((d / written.back()).string(), names, columns);
  }
  // the rig's signals: pressure [MPa] in, contraction [mm] out (`hysteron evaluate` checks a record against them)
  const nlohmann::json units{{"units", {{"input", "MPa"}, {"output", "mm"}}}};
  nlohmann::json fitted = units;  // with the training error (evaluate compares a record's with it)
  if (nlohmann::json t = io::training_json(r.fit.train); !t.is_null()) fitted["training"] = std::move(t);
  io::write_model_file((d / "model.json").string(), r.fit.model, fitted);
  nlohmann::json best = units;
  if (nlohmann::json t = io::training_json(r.best_fit.train); !t.is_null()) best["training"] = std::move(t);
  if (!r.model_reason.empty())
    best["note"] = fmt::format("hysteron experiment {}: the model of the compensated variants; {}", r.name,
                               r.model_reason);
  io::write_model_file((d / "best_model.json").string(), r.best_fit.model, best);
  io::write_text_file((d / "result.json").string(), io::to_json(r).dump(2) + "\n");
  return written;
}

}  // namespace

void ExperimentResult::write(const std::string& dir) const { write_all({this}, {dir}); }

void ExperimentResult::write_all(const std::vector<const ExperimentResult*>& results,
                                 const std::vector<std::string>& dirs,
                                 const std::function<std::vector<std::string>(std::size_t, const std::string&)>& also) {
  namespace fs = std::filesystem;
  if (results.size() != dirs.size()) throw Error("experiment: write_all needs one directory per result");
  for (std::size_t i = 0; i < results.size(); ++i) {
    std::vector<std::pair<std::string, std::string>> inputs;
    for (const std::string& f : results[i]->input_files) inputs.emplace_back("--reference", f);
    check_inputs_not_outputs(dirs[i], inputs);  // nothing written where an input would be replaced or removed
  }
  std::error_code ec;
  std::vector<fs::path> created;  // the directories made here, parents first (removed again on an error)
  std::vector<bool> earlier_run(dirs.size());
  std::vector<std::vector<std::string>> written(dirs.size());
  try {
    for (std::size_t i = 0; i < dirs.size(); ++i) {
      const fs::path d(dirs[i]);
      std::vector<fs::path> missing;
      for (fs::path p = d; !p.empty() && !fs::exists(p, ec); p = p.parent_path()) missing.push_back(p);
      fs::create_directories(d, ec);
      if (ec) throw Error(fmt::format("experiment: cannot create output directory {}: {}", dirs[i], ec.message()));
      created.insert(created.end(), missing.rbegin(), missing.rend());
      earlier_run[i] = fs::exists(d / "result.json", ec);
    }
    io::FileBatch batch;  // every file of every run complete before any is replaced
    for (std::size_t i = 0; i < dirs.size(); ++i) {
      written[i] = write_files(*results[i], fs::path(dirs[i]));
      if (also)
        for (std::string& f : also(i, dirs[i])) written[i].push_back(std::move(f));
    }
    batch.commit();
  } catch (...) {
    for (auto it = created.rbegin(); it != created.rend(); ++it) fs::remove(*it, ec);  // those still empty
    throw;
  }
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    if (!earlier_run[i]) continue;
    const fs::path d(dirs[i]);
    // The earlier run's files this one does not have (a variant it did not run, its report).
    std::vector<fs::path> stale;
    for (const auto& e : fs::directory_iterator(d, ec)) {
      const std::string f = e.path().filename().string();
      if (is_output_file(f) && std::find(written[i].begin(), written[i].end(), f) == written[i].end())
        stale.push_back(e.path());
    }
    // never a file the run read (checked above; kept here too should it have appeared since)
    const auto& inputs = results[i]->input_files;
    std::erase_if(stale, [&](const fs::path& p) {
      return std::any_of(inputs.begin(), inputs.end(), [&](const std::string& in) {
        std::error_code e2;
        return fs::equivalent(p, in, e2);
      });
    });
    for (const fs::path& p : stale) fs::remove(p, ec);
  }
}

std::string ExperimentResult::table() const {
  std::string s = fmt::format("{}: {}\n", name, title);
  s += fmt::format("  control period {:g} ms, rig noise seed {}\n", control_period_s * 1e3, seed);
  s += fmt::format("  identification: {} fitted on the major loop, RMS {:.3f} mm train, {:.3f} mm ({:.2f} % of span) "
                   "on the minor loops; best model {} ({:.3f} mm RMS on a second run)\n",
                   fit_model_name(fit.model_kind), fit.train.rms, validation.rms, validation.rms_percent_span,
                   fit_model_name(best_fit.model_kind), best_validation.rms);
  if (!model_reason.empty()) s += fmt::format("  model of the compensated variants: {}\n", model_reason);
  if (candidates.size() > 1) {
    s += "  candidates (RMS on the second run [mm], fit time [s]):";
    for (const auto& c : candidates)
      s += c.ok ? fmt::format(" {}{} {:.3f} ({:.2f} s);", fit_model_name(c.kind), c.chosen ? "*" : "", c.validation.rms,
                              c.fit_time_s)
                : fmt::format(" {} skipped;", fit_model_name(c.kind));
    s.back() = '\n';
  }
  s += fmt::format("  {:<10} {:<12} {:>9} {:>9} {:>9}\n", "reference", "variant", "max [mm]", "MAE [mm]", "RMS [mm]");
  for (const auto& r : runs)
    s += fmt::format("  {:<10} {:<12} {:>9.3f} {:>9.4f} {:>9.4f}{}\n", r.reference, r.variant, r.errors.max_error_mm,
                     r.errors.mae_mm, r.errors.rms_error_mm,
                     r.periods.empty() ? "" : fmt::format("   (period {})", r.periods.size()));
  if (!published.empty()) {
    auto cell = [](double v, int digits) {
      return std::isfinite(v) ? fmt::format("{:>9.{}f}", v, digits) : fmt::format("{:>9}", "-");
    };
    for (const auto& e : published.errors)
      s += fmt::format("  {:<10} {:<12} {} {} {}\n", e.reference.empty() ? "paper" : e.reference, "published",
                       cell(e.max_error_mm, 3), cell(e.mae_mm, 4), cell(e.rms_error_mm, 4));
  } else {
    s += "  (the paper's text ends before its results: no published figures)\n";
  }
  for (const auto& r : runs) {
    if (r.periods.empty()) continue;
    s += fmt::format("  learning, {}: RMS [mm] of each period:", r.reference);
    for (const auto& e : r.periods) s += fmt::format(" {:.3f}", e.rms_error_mm);
    s += "\n";
  }
  // the relay's amplitude only where it had to be raised (a wide hysteresis band)
  const double h = dynamics.position_relay_amplitude_mpa;
  // ... and its level (and the pressure relay's) only where a capped supply moved it off 0.3 MPa
  auto moved = [&](double level) { return level > 0.0 && std::abs(level - relay_level(pressure_limit_mpa)) > 1e-9; };
  std::string amplitude;
  if (moved(dynamics.position_relay_level_mpa))
    amplitude = fmt::format(" (at {:.3f} +-{:g} MPa)", dynamics.position_relay_level_mpa, h);
  else if (h > kPositionRelayAmplitude * (1.0 + 1e-9))
    amplitude = fmt::format(" (+-{:g} MPa)", h);
  s += fmt::format("  identified: dead time {:.0f} ms, lag {:.0f} ms, slope {:.3f} mm/kPa; position relay{} K_u = {:.3g} "
                   "MPa/m, T_u = {:.0f} ms, mode {:.2f} Hz (damping {:.2f}){}\n",
                   dynamics.dead_time_s * 1e3, dynamics.lag_s * 1e3, dynamics.gain_m_per_mpa, amplitude,
                   dynamics.position_relay_gain, dynamics.position_relay_period_s * 1e3,
                   dynamics.mode_frequency_hz, dynamics.mode_damping,
                   dynamics.relay_gain > 0
                       ? fmt::format(", pressure relay{}{} K_u = {:.3g}/MPa, T_u = {:.1f} ms",
                                     moved(dynamics.relay_level_mpa)
                                         ? fmt::format(" (at {:.3f} MPa)", dynamics.relay_level_mpa)
                                         : std::string(),
                                     dynamics.relay_duty > 0.5 ? fmt::format(" (duty +-{:g}: the valves did not "
                                                                             "open at +-0.5)", dynamics.relay_duty)
                                                               : std::string(),
                                     dynamics.relay_gain, dynamics.relay_period_s * 1e3)
                       : std::string());
  for (const auto& g : gain_trials) {
    s += fmt::format("  gain trial, {}: PID gains x{:.2f}{}; RMS [mm] on the trapezoid per scale:", g.reference, g.scale,
                     g.shaped ? ", shaped feedforward" : "");
    for (std::size_t i = 0; i < g.scales.size(); ++i)
      s += fmt::format(" x{:.2f}{} {:.3f}", g.scales[i], !g.shaped && g.scales[i] == g.scale ? "*" : "", g.rms_mm[i]);
    if (!g.rms_shaped_mm.empty()) {
      s += "; shaped:";
      for (std::size_t i = 0; i < g.scales.size(); ++i)
        s += fmt::format(" x{:.2f}{} {:.3f}", g.scales[i], g.shaped && g.scales[i] == g.scale ? "*" : "",
                         g.rms_shaped_mm[i]);
    }
    if (g.early_stop) s += " (stopped early above the best: those RMS are lower bounds)";
    s += "\n";
  }
  if (const auto useless = not_below_baseline(); !useless.empty())
    s += fmt::format("  NOT BELOW THE BASELINE: {}: on this rig the compensation does no better than a straight line "
                     "for the hysteresis (the notes say why)\n",
                     fmt::join(useless, ", "));
  for (const auto& m : messages) s += fmt::format("  note: {}\n", m);
  return s;
}

bool is_hysterons_loop(std::string_view variant) noexcept {
  return variant == "compensated" || variant == "learning" || variant == "adaptive";
}

bool ExperimentResult::not_below_baseline(const TrackingRun& run) const {
  if (!is_hysterons_loop(run.variant)) return false;
  for (const TrackingRun& base : runs)
    if (base.variant == "baseline" && base.reference == run.reference &&
        !(run.errors.rms_error_mm < base.errors.rms_error_mm))
      return true;
  return false;
}

std::vector<std::string> ExperimentResult::not_below_baseline() const {
  std::vector<std::string> out;
  for (const TrackingRun& run : runs)
    if (not_below_baseline(run)) out.push_back(fmt::format("{} ({})", run.variant, run.reference));
  return out;
}

}  // namespace hysteron
