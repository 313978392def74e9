// Bindings of the papers' experiments, the plots and the HTML reports.
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <future>
#include <optional>
#include <span>
#include <utility>
#include <variant>

#include "hysteron/compensation.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/learning.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/report.hpp"
#include "hysteron/sweep.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/units.hpp"
#include "more.hpp"

namespace hysteron::python {

namespace {

// run_sweep without the GIL while this thread looks for signals (run_interruptible): Ctrl-C
// stops new runs from starting, abandons the runs under way (SweepOptions::stop_requested reaches
// into them) and raises KeyboardInterrupt.
SweepResult run_sweep_interruptible(SweepOptions o) {
  std::atomic<bool> stop{false};
  o.stop_requested = [&stop] { return stop.load(); };
  return run_interruptible(stop, [&o] { return run_sweep(o); });
}


report::Labels labels(const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
                      const std::string& yu) {
  return {title, {xl, xu}, {yl, yu}};
}

// An identification run as the dict of run_experiment()'s "identification" and
// "model_identification" (the CSV's columns; t in seconds).
py::dict id_run_dict(const IdentificationRun& run) {
  py::dict d;
  d["t"] = to_numpy(run.t);
  d["pressure_command_mpa"] = to_numpy(run.pressure_command_mpa);
  d["pressure_mpa"] = to_numpy(run.pressure_mpa);
  d["contraction_mm"] = to_numpy(run.contraction_mm);
  return d;
}

// A rig from a JSON file's path or a parameter dict (`where` names the argument in errors).
PamRigParams rig_from(const py::object& plant, const char* where) {
  return is_path(plant) ? load_rig_params(path_arg(plant, where))
                                        : rig_params_from_json(to_json(plant, where), where);
}

// Keyword arguments shared by the plot functions.
#define HYSTERON_PLOT_ARGS(title, xl, xu, yl, yu)                                                            \
  py::arg("path"), py::arg("title") = title, py::arg("x_label") = xl, py::arg("x_unit") = xu,                \
      py::arg("y_label") = yl, py::arg("y_unit") = yu

}  // namespace

void bind_experiment(py::module_& m) {
  m.def("experiment_names", &experiment_names, "Names of the registered experiments (the papers').");
  m.def(
      "controller_from",
      [](const py::object& controller, const py::object& model) {
        const LoopDesign d = io::from_json<LoopDesign>(to_json(controller), "controller");
        const io::ModelDocument doc = model_document(model, "controller_from: model");
        if (const std::string why = input_unit_refusal(model, doc); !why.empty())
          throw Error(fmt::format("controller_from: {}", why));
        if (const std::string why = io::model_scale_mismatch(d.feedforward.model_scale, doc.unit("output"));
            !why.empty())
          throw Error(fmt::format("controller_from: {}: the controller was designed for a model in another length "
                                  "unit",
                                  why));
        Controller c = make_controller(d, doc.params);
        return std::visit([](auto& loop) { return py::cast(std::move(loop)); }, c);
      },
      py::arg("controller"), py::arg("model"),
      R"doc(The loop a tracking run's "controller" (a run's runs[i]["controller"], or result.json's)
describes, on `model` (best_model.json for the compensated and learning loops, model.json for the
faithful one): a FeedforwardPidController, OpenLoopController or CascadePwmController by its
"loop". The learning is not part of it (IterativeLearning from controller["learning"]). An
adaptive run's controller ("adaptation": its inverse adapted online) is refused: the loop's
inverse is fixed. hysteron.Error names a missing or invalid key. docs/deploy.md.)doc");
  m.def(
      "export_c",
      [](const py::object& model, const std::string& prefix, const std::string& header_name,
         const std::optional<std::pair<double, double>>& limits, const py::object& controller,
         const std::string& source_name) {
        io::ExportOptions o;
        o.prefix = prefix;
        o.header_name = header_name;
        o.source_name = source_name;
        if (limits) o.inverse_limits = Limits{limits->first, limits->second};
        if (!controller.is_none()) o.loop = io::from_json<LoopDesign>(to_json(controller), "controller");
        const io::ModelDocument doc = model_document(model, "export_c: model");
        o.input_unit = doc.unit("input");  // the model's units, stated in the comments as hysteron export does
        o.output_unit = doc.unit("output");
        const io::GeneratedC g = io::generate_c(doc.params, o);
        py::dict out;
        out["source"] = g.source;
        out["header"] = g.header;
        return out;
      },
      py::arg("model"), py::kw_only(), py::arg("prefix") = "compensator", py::arg("header_name") = "",
      py::arg("limits") = py::none(), py::arg("controller") = py::none(), py::arg("source_name") = "",
      R"doc(hysteron export as a function (docs/export.md): the model and its exact inverse as one
self-contained C99 file, {"source": the .c text, "header": the .h text or "" without header_name}.
prefix names every C symbol; header_name (e.g. "compensator.h") moves the declarations to a
header the source #includes; limits=(lo, hi) the inverse's input limits. The model's "units"
(a model file's, a dict's or a Model's) are stated in the comments. controller (a run's
"controller" dict, e.g. loop_of_run(result, "compensated.sine")) adds the run's loop around the
inverse: PREFIX_loop_reset / _loop_step / _loop_preview, which step exactly as controller_from(
controller, model); a learning run's controller also adds its iterative learning,
PREFIX_learning_reset / _learning_warm_start / _learning_step and PREFIX_loop_learning_step, which
step exactly as learning_from(controller) around the loop. model must be the one the run
inverts. hysteron.Error on a model without inverse, a bad prefix, an adaptive run's loop (its
inverse adapted online) or a loop generated C cannot hold.)doc");
  m.def(
      "loop_of_run",
      [](const py::object& result, const std::string& run) {
        const LoopDesign d = py::isinstance<py::dict>(result)
                                 ? io::loop_design_of_run(to_json(result), run, "result")
                                 : io::read_loop_design(path_arg(result, "loop_of_run: result"), run);
        return from_json(io::to_json(d));
      },
      py::arg("result"), py::arg("run"),
      R"doc(One run's "controller" out of a result.json (a file name, or the parsed document as a
dict): run is "VARIANT" for an experiment with one reference ("compensated") or
"VARIANT.REFERENCE" ("learning.triangle"); "" takes result as a controller itself. The reader
behind the C ABI's hysteron_loop_params_from_file; hysteron.Error names the runs there are when
run is not one of them. Pass the dict it returns to controller_from, learning_from or
feedforward_preview.)doc");
  m.def(
      "learning_from",
      [](const py::object& controller) {
        const LoopDesign d = io::from_json<LoopDesign>(to_json(controller), "controller");
        if (!d.learning) throw Error("controller: no \"learning\" (not a learning run's controller)");
        return IterativeLearning(d.learning->params);
      },
      py::arg("controller"),
      R"doc(The learning update a learning run's "controller" describes (its "learning" parameters,
supervision included), from period 0 with zero corrections: ilc.reset(correction) warm-starts it
from a run's last correction_mm period (in m). hysteron.Error if the run has no learning.)doc");
  m.def(
      "feedforward_preview",
      [](const py::object& controller, const ArrayArg& reference) {
        const LoopDesign d = io::from_json<LoopDesign>(to_json(controller), "controller");
        return to_numpy(feedforward_preview(d, as_finite_span(reference, "feedforward_preview: reference")));
      },
      py::arg("controller"), py::arg("reference"),
      R"doc(The reference the loop's feedforward is fed (step()'s preview_m), for a recorded reference
(any units): through controller["shaper"] if there is one, then feedforward_lead_samples ahead,
indices clamped to the record, as hysteron experiment's tracking runs do.)doc");
  m.def(
      "experiments",
      [] {
        py::list l;
        for (const auto& e : experiments()) {
          py::dict d;
          d["name"] = e.name;
          d["title"] = e.title;
          d["summary"] = e.summary;
          d["variants"] = e.variants;
          d["published_source"] = e.published_source;
          l.append(d);
        }
        return l;
      },
      "The registered experiments: a list of dicts with name, title, summary, variants (e.g. faithful, "
      "compensated, learning, adaptive, baseline) and published_source (\"\" where the paper gives no figures).");
  m.def(
      "run_experiment",
      [](const std::string& name, const IntArg& seed_arg, const py::object& plant, const PathArg& out_arg,
         const PathArg& report_arg, const IntArg& learning_periods, bool adaptive, const py::object& tracking_plant,
         const std::string& model, bool paper_references, double control_period, const py::object& references) {
        // the user's references first: a bad spec is an error before anything is checked, read or run
        std::vector<std::string> specs;
        if (py::isinstance<py::str>(references)) {
          specs.push_back(references.cast<std::string>());
        } else if (!references.is_none()) {
          if (!py::isinstance<py::sequence>(references))
            throw Error(fmt::format("run_experiment: references must be a list of SPEC strings or None, not {}",
                                    py::str(py::type::of(references).attr("__name__")).cast<std::string>()));
          std::size_t i = 0;
          for (const py::handle h : references) {
            if (!py::isinstance<py::str>(h))
              throw Error(fmt::format("run_experiment: references[{}] must be a SPEC string, not {}", i,
                                      py::str(py::type::of(h).attr("__name__")).cast<std::string>()));
            specs.push_back(h.cast<std::string>());
            ++i;
          }
        }
        std::vector<UserReference> user = parse_references(specs, "references");
        // where the outputs go, before the run (minutes): a report whose directory is `out` is
        // written after `out` was created
        const std::string out = path_arg(out_arg, "run_experiment: out");
        const std::string report_path = path_arg(report_arg, "run_experiment: report");
        const std::uint64_t seed = uint_arg(seed_arg, "run_experiment: seed");
        io::check_output_directory({"run_experiment: out", out});
        const auto dir = [](const std::string& p) { return std::filesystem::path(p).lexically_normal(); };
        if (!out.empty() && !report_path.empty() &&
            dir(report_path).parent_path() == dir(out + "/").parent_path())
          io::check_output_directory({"run_experiment: report", out});
        else
          io::check_output_file({"run_experiment: report", report_path});
        ExperimentOptions o;
        o.model = fit_model_from_name(model);
        o.fit_references = !paper_references;
        o.name = name;
        o.seed = seed;
        o.learning_periods = int_arg(learning_periods, "run_experiment: learning_periods");
        o.adaptive = adaptive;
        o.control_period = control_period;  // checked by run_experiment before anything is run or written
        o.references = std::move(user);
        if (!plant.is_none()) o.rig = rig_from(plant, "plant");
        if (!tracking_plant.is_none()) o.tracking_rig = rig_from(tracking_plant, "tracking_plant");
        // Ctrl-C stops the run within a fraction of a second (ExperimentOptions::stop_requested)
        std::atomic<bool> stop{false};
        o.stop_requested = [&stop] { return stop.load(); };
        ExperimentResult r = run_interruptible(stop, [&o] { return run_experiment(o); });
        const std::string command = fmt::format("hysteron.run_experiment('{}', seed={})", name, seed);
        if (!out.empty()) {  // the files and the report replaced together (as the CLI's --out)
          ExperimentResult::write_all({&r}, {out}, [&](std::size_t, const std::string& out_dir) {
            std::vector<std::string> in_dir;
            if (report_path.empty()) return in_dir;
            report::write_experiment_report(r, report_path, command);
            // a report in the directory is one of this run's files, not an earlier run's to remove:
            // the directories compared (through links), the report's own name kept (a link named
            // report.html in out stays, as the CLI keeps it)
            std::error_code ec;
            const std::filesystem::path rp(report_path);
            if (std::filesystem::equivalent(std::filesystem::absolute(rp, ec).parent_path(), out_dir, ec) && !ec)
              in_dir.push_back(rp.filename().string());
            return in_dir;
          });
        } else if (!report_path.empty()) {
          report::write_experiment_report(r, report_path, command);
        }
        py::dict d;
        d["summary"] = from_json(io::to_json(r));
        // the straight line the baseline loop inverts (result.json's "baseline_model"; None where none)
        d["baseline_model"] = d["summary"]["baseline_model"];
        d["table"] = r.table();
        py::dict id = id_run_dict(r.identification);
        id["train_end"] = r.id_train_end;
        d["identification"] = id;
        // the run hysteron's model was fitted on, where not the paper's
        d["model_identification"] = r.model_identification.empty() ? py::object(py::none())
                                                                   : py::object(id_run_dict(r.model_identification));
        d["fit"] = fit_dict(r.fit);
        d["validation"] = metrics_dict(r.validation);
        d["best_fit"] = fit_dict(r.best_fit);
        d["best_validation"] = metrics_dict(r.best_validation);
        {
          py::dict md;  // which kind the compensated variants invert, and why
          md["choice"] = std::string(fit_model_name(r.model_choice));
          md["kind"] = std::string(fit_model_name(r.best_fit.model_kind));
          md["reason"] = r.model_reason;
          py::list cands;
          for (const auto& c : r.candidates) {
            py::dict x;
            x["kind"] = std::string(fit_model_name(c.kind));
            x["ok"] = c.ok;
            x["status"] = std::string(fit_status_name(c.status));
            x["message"] = c.message;
            x["validation"] = metrics_dict(c.validation);
            x["fit_time_s"] = c.fit_time_s;
            x["chosen"] = c.chosen;
            cands.append(x);
          }
          md["candidates"] = cands;
          d["model"] = md;
        }
        d["messages"] = r.messages;
        py::list runs;
        for (const auto& run : r.runs) {
          py::dict x;
          x["variant"] = run.variant;
          x["reference"] = run.reference;
          x["description"] = run.description;
          x.attr("update")(from_json(io::to_json(run.errors)));  // max_error_mm, mae_mm, rms_error_mm
          x["saturated"] = run.saturated;
          x["scored_from_s"] = run.scored_from_s;
          x["controller"] = from_json(io::to_json(run.controller));  // the loop's numbers (docs/deploy.md)
          py::list per;
          for (const auto& e : run.periods) per.append(from_json(io::to_json(e)));
          x["periods"] = per;
          x["t"] = to_numpy(run.t);
          x["reference_mm"] = to_numpy(run.reference_mm);
          x["measured_mm"] = to_numpy(run.measured_mm);
          x["actual_mm"] = to_numpy(run.actual_mm);
          x["pressure_command_mpa"] = to_numpy(run.pressure_command_mpa);
          x["pressure_mpa"] = to_numpy(run.pressure_mpa);
          x["pressure_measured_mpa"] = to_numpy(run.pressure_measured_mpa);  // what the loop was given
          x["duty"] = to_numpy(run.duty);
          x["correction_mm"] = to_numpy(run.correction_mm);  // learning runs; empty otherwise
          runs.append(x);
        }
        d["runs"] = runs;
        d["published"] = from_json(io::to_json(r.published));
        return d;
      },
      py::arg("name"), py::arg("seed") = 1, py::arg("plant") = py::none(), py::arg("out") = "",
      py::arg("report") = "", py::arg("learning_periods") = 10, py::arg("adaptive") = true,
      py::arg("tracking_plant") = py::none(), py::arg("model") = "auto", py::arg("paper_references") = false,
      py::arg("control_period") = ExperimentOptions{}.control_period, py::arg("references") = py::none(),
      R"doc(Run one of the registered experiments (experiment_names(): "gpi-pid", "mpi-openloop",
"mpi-pwm") on the simulated rig. plant: rig parameter dict or JSON path (None: defaults).
model: kind of hysteron's model, the one the compensated, learning and adaptive variants
invert: "auto" (every kind fitted, the least RMS on a second identification run chosen) or
one kind of fit_models() (hysteron.Error if unknown or if it cannot be fitted or inverted);
the adaptive variant needs the PI family and is skipped (a note in "messages") otherwise.
learning_periods: periods of the learning variant (0: none; 0..1000).
adaptive: run the adaptive variant (online RLS of the inverse's weights).
control_period: the controller's sample time [s] (default 0.001): within [rig dt, 0.01] and a
whole number of the rig's time steps, else hysteron.Error before anything runs or is written.
tracking_plant: rig parameters of the tracking runs if the rig changed after its
identification (None: the identified rig).
paper_references: track the papers' references as published even above the contraction the
rig reached in its identification run (default False: such a reference is scaled into the
reach, said in "messages"; the ranges are in summary["references"] and summary["reach"]).
references: None (the paper's references) or a list of SPEC strings tracked instead, as the
CLI's --reference: "sine:amplitude=MM,offset=MM,frequency=HZ,periods=N",
"triangle:amplitude=MM,offset=MM,frequency=HZ,periods=N" or
"file:PATH[,time=COL][,contraction=COL][,periodic][,periods=N]", each with an optional
name=NAME (docs/control.md, section 8); a bad spec is hysteron.Error naming
references, the spec and the key, before anything runs.
out: directory for the CSV/JSON outputs (as `hysteron experiment --out`);
report: path of an HTML report. Returns a dict: "summary" (the CLI's --json
object), "table" (text), "identification" (numpy series + train_end), "fit",
"validation", "best_fit", "best_validation", "model" (choice, kind, reason, candidates: kind,
ok, status, message, validation, fit_time_s, chosen), "messages", "runs" (list of dicts with the
errors, the per-period errors of a learning run and numpy time series) and "published".)doc");

  m.def(
      "run_sweep",
      [](const py::object& experiments, const std::vector<std::string>& vary, const py::object& grid,
         const std::string& set, const py::object& plant, const IntArg& seed, const IntArg& learning_periods,
         const std::string& model, bool paper_references, bool identify_on_base, const IntArg& jobs,
         const PathArg& out_arg, const PathArg& report_arg, double control_period) {
        const std::string out = path_arg(out_arg, "run_sweep: out");
        const std::string report_path = path_arg(report_arg, "run_sweep: report");
        io::check_output_file({"run_sweep: out", out});
        io::check_output_file({"run_sweep: report", report_path});
        SweepOptions o;
        o.experiments = sweep_experiments(
            py::isinstance<py::str>(experiments)
                ? std::vector<std::string>{experiments.cast<std::string>()}
                : cast_arg<std::vector<std::string>>(experiments, "run_sweep: experiments",
                                                     "a name of experiment_names(), \"all\", or a list of names"));
        o.seed = uint_arg(seed, "run_sweep: seed");
        o.learning_periods = int_arg(learning_periods, "run_sweep: learning_periods");
        o.control_period = control_period;
        o.model = fit_model_from_name(model);
        o.fit_references = !paper_references;
        o.identify_on_base = identify_on_base;
        o.jobs = static_cast<unsigned>(uint_arg(jobs, "run_sweep: jobs", 0, 0xffffffffu));
        if (!plant.is_none()) o.base = rig_from(plant, "plant");
        if (!set.empty())
          for (auto& v : variant_set(set, "run_sweep: set")) o.variants.push_back(std::move(v));
        for (const auto& spec : vary)
          for (auto& v : parse_vary(spec)) o.variants.push_back(std::move(v));
        if (!grid.is_none())
          for (auto& v : is_path(grid) ? read_variant_grid(path_arg(grid, "run_sweep: grid"))
                                       : variant_grid_from_json(to_json(grid, "run_sweep: grid"), "grid"))
            o.variants.push_back(std::move(v));
        if (o.variants.empty())
          throw Error(fmt::format("run_sweep: no variants: give vary=['PATH=V1,V2,...'], grid= or set='{}'",
                                  documented_set_name));
        const SweepResult r = run_sweep_interruptible(std::move(o));
        // the page first (gnuplot may fail), then the table and the page replaced together (as the CLI)
        std::string html;
        if (!report_path.empty()) html = report::sweep_report_html(r, "hysteron.run_sweep(...)");
        io::FileBatch batch;
        if (!out.empty()) io::write_text_file(out, r.csv());
        if (!report_path.empty()) io::write_text_file(report_path, html);
        batch.commit();
        py::dict d = from_json(r.to_json());
        d["text"] = r.text();
        return d;
      },
      py::arg("experiments"), py::kw_only(), py::arg("vary") = std::vector<std::string>{}, py::arg("grid") = py::none(),
      py::arg("set") = "", py::arg("plant") = py::none(), py::arg("seed") = 1, py::arg("learning_periods") = 10,
      py::arg("model") = "auto", py::arg("paper_references") = false, py::arg("identify_on_base") = false,
      py::arg("jobs") = 0, py::arg("out") = "", py::arg("report") = "",
      py::arg("control_period") = ExperimentOptions{}.control_period,
      R"doc(Run experiments over plant variants on all cores, as `hysteron sweep` (docs/plant.md).
experiments: a name of experiment_names(), "all", or a list of them. Variants (at least one
source): vary, a list of "PATH=V1,V2,..." (e.g. "load.mass=10,35", "muscle.force_620=-15%");
grid, a grid file's path or its dict ({"variants": [{"name": ..., "set": {PATH: value}}]});
set="documented", issue 11's documented set. plant: the base rig (dict or JSON path; None:
nominal), always run first as "nominal". identify_on_base: identify and tune every run on the
base rig and track on the variant's (a rig that changed after its identification; default:
each variant identified on its own rig). seed, learning_periods, model, paper_references,
control_period: as run_experiment, for every run. jobs: runs at once (0: one per usable CPU); Ctrl-C starts no further run, abandons the
runs under way within a fraction of a second and raises KeyboardInterrupt (nothing written). out: the CSV table,
report: the HTML page (written after every run finished, the two replaced together). Returns the JSON document of
`hysteron sweep --json` as a dict (variants, runs with their tracking errors, target_misses,
learning_not_below_compensated, notes, failures, ...) and "text", the text table. A failed run
is recorded in the result (failures > 0), not raised; bad input raises hysteron.Error.)doc");

  m.def(
      "write_report",
      [](const PathArg& input_arg, const PathArg& out_arg) {
        const std::string input = path_arg(input_arg, "write_report: input");
        const std::string out = path_arg(out_arg, "write_report: out");
        report::write_report_from(input, out, fmt::format("hysteron.write_report('{}', '{}')", input, out));
      },
      py::arg("input"), py::arg("out"),
      "HTML report from an experiment output directory or a fit report JSON file (as `hysteron report`).");

  m.def(
      "plot",
      [](const py::list& series, const PathArg& path, const std::string& title, const std::string& xl,
         const std::string& xu, const std::string& yl, const std::string& yu) {
        report::PlotSpec spec{labels(title, xl, xu, yl, yu), {}};
        for (std::size_t i = 0; i < series.size(); ++i) {
          const std::string where = fmt::format("plot: series[{}]", i);
          const auto d = cast_arg<py::dict>(series[i], where, "a dict {label, x, y, style, color, dashed}");
          check_dict_keys(d, {"label", "x", "y", "style", "color", "dashed"}, where);
          const auto get = [&]<class T>(const char* key, const char* expected) {
            if (!d.contains(key)) throw py::value_error(fmt::format("{}: no \"{}\" ({})", where, key, expected));
            return cast_arg<T>(d[key], fmt::format("{}[\"{}\"]", where, key), expected);
          };
          report::Series r;
          r.label = get.operator()<std::string>("label", "a str");
          r.x = as_vector(get.operator()<ArrayArg>("x", "an array of numbers"), where + "[\"x\"]");
          r.y = as_vector(get.operator()<ArrayArg>("y", "an array of numbers"), where + "[\"y\"]");
          if (d.contains("style")) r.style = get.operator()<std::string>("style", "a str");
          if (d.contains("color")) r.color = get.operator()<std::string>("color", "a str");
          if (d.contains("dashed")) r.dashed = get.operator()<bool>("dashed", "a bool");
          spec.series.push_back(std::move(r));
        }
        report::plot(spec, path_arg(path, "plot: path"));
      },
      py::arg("series"), HYSTERON_PLOT_ARGS("hysteron plot", "x", "", "y", ""),
      "Generic plot (gnuplot) to .svg or .png; series: dicts {label, x, y, style, color, dashed}.");
  m.def(
      "plot_hysteresis_loops",
      [](const ArrayArg& x, const ArrayArg& y, const ArrayArg& model, const PathArg& path,
         const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
         const std::string& yu, const IntArg& major_end) {
        report::plot_hysteresis_loops(as_span(x, "plot_hysteresis_loops: input"),
                                      as_span(y, "plot_hysteresis_loops: measured"),
                                      as_span(model, "plot_hysteresis_loops: model"), labels(title, xl, xu, yl, yu),
                                      path_arg(path, "plot_hysteresis_loops: path"),
                                      uint_arg(major_end, "plot_hysteresis_loops: major_end"));
      },
      py::arg("input"), py::arg("measured"), py::arg("model"),
      HYSTERON_PLOT_ARGS("Hysteresis loops", "Pressure", "MPa", "Contraction", "mm"), py::arg("major_end") = 0,
      "Measured (and model, if non-empty) output against input; [0, major_end) drawn as the major loop.");
  m.def(
      "plot_identification_input",
      [](const ArrayArg& t, const ArrayArg& cmd, const ArrayArg& meas, const PathArg& path,
         const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
         const std::string& yu) {
        report::plot_identification_input(as_span(t, "plot_identification_input: t"),
                                          as_span(cmd, "plot_identification_input: command"),
                                          as_span(meas, "plot_identification_input: measured"),
                                          labels(title, xl, xu, yl, yu),
                                          path_arg(path, "plot_identification_input: path"));
      },
      py::arg("t"), py::arg("command"), py::arg("measured"),
      HYSTERON_PLOT_ARGS("Identification input", "Time", "s", "Pressure", "MPa"),
      "Identification input against time (Fig. 4).");
  m.def(
      "plot_tracking",
      [](const ArrayArg& t, const ArrayArg& d, const ArrayArg& a, const PathArg& path,
         const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
         const std::string& yu) {
        report::plot_tracking(as_span(t, "plot_tracking: t"), as_span(d, "plot_tracking: desired"),
                              as_span(a, "plot_tracking: actual"), labels(title, xl, xu, yl, yu),
                              path_arg(path, "plot_tracking: path"));
      },
      py::arg("t"), py::arg("desired"), py::arg("actual"),
      HYSTERON_PLOT_ARGS("Trajectory tracking", "Time", "s", "Contraction", "mm"),
      "Desired and actual output against time (Fig. 11).");
  m.def(
      "plot_tracking_error",
      [](const ArrayArg& t, const ArrayArg& d, const ArrayArg& a, const PathArg& path,
         const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
         const std::string& yu) {
        report::plot_tracking_error(as_span(t, "plot_tracking_error: t"), as_span(d, "plot_tracking_error: desired"),
                                    as_span(a, "plot_tracking_error: actual"), labels(title, xl, xu, yl, yu),
                                    path_arg(path, "plot_tracking_error: path"));
      },
      py::arg("t"), py::arg("desired"), py::arg("actual"),
      HYSTERON_PLOT_ARGS("Tracking error", "Time", "s", "Error", "mm"), "Tracking error against time (Fig. 12).");
  m.def(
      "plot_desired_vs_actual",
      [](const ArrayArg& d, const ArrayArg& a, const PathArg& path, const std::string& title,
         const std::string& xl, const std::string& xu, const std::string& yl, const std::string& yu) {
        report::plot_desired_vs_actual(as_span(d, "plot_desired_vs_actual: desired"),
                                       as_span(a, "plot_desired_vs_actual: actual"), labels(title, xl, xu, yl, yu),
                                       path_arg(path, "plot_desired_vs_actual: path"));
      },
      py::arg("desired"), py::arg("actual"),
      HYSTERON_PLOT_ARGS("Desired vs actual", "Desired contraction", "mm", "Actual contraction", "mm"),
      "Actual against desired output with the line y = x (Fig. 13).");
  m.def(
      "plot_fit_residuals",
      [](const ArrayArg& x, const ArrayArg& y, const ArrayArg& model, const PathArg& path,
         const std::string& title, const std::string& xl, const std::string& xu, const std::string& yl,
         const std::string& yu) {
        report::plot_fit_residuals(as_span(x, "plot_fit_residuals: x"), as_span(y, "plot_fit_residuals: measured"),
                                   as_span(model, "plot_fit_residuals: model"), labels(title, xl, xu, yl, yu),
                                   path_arg(path, "plot_fit_residuals: path"));
      },
      py::arg("x"), py::arg("measured"), py::arg("model"),
      HYSTERON_PLOT_ARGS("Fit residuals", "Sample", "", "Residual", "mm"),
      "Residuals (measured - model) against x (time or sample index; empty: index).");
}

}  // namespace hysteron::python
