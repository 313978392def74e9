// hysteron evaluate: a saved model against (new) measured data, so a model fitted last
// week can be checked on today's record.
//
//   hysteron evaluate --model m.json|- --data D.csv --input COL --output COL
//                     [--range A:B | --train A:B] [--time-column T [--time-unit s|ms|us]]
//                     [--sample-time S] [--relaxed]
//                     [--report r.html|r.json] [--json] [--uncensored] [--input-label "Pressure [kPa]"]
//                     [--output-label "..."]
//
// The model is simulated over the whole record from its start (virgin, or --relaxed at
// the first sample) and scored on the range (default: the whole record). A record whose
// output clips (a sensor's limit, detect_clipping) is scored as censored, as `fit` scores its
// validation: a sample at the limit where the model predicts beyond it is no error
// (--uncensored: as recorded); the text and the document say how many. Text summary on
// stdout, or one JSON document with --json; the report is HTML (metrics, loops,
// residuals) if its name ends in .html/.htm, else the JSON document (`hysteron report` turns it
// into the same page).
// Exit codes: 0 evaluated; 1 error (bad input or usage, unreadable files); 3 a useless evaluation:
// where the model file records its training error ("training", as hysteron fit writes it), a record
// the model predicts worse than its mean (R^2 <= 0) with more than kValidationRmsFactor times that
// error (validation_useless, as fit --validate-data exits 3); never a record whose input spans less
// than kNarrowInputShare of the model's input range (its R^2 says little) that no sign, unit or zero
// explains (output_map_names, input_map).
#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/report.hpp"

