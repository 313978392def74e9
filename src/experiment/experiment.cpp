#include "hysteron/experiment.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <tuple>

#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/signals.hpp"

namespace hysteron {

namespace {

constexpr double kPressureMax = 0.6;  // [MPa] actuator limit of every experiment

struct IdRecord {
  std::vector<double> t, p_cmd, p, x_mm;
};

// Drives the regulator with a pressure sequence sampled at the control period.
IdRecord identification_run(const PamRigParams& rp, std::uint64_t seed, const std::vector<double>& pressure,
                            double tc) {
  PamRig rig(rp, seed);
  rig.reset();
  IdRecord rec;
  std::size_t k = 0;
  rig.run(static_cast<double>(pressure.size()) * tc, tc, [&](const RigOutputs& o) {
    RigInputs in;
    in.mode = Actuation::regulator;
    in.pressure_command = std::clamp(pressure[std::min(k, pressure.size() - 1)], 0.0, kPressureMax);
    rec.t.push_back(o.time);
    rec.p_cmd.push_back(in.pressure_command);
    rec.p.push_back(o.pressure_measured * 1e-6);
    rec.x_mm.push_back(o.contraction_measured * 1e3);
    ++k;
    return in;
  });
  return rec;
}

// Straight line x = a p + b through the record (least squares): the baseline's
// "inverse without hysteresis".
ModelParams straight_line(const IdRecord& r) {
  const std::size_t n = r.p.size();
  double sp = 0, sx = 0, spp = 0, spx = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sp += r.p[i];
    sx += r.x_mm[i];
    spp += r.p[i] * r.p[i];
    spx += r.p[i] * r.x_mm[i];
  }
  const double den = n * spp - sp * sp;
  const double a = (n * spx - sp * sx) / den;
  const double b = (sx - a * sp) / n;
  if (!(a > 0)) throw Error("experiment: the identification run shows no contraction increasing with pressure");
  GpiParams g;
  g.envelope = Envelope::affine(a, b);
  g.q = 1.0;
  g.n = 0;
  g.input_limits = {0.0, kPressureMax};
  return g;
}

void set_limits(ModelParams& m) {
  std::visit([](auto& p) { p.input_limits = {0.0, kPressureMax}; }, m);
}

TrackingErrors errors_of(const TrackingRun& run, std::size_t from) {
  TrackingErrors e;
  double s2 = 0, s1 = 0;
  std::size_t n = 0;
  for (std::size_t k = from; k < run.t.size(); ++k) {
    const double d = run.reference_mm[k] - run.measured_mm[k];
    e.max_error_mm = std::max(e.max_error_mm, std::abs(d));
    s1 += std::abs(d);
    s2 += d * d;
    ++n;
  }
  if (n) {
    e.mae_mm = s1 / n;
    e.rms_error_mm = std::sqrt(s2 / n);
  }
  return e;
}

// What a controller sees each control period and what it commands.
struct Sample {
  double reference_m, preview_m, measured_m, pressure_mpa;
};
using Law = std::function<RigInputs(const Sample&)>;

// Runs one tracking experiment: reference sampled at the control period,
// preview `lead` samples ahead; errors from sample `score_from` on.
TrackingRun track(const ExperimentOptions& o, std::uint64_t seed, const std::vector<double>& ref_m,
                  std::size_t lead, std::size_t score_from, const Law& law) {
  PamRig rig(o.rig, seed);
  rig.reset();
  TrackingRun run;
  const std::size_t n = ref_m.size();
  for (auto* v : {&run.t, &run.reference_mm, &run.measured_mm, &run.actual_mm, &run.pressure_command_mpa,
                  &run.pressure_mpa, &run.duty})
    v->reserve(n);
  std::size_t k = 0;
  rig.run(static_cast<double>(n) * o.control_period, o.control_period, [&](const RigOutputs& out) {
    const std::size_t i = std::min(k, n - 1);
    const Sample s{ref_m[i], ref_m[std::min(i + lead, n - 1)], out.contraction_measured, out.pressure_measured * 1e-6};
    RigInputs in = law(s);
    run.t.push_back(out.time);
    run.reference_mm.push_back(s.reference_m * 1e3);
    run.measured_mm.push_back(out.contraction_measured * 1e3);
    run.actual_mm.push_back(out.contraction * 1e3);
    // With the valves, pressure_command carries the cascade's desired pressure (the rig ignores it).
    run.pressure_command_mpa.push_back(in.pressure_command);
    run.pressure_mpa.push_back(out.pressure * 1e-6);
    run.duty.push_back(in.mode == Actuation::switching_valves ? in.pwm_duty : 0.0);
    if (in.pressure_command <= 0.0 || in.pressure_command >= kPressureMax)
      ++run.saturated;
    ++k;
    return in;
  });
  run.errors = errors_of(run, score_from);
  return run;
}

RigInputs regulator(double p) {
  RigInputs in;
  in.mode = Actuation::regulator;
  in.pressure_command = std::clamp(p, 0.0, kPressureMax);
  return in;
}

RigInputs valves(const CascadePwmController& c, double duty) {
  RigInputs in;
  in.mode = Actuation::switching_valves;
  in.pwm_duty = std::clamp(duty, -1.0, 1.0);
  in.pressure_command = c.desired_pressure();
  return in;
}

// The fits use the record at 100 Hz (every 10th sample at a 1 kHz control
// period): the loops are slow (0.2 Hz), so nothing is lost and fitting is 10x faster.
constexpr double kFitRate = 100.0;  // [Hz]

IdRecord decimate(const IdRecord& r, std::size_t every) {
  IdRecord d;
  for (std::size_t i = 0; i < r.t.size(); i += every) {
    d.t.push_back(r.t[i]);
    d.p_cmd.push_back(r.p_cmd[i]);
    d.p.push_back(r.p[i]);
    d.x_mm.push_back(r.x_mm[i]);
  }
  return d;
}

FitReport fit_checked(const IdRecord& r, FitOptions fo, const std::string& what) {
  FitReport rep = fit(r.p, r.x_mm, fo);
  if (rep.status == FitStatus::invalid_input || rep.status == FitStatus::failed)
    throw Error(fmt::format("experiment: fit of the {} failed: {}", what, rep.message));
  set_limits(rep.model);
  Inverse check(rep.model);  // throws if the fitted model is not invertible
  return rep;
}

// Lead [samples] that best aligns the model driven by the COMMANDED pressure with
// the measured contraction: x(t) ~ M(p_cmd(t - lead)). It lumps the regulator's
// dead time and lag and the load's dynamics; the compensated variants feed the
// inverse with the reference `lead` ahead (the reference is known in advance).
std::size_t estimate_lead(const ModelParams& model, const IdRecord& r, double tc) {
  const auto max_lead = static_cast<std::size_t>(std::lround(0.3 / tc));
  const auto step = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(0.002 / tc)));
  std::size_t best = 0;
  double best_sse = std::numeric_limits<double>::infinity();
  std::vector<double> shifted(r.p_cmd.size());
  for (std::size_t lead = 0; lead <= max_lead; lead += step) {
    for (std::size_t k = 0; k < shifted.size(); ++k) shifted[k] = r.p_cmd[k >= lead ? k - lead : 0];
    const std::vector<double> y = simulate_record(model, shifted);
    double sse = 0;
    for (std::size_t k = max_lead; k < y.size(); ++k) sse += (y[k] - r.x_mm[k]) * (y[k] - r.x_mm[k]);
    if (sse < best_sse) {
      best_sse = sse;
      best = lead;
    }
  }
  return best;
}

