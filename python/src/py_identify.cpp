// Bindings of identification: fit, evaluate, simulate_record, metrics, RLS.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "hysteron/io/files.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"
#include "more.hpp"

namespace hysteron::python {

namespace {

// A sample range (begin, end) of ints >= 0 or None; `what` names the argument in errors.
IndexRange range_from(const py::object& r, const char* what) {
  if (r.is_none()) return {};
  const auto t = cast_arg<std::pair<py::object, py::object>>(r, what, "(begin, end): two sample indices or None");
  const auto index = [&](const py::object& v, const char* which, std::size_t none) -> std::size_t {
    if (v.is_none()) return none;
    if (py::isinstance<py::bool_>(v) || !PyIndex_Check(v.ptr()))
      throw_arg_type(v, fmt::format("{}: {}", what, which), "a sample index (an int >= 0) or None");
    const long long i = cast_arg<long long>(v, fmt::format("{}: {}", what, which), "a sample index (an int >= 0)");
    if (i < 0)
      throw py::value_error(fmt::format("{}: {} = {}: a sample index must be >= 0 (None: {})", what, which, i,
                                        none == 0 ? "from the first sample" : "to the end"));
    return static_cast<std::size_t>(i);
  };
  return {index(t.first, "begin", 0), index(t.second, "end", IndexRange::npos)};
}

// fit's units= (None or {"input": str, "output": str}; "" = not given) with the units of
// input_axis / output_axis: one unit per signal, the one given, else the axis's; two that name
// different units are refused, as the CLI refuses a --input-label against the column's unit.
nlohmann::json fit_units(const py::object& units, const std::pair<std::string, std::string>& input_axis,
                         const std::pair<std::string, std::string>& output_axis) {
  const auto trimmed = [](std::string s) {
    const auto b = s.find_first_not_of(" \t\r\n"), e = s.find_last_not_of(" \t\r\n");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  std::string given[2];
  if (!units.is_none()) {
    const auto d = cast_arg<py::dict>(units, "fit: units", "a dict {'input': str, 'output': str} or None");
    check_dict_keys(d, {"input", "output"}, "fit: units");
    const char* names[2] = {"input", "output"};
    for (int i = 0; i < 2; ++i) {
      if (!d.contains(names[i])) continue;
      const py::object v = d[names[i]];
      const std::string what = fmt::format("fit: units['{}']", names[i]);
      if (!py::isinstance<py::str>(v)) throw_arg_type(v, what, "a str naming the unit, such as 'kPa'");
      given[i] = trimmed(v.cast<std::string>());
    }
  }
  const std::string axis[2] = {trimmed(input_axis.second), trimmed(output_axis.second)};
  nlohmann::json out = nlohmann::json::object();
  const char* names[2] = {"input", "output"};
  for (int i = 0; i < 2; ++i) {
    const std::string ca = io::canonical_unit(given[i]), cb = io::canonical_unit(axis[i]);
    if (!given[i].empty() && !axis[i].empty() && given[i] != axis[i] && (ca.empty() || cb.empty() || ca != cb))
      throw Error(fmt::format("fit: units['{0}'] is '{1}' but {0}_axis gives the unit '{2}': give both the same unit "
                              "(or one of them)",
                              names[i], given[i], axis[i]));
    const std::string& u = given[i].empty() ? axis[i] : given[i];
    if (!u.empty()) out[names[i]] = u;
  }
  return out;
}

}  // namespace

void bind_identify(py::module_& m) {
  m.def(
      "fit",
      [](const ArrayArg& x, const ArrayArg& y, const std::string& model, const IntArg& num_operators,
         const IntArg& num_dead_zones, const std::string& initial_state, const py::object& train, double huber_delta,
         const IntArg& num_starts, const IntArg& seed, const IntArg& max_iterations, bool fix_scale, bool free_weights,
         bool compute_covariance, const PathArg& report_arg, std::pair<std::string, std::string> input_axis,
         std::pair<std::string, std::string> output_axis, const IntArg& num_threads, const IntArg& stall_iterations,
         double stall_tolerance, double min_slope, double sample_time, const IntArg& censor_passes, bool mirror,
         const py::object& units_arg) {
        const nlohmann::json units = fit_units(units_arg, input_axis, output_axis);  // before the fit, not after it
        if (input_axis.second.empty() && units.contains("input")) input_axis.second = units["input"].get<std::string>();  // the report's
        if (output_axis.second.empty() && units.contains("output")) output_axis.second = units["output"].get<std::string>();
        const std::string report = path_arg(report_arg, "fit: report");
        io::check_output_file({"fit: report", report});  // before the fit, not after it
        if (!report.empty()) {  // the CLI's --report writes JSON unless the name ends .html / .htm: no HTML in a .json
          if (!io::is_html_path(report))
            throw Error(fmt::format("fit: report: '{}' does not end in .html or .htm: fit(report=) writes the HTML "
                                    "report (the JSON is the dict fit() returns: json.dump it)",
                                    report));
        }
        FitOptions o;
        o.model = fit_model_from_name(model);
        o.num_operators = int_arg(num_operators, "fit: num_operators");
        o.num_dead_zones = int_arg(num_dead_zones, "fit: num_dead_zones");
        o.initial_state = initial_state_from(initial_state);
        o.train = range_from(train, "fit: train");
        o.huber_delta = huber_delta;
        o.num_starts = int_arg(num_starts, "fit: num_starts");
        o.seed = static_cast<unsigned>(uint_arg(seed, "fit: seed", 0, 0xffffffffu));
        o.max_iterations = int_arg(max_iterations, "fit: max_iterations");
        o.gpi_fix_scale = fix_scale;
        o.gpi_free_weights = free_weights;
        o.compute_covariance = compute_covariance;
        o.num_threads = int_arg(num_threads, "fit: num_threads");
        o.stall_iterations = int_arg(stall_iterations, "fit: stall_iterations");
        o.stall_tolerance = stall_tolerance;
        o.min_slope = min_slope;
        o.sample_time = sample_time;
        o.censor_passes = int_arg(censor_passes, "fit: censor_passes");
        o.mpi_asym_mirror = mirror;
        // copies: another thread may change the caller's arrays while the fit runs without the GIL
        std::vector<double> xs = as_vector(x, "fit: x"), ys = as_vector(y, "fit: y");
        // Ctrl-C stops the fit within a fraction of a second (FitOptions::stop_requested)
        std::atomic<bool> stop{false};
        o.stop_requested = [&stop] { return stop.load(); };
        FitReport r = run_interruptible(stop, [&] { return fit(xs, ys, o); });
        if (!report.empty()) {
          report::FitData data;
          data.x = std::move(xs);
          data.y = std::move(ys);
          data.input = {input_axis.first, input_axis.second};
          data.output = {output_axis.first, output_axis.second};
          data.initial_state = o.initial_state;
          data.train = o.train;
          data.source = "numpy arrays (Python)";
          report::write_fit_report(r, data, report, fmt::format("hysteron.fit(x, y, model='{}', num_operators={})",
                                                                model, o.num_operators));
        }
        py::dict d = fit_dict(r);
        if (!units.empty()) {  // in every model dict: Model(d["model"]).save(path) writes them
          const py::object u = from_json(units);
          const auto put = [&](py::handle dict) {
            if (py::isinstance<py::dict>(dict)) dict.cast<py::dict>()["units"] = u.attr("copy")();
          };
          if (d.contains("model")) put(d["model"]);
          if (d.contains("candidates"))
            for (py::handle c : d["candidates"])
              if (py::isinstance<py::dict>(c) && c.cast<py::dict>().contains("model")) put(c.cast<py::dict>()["model"]);
        }
        return d;
      },
      py::arg("x"), py::arg("y"), py::arg("model") = "gpi", py::arg("num_operators") = 10,
      py::arg("num_dead_zones") = 4, py::arg("initial_state") = "virgin", py::arg("train") = py::none(),
      py::arg("huber_delta") = 0.0, py::arg("num_starts") = 2, py::arg("seed") = 0, py::arg("max_iterations") = 200,
      py::arg("fix_scale") = true, py::arg("free_weights") = false, py::arg("compute_covariance") = true, py::arg("report") = "",
      py::arg("input_axis") = std::make_pair(std::string("Input"), std::string()),
      py::arg("output_axis") = std::make_pair(std::string("Output"), std::string()), py::arg("num_threads") = 0,
      py::arg("stall_iterations") = 25, py::arg("stall_tolerance") = 1e-5,
      py::arg("min_slope") = FitOptions{}.min_slope, py::arg("sample_time") = 0.0,
      py::arg("censor_passes") = FitOptions{}.censor_passes, py::arg("mirror") = FitOptions{}.mpi_asym_mirror,
      py::arg("units") = py::none(),
      R"doc(Identify a hysteresis model by Levenberg-Marquardt (Eq. 12 of the GPI paper).

x, y: input and measured output (1-D arrays of equal length).
model: "gpi", "pi", "mpi-deadzone", "mpi-asym", "preisach", "kp", "bouc-wen",
"maxwell-slip", "rate-pi" or "auto" (every kind fitted, the one
chosen by the hold-out score: over the first and the last part of the training range, each predicted by a fit on
the rest, the geometric mean of its RMS over the best kind's; within 2 % of the least score, the kind with the fewest
fitted parameters; the table is in
"candidates"); num_operators: n.
min_slope: minimum slope of the model relative to span(y)/span(x) over the training
range (bounds the inverse's slope).
sample_time: seconds between samples (rate-pi only; 0 = unknown, then rate-pi is refused).
censor_passes: an output that clips (a sensor's limit, detected from the record) is fitted as
censored data over this many refits (0: fitted to the limit as recorded).
mirror: mpi-asym: also fit the input negated (the descending bound taking priority where the
envelopes cross) and keep the orientation with the lower training cost (docs/models.md).
train: (begin, end) sample range entering the cost (None = all; end None = to the end).
num_starts: initial guesses refined by LM, on up to num_threads threads (0: one per
usable CPU (affinity mask, cgroup quota), 1: sequential; the result does not depend on it). max_iterations:
LM iterations per start (as the C++ default, 200). stall_iterations, stall_tolerance:
LM also ends as converged when the cost falls by at most stall_tolerance (relative)
over the last stall_iterations iterations (0 disables it).
report: if given, path of a self-contained HTML report (plots, parameters,
errors), with input_axis/output_axis = (label, unit) for its plots; its name must end in
.html or .htm (hysteron.Error before the fit otherwise: the CLI's --report writes JSON for
other names, and the JSON here is the returned dict).
units: the units of x and y, {"input": "kPa", "output": "N"} (either key may be left out; "" is
none), or None: written as "units" into the returned model dicts (and so by Model(...).save into
the model file, as `hysteron fit` writes a record's units), where the CLI's evaluate, simulate and
invert refuse a record whose columns name other units. A unit given in input_axis / output_axis
counts too (as the CLI's --input-label); units and an axis naming two different units raise
hysteron.Error. A key other than "input" and "output" raises hysteron.Error, a value that is not a
str TypeError, before the fit.

Never raises on bad data: returns a dict (the JSON of `hysteron fit --json`, NaN as
None) with "status" (one of hysteron.fit_statuses: "converged", "no_convergence",
"failed", "poor_fit", "invalid_input"), "ok", "message", "model_kind", "model" (a
model dict usable by hysteron.Model), "parameters" (list of {name, value,
std_error, held, at_bound}), "train" and "reference" metrics (the reference PI on the
training range), "inverse" ({max_slope, max_jump, max_input_step, increasing}),
"warnings" (list of str), "fault_runs" (the runs the sensor-fault warnings name: list of {"rows": [begin, end],
"column": "input" or "output"}, in order; [] where none), "fault_free_train" (where there are fault_runs: [begin,
end], the longest stretch of the training range free of them, to pass as train=; None otherwise), "candidates"
(model="auto": list of {kind, fit_range, status,
message, train, holdout, holdout_score, num_parameters, time_s, chosen, model}: status, message, train,
num_parameters and model are the kind's fold-0 fit on fit_range, [begin, end], the training range without
its last 20 %, not the chosen kind's refit on the whole range), costs, iterations and
"report" (text). Invalid options give the status "invalid_input" with the reason in "message"; arguments of the wrong
type (a complex array, a float count), and a negative integer argument, raise TypeError / ValueError naming it.
x and y are copied first: the fit runs without the GIL, and another thread may change the arrays meanwhile.)doc");

  m.def(
      "reference_pi",
      [](const ArrayArg& x, const ArrayArg& y, const py::object& train, const IntArg& num_operators) {
        PiParams p;
        {
          const auto xs = as_vector(x, "reference_pi: x"), ys = as_vector(y, "reference_pi: y");  // (no GIL below)
          const IndexRange r = range_from(train, "reference_pi: train");
          const int n = int_arg(num_operators, "reference_pi: num_operators");
          py::gil_scoped_release release;
          p = reference_pi(xs, ys, r, n);
        }
        return from_json(io::model_to_json(ModelParams{p}));
      },
      py::arg("x"), py::arg("y"), py::arg("train") = py::none(), py::arg("num_operators") = 10,
      R"doc(The reference every fit is compared with: a classical PI with num_operators plays
on thresholds evenly spaced over half the training input span, started relaxed at
the first sample, a free linear term and an output offset, weights >= 0 by
non-negative least squares over train ((begin, end) or None). Returns a model dict
usable by hysteron.Model (it may not be invertible).)doc");

  {
    py::list statuses, models;
    for (FitStatus st : {FitStatus::not_run, FitStatus::converged, FitStatus::no_convergence, FitStatus::failed,
                         FitStatus::poor_fit, FitStatus::invalid_input})
      statuses.append(std::string(fit_status_name(st)));
    models.append(std::string(fit_model_name(FitModel::automatic)));
    for (FitModel k : fit_model_kinds) models.append(std::string(fit_model_name(k)));
    m.attr("fit_statuses") = py::tuple(statuses);
    m.attr("fit_models") = py::tuple(models);
  }

  m.def(
      "evaluate",
      [](const py::object& model, const ArrayArg& x, const ArrayArg& y, const py::object& range,
         const std::string& initial_state, bool censored) {
        // the model file's "training" (a dict, file or Model carries it): the error evaluate judges against
        const io::ModelDocument doc = model_document(model, "evaluate: model");
        const ModelParams& spec = doc.params;
        const FitMetrics train = io::training_metrics(doc);
        std::size_t count = 0;
        // copied: the work below runs without the GIL, and another thread may change the arrays meanwhile
        const std::vector<double> xs = as_vector(x, "evaluate: x"), ys = as_vector(y, "evaluate: y");
        const IndexRange r = range_from(range, "evaluate: range");
        const InitialState init = initial_state_from(initial_state);
        FitMetrics met;
        InputCoverage coverage;
        OutputMap map;  // y ~ gain * prediction + offset, and the warning where that map explains a poor score
        std::size_t would = 0;  // samples the CLI's default (censored) would not count as errors
        EvaluationVerdict v;
        {
          py::gil_scoped_release release;
          met = evaluate_scored(spec, xs, ys, r, init, censored, &count);
          coverage = input_coverage(spec, xs, r);
          map = output_map(spec, xs, ys, r, init, censored);
          if (!censored) (void)evaluate_scored(spec, xs, ys, r, init, true, &would);
          // The CLI's diagnosis and verdict (judge_evaluation): the output map's warning, or the input map's where
          // the input is in another zero or unit, and useless against the model's training error
          const IndexRange rr = r.resolved(xs.size());
          v = judge_evaluation(spec, xs, ys, r, init, censored, map, met, train, coverage.span_share,
                               "evaluate's record", fmt::format("samples {}..{}", rr.begin, rr.end));
        }
        py::dict d = metrics_dict(met);
        if (censored) d["censored_samples"] = count;  // (as before: the key only when asked)
        d["outside_input_limits"] = coverage.outside;
        py::dict om;
        om["gain"] = map.gain;
        om["offset"] = map.offset;
        om["r2"] = map.r2;
        om["r2_mapped"] = map.r2_mapped;
        om["rms"] = map.rms;
        om["rms_mapped"] = map.rms_mapped;
        om["span"] = map.span;
        d["output_map"] = om;
        // The CLI's evaluate censors by default (--uncensored), this one does not: where the output clips,
        // say how many samples the CLI would not count as errors (a clipped Festo record: RMS 30.8 here, 3.34 there).
        std::string clip_warning;
        if (!censored) {
          if (would > 0)
            clip_warning = fmt::format(
                "evaluate: the output clips: {} samples at its limit where the model predicts beyond it are scored as "
                "errors here (censored=False, the default); hysteron evaluate and fit score them as censored, no "
                "error: pass censored=True to score as they do",
                would);
        }
        d["clipping_warning"] = clip_warning;
        d["input_coverage_warning"] = input_coverage_warning(coverage, "evaluate's record");
        d["output_map_warning"] = v.diagnosis.warning;
        d["stuck_output_warning"] = v.diagnosis.sensor_warning;
        d["stuck_input_warning"] = v.diagnosis.input_sensor_warning;
        d["outlier_warning"] = v.diagnosis.outlier_warning;
        if (v.diagnosis.input_map.found) {
          const InputMap& im = v.diagnosis.input_map;
          py::dict imd;
          imd["scale"] = im.scale;
          imd["shift"] = im.shift;
          imd["rms"] = im.rms;
          imd["r2"] = im.r2;
          imd["rms_as_is"] = im.rms_as_is;
          d["input_map"] = imd;
        } else {
          d["input_map"] = py::none();
        }
        if (const auto t = doc.training()) {  // as the model file records it
          py::dict td;
          td["rms"] = t->rms;
          td["r2"] = t->r2;
          td["samples"] = t->samples;
          d["training"] = td;
        } else {
          d["training"] = py::none();
        }
        d["useless"] = v.useless;
        d["useless_warning"] = v.useless_warning;
        py::list ws;  // the non-empty warnings, in the CLI's order (after this one's clipping_warning)
        for (const std::string& w : {clip_warning, input_coverage_warning(coverage, "evaluate's record"), v.diagnosis.warning,
                                     v.diagnosis.sensor_warning, v.diagnosis.input_sensor_warning,
                                     v.diagnosis.outlier_warning, v.useless_warning})
          if (!w.empty()) ws.append(w);
        d["warnings"] = ws;
        return d;
      },
      py::arg("model"), py::arg("x"), py::arg("y"), py::arg("range") = py::none(),
      py::arg("initial_state") = "virgin", py::arg("censored") = false,
      R"doc(Simulate `model` (dict, file path or Model) over x from its start and return the
error metrics {rms, max, mae, rms_percent_span, r2, n} against y on `range`
((begin, end) or None for all samples). x and y are copied first: the evaluation runs without
the GIL, so other Python threads go on meanwhile.

censored: where y clips (a sensor's limit, detected from the record), a sample at the limit
where the model predicts beyond it is no error, as fit() treats such a record and as
`hysteron fit` / `hysteron evaluate` score it; the dict then also has censored_samples, their
number in the range. Default False: scored as recorded (the CLI's --uncensored), and where y
clips clipping_warning says how many samples the CLI's default would not count as errors
("" otherwise, and always "" with censored=True).

output_map: {gain, offset, r2, r2_mapped, rms, rms_mapped, span}, y ~ gain * prediction +
offset by least squares on the range. output_map_warning, input_map, useless and
useless_warning are the diagnosis and verdict of `hysteron evaluate` (the same C++,
judge_evaluation; "evaluate's record" names the record), judged against the training error that the
model file's "training" records (a dict from fit()'s "model", a file hysteron fit wrote or a
Model made of either carries it; "training" here: {rms, r2, samples}, or None):
output_map_warning: "" where nothing is to be said; else where a sign, unit or zero of the
output explains a poor score (a negative gain is a flipped sign), where the model describes
the record far worse than its training record, where the input spans too little of the model's
input range for R^2 to say much, or, where the INPUT is in another zero or unit (absolute
against gauge pressure, kPa against MPa), the input map's warning; input_map: then {scale,
shift, rms, r2, rms_as_is} (the record's input x -> scale * x + shift brings the RMS error from
rms_as_is to rms), else None. useless: True where the model file records its training error
and the prediction is worse than the record's mean (R^2 <= 0) with more than twice that RMS
error, unless the input spans less than half the model's input range and no sign, unit or zero
explains it (`hysteron evaluate` exits 3 there); useless_warning says so ("" otherwise).
stuck_output_warning: where y's reading sits frozen at one value inside its range while x
moves on (a stuck output sensor, as fit names one on its training record; "" otherwise).
stuck_input_warning: where x's reading sits frozen at one value inside its range while y
moves on, and then jumps to where x went (a stuck input sensor, as fit names one; ""
otherwise).
warnings: the non-empty warnings, clipping_warning, input_coverage_warning,
output_map_warning, stuck_output_warning, stuck_input_warning, useless_warning in that order
(the CLI's, less clipping_warning).

outside_input_limits: the samples of the range whose input lies outside the model's
input_limits (fit() sets them to the training range's input) by more than 2 % of their span:
the model extrapolates there (hysteron.input_coverage in C++); input_coverage_warning: where
they are more than 1 % (as `hysteron evaluate` warns; "" otherwise).)doc");

  m.def(
      "simulate_record",
      [](const py::object& model, const ArrayArg& x, const std::string& initial_state) {
        const ModelParams spec = model_spec(model, "simulate_record: model");
        const std::vector<double> xs = as_vector(x, "simulate_record: x");  // (no GIL below)
        const InitialState init = initial_state_from(initial_state);
        std::vector<double> y;
        {
          py::gil_scoped_release release;
          y = simulate_record(spec, xs, init);
        }
        return to_numpy(y);
      },
      py::arg("model"), py::arg("x"), py::arg("initial_state") = "virgin",
      "Model output over a whole record, starting as fit() does (virgin or relaxed). x is copied first: the\n"
      "simulation runs without the GIL.");

  m.def(
      "compute_metrics",
      [](const ArrayArg& measured, const ArrayArg& predicted) {
        const auto ym = as_finite_span(measured, "compute_metrics: measured");
        const auto yp = as_finite_span(predicted, "compute_metrics: predicted");
        // zeros for no samples would read as a perfect fit (evaluate refuses an empty record too)
        if (ym.empty() && yp.empty())
          throw Error("compute_metrics: measured and predicted are empty: no samples to score");
        return metrics_dict(compute_metrics(ym, yp));
      },
      py::arg("measured"), py::arg("predicted"),
      "Error metrics of predicted against measured (equal lengths, at least one sample; hysteron.Error otherwise).");

  def_copy(py::class_<Rls>(m, "Rls", R"doc(
Recursive least squares with forgetting factor lam for the weights [q, p_1..p_n]
of a model whose output is linear in them (pi, mpi-asym, gpi with free weights).
Rls(model, lam=1.0, p0=1e6): model (dict, file path or Model) fixes thresholds
and envelopes and gives the initial weights.)doc"))
      .def(py::init([](const py::object& model, double lam, double p0) {
             return Rls(model_spec(model, "Rls: model"), lam, p0);
           }),
           py::arg("model"), py::arg("lam") = 1.0, py::arg("p0") = 1e6)
      .def("step", &Rls::step, py::arg("x"), py::arg("y"),
           "One sample: update with input x and measured y; returns the a-priori prediction.")
      .def(
          "reset_state",
          [](Rls& r, const std::string& initial, double x0) {
            r.reset_state(initial_state_from(initial), finite_arg(x0, "Rls.reset_state: x0"));
          },
          py::arg("initial_state") = "virgin", py::arg("x0") = 0.0, "Restart the operator state, keeping the weights.")
      .def_property_readonly(
          "theta", [](const Rls& r) { return to_numpy(std::vector<double>(r.theta().begin(), r.theta().end())); },
          "Current weights [q, p_1..p_n].")
      .def_property_readonly("lam", &Rls::lambda, "Forgetting factor.")
      .def_property_readonly(
          "covariance",
          [](const Rls& r) {
            const Eigen::MatrixXd& P = r.covariance();
            py::array_t<double> out({P.rows(), P.cols()});
            auto v = out.mutable_unchecked<2>();
            for (Eigen::Index i = 0; i < P.rows(); ++i)
              for (Eigen::Index j = 0; j < P.cols(); ++j) v(i, j) = P(i, j);
            return out;
          },
          "Covariance P (a copy), bounded by its prior's trace (n + 1) p0.")
      .def_property_readonly("faults", &Rls::faults,
                             "Samples not learned from: non-finite pairs and covariance resets.")
      .def_property_readonly("resets", &Rls::resets,
                             "Covariance resets to the prior (it was no longer positive definite).")
      .def_property_readonly("bounded", &Rls::bounded,
                             "Updates at the covariance bound (directional forgetting instead of the standard step).")
      .def(
          "params", [](const Rls& r) { return from_json(io::model_to_json(r.params())); },
          "The model with the current weights, as a model dict. RLS does not constrain the weights: "
          "hysteron.Error naming the parameter where they make no valid model of the kind (e.g. gpi q <= 0); "
          "theta still gives them.")
      .def("__repr__", [](const Rls& r) {
        return fmt::format("Rls(model='{}', weights={}, lam={})", model_name(r.model()), r.theta().size(), r.lambda());
      });

  m.def(
      "rls_fit",
      [](const py::object& model, const ArrayArg& x, const ArrayArg& y, double lam, const IntArg& passes,
         const std::string& initial_state) {
        return from_json(io::model_to_json(
            rls_fit(model_spec(model, "rls_fit: model"), as_span(x, "rls_fit: x"), as_span(y, "rls_fit: y"), lam,
                    int_arg(passes, "rls_fit: passes"), initial_state_from(initial_state))));
      },
      py::arg("model"), py::arg("x"), py::arg("y"), py::arg("lam") = 1.0, py::arg("passes") = 1,
      py::arg("initial_state") = "virgin",
      "Run Rls over the record `passes` times; returns the model dict. RLS does not constrain the weights: "
      "hysteron.Error naming the parameter where the estimate makes no valid model of the kind (e.g. gpi q <= 0); "
      "fit_weights gives bounded ones.");

  m.def(
      "fit_weights",
      [](const py::object& model, const ArrayArg& x, const ArrayArg& y, const std::string& initial_state,
         const py::object& train) {
        WeightFitOptions o;
        o.initial_state = initial_state_from(initial_state);
        o.train = range_from(train, "fit_weights: train");
        return from_json(io::model_to_json(fit_weights(model_spec(model, "fit_weights: model"),
                                                       as_span(x, "fit_weights: x"), as_span(y, "fit_weights: y"), o)));
      },
      py::arg("model"), py::arg("x"), py::arg("y"), py::arg("initial_state") = "virgin", py::arg("train") = py::none(),
      "Constrained linear least squares for the weights of a model with fixed thresholds/envelopes, bounded so "
      "that the model stays invertible: every cumulative slope q + p_1 + ... + p_i > 0 (pi, gpi, mpi-deadzone), "
      "q > 0 and every p_i >= 0 (mpi-asym).");
}

}  // namespace hysteron::python