namespace hysteron::cli {

namespace {

struct EvaluateOptions {
  std::string model, range, report;
  DataSelection sel;
  double sample_time = 0.0;  // s; 0: the time column's mean step, or unknown
  bool json = false, relaxed = false, uncensored = false;
};

int run_evaluate(const EvaluateOptions& c) {
  // a --report naming stdout (-, /dev/stdout, the file stdout is redirected to) is handled as - is
  const bool report_stdout = names_stdout(c.report);
  if (c.json && report_stdout)
    throw Error(fmt::format("--report {} and --json both write to standard output: choose one", c.report));
  io::check_output_files({{"--report", c.report}}, {{"--model", c.model}, {"--data", c.sel.file}});
  const io::ModelDocument model_doc = io::read_model_document(c.model);
  const ModelParams& model = model_doc.params;
  const ModelUnits units = model_units(model_doc);
  const DataSelection& sel = c.sel;
  const DataColumns rec = read_data_columns(c.sel.file, sel);
  check_units_agree(units, fmt::format("the model {}", c.model == "-" ? "<stdin>" : c.model), rec, sel, c.sel.file);
  if (rec.t && c.range.find('s') != std::string::npos)
    (void)require_increasing_time(*rec.t, c.sel.file, sel.time_column, "a range in seconds", true);
  const IndexRange range = c.range.empty() ? IndexRange{0, rec.x.size()}
                                           : parse_range(c.range, "--range", rec.t ? &*rec.t : nullptr, rec.x.size());
  const InitialState initial = c.relaxed ? InitialState::relaxed : InitialState::virgin;
  if (range.end - range.begin < 2)
    throw Error(fmt::format("{}: {} sample(s) in the evaluated range [{}, {}): too few to score (need at least 2)",
                            c.sel.file, range.end - range.begin, range.begin, range.end));
  std::vector<std::string> warnings;
  // rate-pi's rates are per second through its dt: a record sampled otherwise is run at the wrong rates
  check_sample_time_agrees(c.sample_time, rec.t ? &*rec.t : nullptr, c.sel.file, sel.time_column);
  warnings = rate_time_warnings(model, rec.t ? &*rec.t : nullptr, c.sample_time, c.sel.file, sel.time_column);
  const InputCoverage coverage = input_coverage(model, rec.x, range);
  if (std::string w = input_coverage_warning(coverage, c.sel.file); !w.empty()) warnings.push_back(std::move(w));

  io::EvaluationDocument doc;
  doc.model_file = c.model == "-" ? std::string("<stdin>") : c.model;
  doc.model = model;
  doc.data = describe_data(sel, rec, initial, range);
  doc.data.censored = !c.uncensored;  // the document, the text and the HTML report score alike
  doc.result.file = c.sel.file;
  doc.result.range = range;
  doc.result.metrics = evaluate_scored(model, rec.x, rec.y, range, initial, doc.data.censored, &doc.result.censored);
  doc.result.outside_input_limits = coverage.outside;
  const FitMetrics& m = doc.result.metrics;
  // The training error the model file records ("training": hysteron fit writes it): judged as fit judges
  // a --validate-data file; without it (older or hand-made files) there is nothing to compare with.
  const FitMetrics train = io::training_metrics(model_doc);
  // a record whose output differs from the training record's by a sign, a unit or a zero scores poorly
  // for that, not for the model's hysteresis: say so where the affine map explains it
  const OutputMap map = output_map(model, rec.x, rec.y, range, initial, !c.uncensored);
  doc.result.output_map = map;
  // (an input in another zero or unit is named as such; a narrow stretch is useless only where a sign,
  // unit or zero explains it: judge_evaluation, as Python's and MATLAB's evaluate)
  EvaluationVerdict verdict =
      judge_evaluation(model, rec.x, rec.y, range, initial, !c.uncensored, map, m, train, coverage.span_share,
                       c.sel.file, fmt::format("samples {}..{}", range.begin, range.end));
  if (!verdict.diagnosis.warning.empty()) warnings.push_back(std::move(verdict.diagnosis.warning));
  if (!verdict.diagnosis.sensor_warning.empty()) warnings.push_back(std::move(verdict.diagnosis.sensor_warning));
  if (!verdict.diagnosis.input_sensor_warning.empty())
    warnings.push_back(std::move(verdict.diagnosis.input_sensor_warning));
  if (!verdict.diagnosis.outlier_warning.empty()) warnings.push_back(std::move(verdict.diagnosis.outlier_warning));
  const bool useless = verdict.useless;
  if (useless) warnings.push_back(fmt::format("{}: evaluate exits {}", verdict.useless_warning, exit_poor_fit));
  for (const auto& w : warnings) fmt::print(stderr, "warning: {}\n", w);
  doc.warnings = warnings;  // the --json / --report document records them and the verdict
  doc.useless = useless;
  const int code = useless ? exit_poor_fit : exit_ok;

  if (!c.report.empty()) {
    if (is_html_path(c.report)) {
      report::FitData data = plot_data(sel, rec, initial, range);
      data.censor_clipped = doc.data.censored;
      report::write_evaluation_report(doc, data, c.report, command_line());  // the page `report ev.json` gives
    } else {
      io::write_text_file(c.report, io::to_json(doc).dump(2) + "\n");
    }
  }
  if (c.json) {
    fmt::print("{}\n", io::to_json(doc).dump(2));
    return code;
  }
  const std::string yu = doc.data.output_unit.empty() ? "" : " " + doc.data.output_unit;
  std::string text = fmt::format("model {} ({}) on {}, samples {}..{} ({} start)\n", doc.model_file, model_name(model),
                                 c.sel.file, range.begin, range.end, c.relaxed ? "relaxed" : "virgin");
  text += fmt::format("evaluate: rms {:.6g}{}  max {:.6g}{}  mae {:.6g}{}  rms {:.4g}% of span  r2 {:.6f}  ({} samples)\n",
                      m.rms, yu, m.max, yu, m.mae, yu, m.rms_percent_span, m.r2, m.n);
  if (doc.result.censored > 0)
    text += fmt::format("note: the output clips (a sensor's limit): {} samples at the limit where the model predicts "
                        "beyond it are scored as censored, no error (--uncensored: as recorded)\n",
                        doc.result.censored);
  if (!c.report.empty() && !report_stdout) text += fmt::format("report written to {}\n", c.report);
  std::fputs(text.c_str(), report_stdout ? stderr : stdout);
  return code;
}

}  // namespace

void add_evaluate(CLI::App& app, Action& action) {
  auto c = std::make_shared<EvaluateOptions>();
  CLI::App* sub = app.add_subcommand("evaluate", "score a saved model on measured input/output data (metrics, "
                                                 "loops and residuals in the report)");
  sub->footer("Exit codes: 0 evaluated; 1 error (bad input or usage, unreadable files); 3 a useless evaluation: "
              "the model file records its training error (\"training\", written by hysteron fit) and the model "
              "predicts the record worse than its mean (R^2 <= 0) with more than twice that RMS error (as fit "
              "--validate-data exits 3), unless the record's input spans less than half the model's input "
              "range and no sign, unit or zero explains it (its R^2 says little there: a warning says so); the metrics are printed as always.");
  sub->add_option("--model,-m", c->model, "model file (JSON); - reads it from stdin")->required();
  add_data_options(sub, c->sel);
  sub->add_option("--range,--train", c->range,
                  "samples scored: A:B (sample indices, half-open) or As:Bs (seconds); default: the whole record");
  sub->add_option("--sample-time", c->sample_time,
                  "sample time of the record in s, checked against a rate-pi model's dt (default: the mean step "
                  "of --time-column; with both they must agree)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--report", c->report, "write a report: HTML if the name ends in .html/.htm, else JSON");
  sub->add_flag("--json", c->json, "print the result as one JSON document");
  sub->add_flag("--relaxed", c->relaxed, "start from rest at the first sample instead of the virgin state");
  sub->add_flag("--uncensored", c->uncensored,
                "score a record whose output clips as recorded (default: a sample at the limit where the model "
                "predicts beyond it is no error, as fit scores its validation)");
  sub->callback([c, &action] { action = [c] { return run_evaluate(*c); }; });
}

}  // namespace hysteron::cli