struct Setup {
  std::string title;
  FitModel model;
  int operators;
  std::vector<double> id_pressure;       // paper's identification input
  std::vector<double> id2_pressure;      // second run for the best model's validation
  std::size_t train_end;                 // major loop
  // name, reference [m], first scored sample: the Eq. 18 sinusoid starts at 5 mm
  // away from the vented muscle, so its first period is a warm-up; the papers'
  // 40/35/30 mm references start at 0 and are scored whole.
  std::vector<std::tuple<std::string, std::vector<double>, std::size_t>> references;
  PublishedFigures published;
};

Setup setup_for(const ExperimentOptions& o) {
  const double tc = o.control_period;
  Setup s;
  const auto major = static_cast<std::size_t>(std::lround(5.0 / tc));  // one 0.2 Hz period
  if (o.name == "gpi-pid") {
    s.title = "GPI model + inverse feedforward + PID (gpi-lm-feedforward-pid.txt, Fig. 10, Tables 3-5)";
    s.model = FitModel::gpi;
    s.operators = 10;
    s.id_pressure = gpi_identification_pressure(tc);
    s.id2_pressure = mpi_identification_pressure(tc);
    s.train_end = major;
    // Eq. 18 / Table 4, one warm-up period then three scored periods.
    s.references.push_back({"sine", gpi_sinusoid_reference(tc, 20.0), major});
    s.published = {"gpi-lm-feedforward-pid.txt, Table 5", {{"", 2.659, 0.7358, 0.8701}}};
  } else if (o.name == "mpi-openloop") {
    s.title = "Asymmetric MPI + open-loop inverse + proportional pressure loop (mpi-asymmetric-openloop.txt, Fig. 6)";
    s.model = FitModel::mpi_asym;
    s.operators = 20;
    s.id_pressure = mpi_identification_pressure(tc);
    s.id2_pressure = gpi_identification_pressure(tc);
    s.train_end = major;
    s.references.push_back({"triangle", mpi_triangle_contraction(tc, 1), 0});
    s.references.push_back({"sine", mpi_sine_contraction(tc, 1), 0});
    s.published = {"mpi-asymmetric-openloop.txt, Results", {{"triangle", 1.29}, {"sine", 1.38}}};
  } else if (o.name == "mpi-pwm") {
    s.title = "Dead-zone MPI + cascade control with fast switching valves (mpi-deadzone-switching-valves.txt)";
    s.model = FitModel::mpi_deadzone;
    s.operators = 10;
    s.id_pressure = gpi_identification_pressure(tc);
    s.id2_pressure = mpi_identification_pressure(tc);
    s.train_end = major;
    s.references.push_back({"sine", gpi_sinusoid_reference(tc, 20.0), major});
    s.references.push_back({"triangle", mpi_triangle_contraction(tc, 1), 0});
    s.published = {};  // the text we have ends before the paper's results
  } else {
    throw Error(fmt::format("experiment: unknown experiment \"{}\"", o.name));  // validate() lists the names
  }
  return s;
}

}  // namespace

void ExperimentOptions::validate() const {
  hysteron::validate(rig, "experiment: rig");
  if (!(control_period >= rig.simulation.dt) || !(control_period <= 0.02))
    throw Error(fmt::format("experiment: control_period = {} s must be within [rig dt = {} s, 0.02 s]",
                            control_period, rig.simulation.dt));
  const auto names = experiment_names();
  if (std::find(names.begin(), names.end(), name) == names.end())
    throw Error(fmt::format("experiment: unknown experiment \"{}\" (expected gpi-pid, mpi-openloop or mpi-pwm)", name));
}

std::vector<std::string> experiment_names() { return {"gpi-pid", "mpi-openloop", "mpi-pwm"}; }

ExperimentResult run_experiment(const ExperimentOptions& o) {
  o.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const double tc = o.control_period;
  Setup su = setup_for(o);
  ExperimentResult res;
  res.name = o.name;
  res.title = su.title;
  res.seed = o.seed;
  res.published = su.published;

  // 1. identification run and the paper's fit on the major loop
  const IdRecord id = identification_run(o.rig, o.seed, su.id_pressure, tc);
  res.id_t = id.t;
  res.id_pressure_command_mpa = id.p_cmd;
  res.id_pressure_mpa = id.p;
  res.id_contraction_mm = id.x_mm;
  res.id_train_end = su.train_end;
  const auto every = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (kFitRate * tc))));
  const IdRecord idf = decimate(id, every);
  const std::size_t train_end = (su.train_end + every - 1) / every;
  FitOptions fo;
  fo.model = su.model;
  fo.num_operators = su.operators;
  fo.train = {0, train_end};
  fo.seed = static_cast<unsigned>(o.seed);
  res.fit = fit_checked(idf, fo, "paper's model");
  res.validation = evaluate(res.fit.model, idf.p, idf.x_mm, {train_end, IndexRange::npos});

  // 2. hysteron's model: candidates fitted on the whole record, chosen on a second
  //    identification run (other seed, other pressure sequence).
  const IdRecord id2 = decimate(identification_run(o.rig, o.seed + 7919, su.id2_pressure, tc), every);
  double best_rms = std::numeric_limits<double>::infinity();
  for (FitModel kind : {su.model, FitModel::gpi, FitModel::mpi_asym}) {
    FitOptions f2 = fo;
    f2.model = kind;
    f2.num_operators = kind == FitModel::mpi_asym ? 20 : std::max(10, su.operators);
    f2.train = {};
    FitReport rep;
    try {
      rep = fit_checked(idf, f2, "candidate model");
    } catch (const Error& e) {
      fmt::print(stderr, "experiment: candidate {} skipped: {}\n", fit_model_name(kind), e.what());
      continue;
    }
    const FitMetrics m = evaluate(rep.model, id2.p, id2.x_mm);
    if (m.rms < best_rms) {
      best_rms = m.rms;
      res.best_fit = std::move(rep);
      res.best_validation = m;
    }
  }
  res.baseline_model = straight_line(id);

  // 3. tracking
  const std::size_t lead = estimate_lead(res.best_fit.model, id, tc);
  res.lead_s = static_cast<double>(lead) * tc;
  const std::uint64_t track_seed = o.seed + 104729;
  for (const auto& [ref_name, ref, score_from] : su.references) {
    auto add = [&](const std::string& variant, const std::string& desc, std::size_t preview, const Law& law) {
      TrackingRun run = track(o, track_seed, ref, preview, score_from, law);
      run.variant = variant;
      run.reference = ref_name;
      run.description = desc;
      res.runs.push_back(std::move(run));
    };
    FeedforwardParams ff_plain;
    ff_plain.sample_time = tc;

    if (o.name == "gpi-pid") {
      const PidParams paper = gpi_paper_pid(tc, -kPressureMax, kPressureMax);
      PidParams tuned = paper;
      tuned.kp = 8.0;    // MPa/m (stability limit ~12 with the regulator lag and the load)
      tuned.ki = 40.0;   // MPa/(m s)
      tuned.kd = 0.2;    // MPa s/m: damps the load's ~3 Hz mode
      tuned.derivative_filter = 0.01;  // s
      auto faithful = std::make_shared<FeedforwardPidController>(res.fit.model, ff_plain, paper);
      add("faithful", "inverse GPI feedforward + PID of Table 3 (Kp = 0.05 V/mm, Ki = 0.01 V/(mm s))", 0,
          [faithful](const Sample& s) { return regulator(faithful->step(s.reference_m, s.preview_m, s.measured_m)); });
      auto best = std::make_shared<FeedforwardPidController>(res.best_fit.model, ff_plain, tuned);
      add("compensated", fmt::format("best inverse model fed {:.0f} ms ahead (lead identified from the identification run), "
                      "PID tuned (Kp = 8 MPa/m, Ki = 40 MPa/(m s), Kd = 0.2 MPa s/m, 10 ms filter)", res.lead_s * 1e3),
          lead, [best](const Sample& s) { return regulator(best->step(s.reference_m, s.preview_m, s.measured_m)); });
      auto base = std::make_shared<FeedforwardPidController>(res.baseline_model, ff_plain, paper);
      add("baseline", "straight-line feedforward (no hysteresis) + PID of Table 3", 0,
          [base](const Sample& s) { return regulator(base->step(s.reference_m, s.preview_m, s.measured_m)); });
    } else if (o.name == "mpi-openloop") {
      OpenLoopParams faithful_p;
      faithful_p.feedforward = ff_plain;
      faithful_p.pressure_gain = 0.5;
      auto faithful = std::make_shared<OpenLoopController>(res.fit.model, faithful_p);
      add("faithful", "inverse asymmetric MPI, open loop, proportional pressure loop (k_p = 0.5)", 0,
          [faithful](const Sample& s) {
            return regulator(faithful->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa));
          });
      OpenLoopParams best_p = faithful_p;
      best_p.position = gpi_paper_pid(tc);
      best_p.position.kp = 6.0;   // MPa/m (x 1.5 through the pressure loop)
      best_p.position.ki = 40.0;  // MPa/(m s)
      best_p.position.kd = 0.2;   // MPa s/m
      best_p.position.derivative_filter = 0.01;
      auto best = std::make_shared<OpenLoopController>(res.best_fit.model, best_p);
      add("compensated", fmt::format("best inverse model fed {:.0f} ms ahead, pressure loop + PI position correction",
                      res.lead_s * 1e3),
          lead, [best](const Sample& s) {
            return regulator(best->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa));
          });
      auto base = std::make_shared<OpenLoopController>(res.baseline_model, faithful_p);
      add("baseline", "straight-line open-loop inverse (no hysteresis), proportional pressure loop", 0,
          [base](const Sample& s) {
            return regulator(base->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa));
          });
    } else {  // mpi-pwm
      CascadeParams cp;
      cp.feedforward = ff_plain;
      cp.position = gpi_paper_pid(tc, -kPressureMax, kPressureMax);
      cp.pressure.kp = 20.0;  // duty per MPa
      cp.pressure.sample_time = tc;
      cp.pwm.gain = 1.0;
      auto faithful = std::make_shared<CascadePwmController>(res.fit.model, cp);
      add("faithful", "inverse dead-zone MPI + PID position loop, P pressure loop on PWM switching valves", 0,
          [faithful](const Sample& s) {
            const double d = faithful->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa);
            return valves(*faithful, d);
          });
      CascadeParams bp = cp;
      bp.position.kp = 4.0;
      bp.position.ki = 40.0;
      bp.pressure.kp = 30.0;
      bp.pressure.ki = 300.0;
      auto best = std::make_shared<CascadePwmController>(res.best_fit.model, bp);
      add("compensated", "best inverse model, PI position loop, PI pressure loop on PWM switching valves", 2,
          [best](const Sample& s) {
            const double d = best->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa);
            return valves(*best, d);
          });
      auto base = std::make_shared<CascadePwmController>(res.baseline_model, cp);
      add("baseline", "straight-line feedforward (no hysteresis) in the same cascade", 0, [base](const Sample& s) {
        const double d = base->step(s.reference_m, s.preview_m, s.measured_m, s.pressure_mpa);
            return valves(*base, d);
      });
    }
  }
  res.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

void ExperimentResult::write(const std::string& dir) const {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(fmt::format("experiment: cannot create output directory {}: {}", dir, ec.message()));
  const std::filesystem::path d(dir);
  io::write_columns((d / "identification.csv").string(),
                    {"t_s", "pressure_command_mpa", "pressure_mpa", "contraction_mm"},
                    {id_t, id_pressure_command_mpa, id_pressure_mpa, id_contraction_mm});
  for (const auto& r : runs)
    io::write_columns((d / fmt::format("tracking_{}_{}.csv", r.variant, r.reference)).string(),
                      {"t_s", "reference_mm", "measured_mm", "actual_mm", "pressure_command_mpa", "pressure_mpa",
                       "pwm_duty"},
                      {r.t, r.reference_mm, r.measured_mm, r.actual_mm, r.pressure_command_mpa, r.pressure_mpa,
                       r.duty});
  io::write_model_file((d / "model.json").string(), fit.model);
  io::write_model_file((d / "best_model.json").string(), best_fit.model);
  io::write_text_file((d / "result.json").string(), io::to_json(*this).dump(2) + "\n");
}

std::string ExperimentResult::table() const {
  std::string s = fmt::format("{}: {}\n", name, title);
  s += fmt::format("  identification: {} fitted on the major loop, RMS {:.3f} mm train, {:.3f} mm ({:.2f} % of span) "
                   "on the minor loops; best model {} ({:.3f} mm RMS on a second run)\n",
                   fit_model_name(fit.model_kind), fit.train.rms, validation.rms, validation.rms_percent_span,
                   fit_model_name(best_fit.model_kind), best_validation.rms);
  s += fmt::format("  {:<10} {:<12} {:>9} {:>9} {:>9}\n", "reference", "variant", "max [mm]", "MAE [mm]", "RMS [mm]");
  for (const auto& r : runs)
    s += fmt::format("  {:<10} {:<12} {:>9.3f} {:>9.4f} {:>9.4f}\n", r.reference, r.variant, r.errors.max_error_mm,
                     r.errors.mae_mm, r.errors.rms_error_mm);
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
  return s;
}

}  // namespace hysteron
