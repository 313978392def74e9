// Compensating controllers on the rig: pressure commands always inside the
// actuator's limits (randomized over plants and references, reachable or not),
// and the gpi-pid experiment end to end.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <random>
#include <limits>
#include <numbers>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "hysteron/compensation.hpp"
#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/report.hpp"
#include "temp_dir.hpp"
#include "../src/experiment/detail.hpp"  // user_references
#include "test_util.hpp"
#include "hysteron/plant.hpp"

using namespace hysteron;

namespace {

using test::rig_like_gpi;

}  // namespace

TEST(Compensation, PressureCommandsNeverLeaveLimitsOnRandomPlantsAndReferences) {
  std::mt19937_64 rng(20261122);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const GpiParams model = rig_like_gpi();
  for (int trial = 0; trial < 12; ++trial) {
    PamRigParams rp;
    rp.load.mass = 5.0 + 25.0 * u(rng);
    rp.load.damping = 50.0 + 800.0 * u(rng);
    rp.hysteresis.pressure_band = 5e3 + 25e3 * u(rng);
    rp.regulator.time_constant = 0.03 + 0.07 * u(rng);
    PamRig rig(rp, 100 + trial);
    rig.reset();
    // Reference: offset and amplitude chosen so that it often leaves the reachable range.
    const double offset = -0.02 + 0.14 * u(rng), amp = 0.08 * u(rng), f = 0.1 + 2.0 * u(rng);
    const double tc = 1e-3;
    FeedforwardParams ff;
    ff.sample_time = tc;
    ff.lag_time_constant = 0.05 * u(rng);
    PidParams pid = gpi_paper_pid(tc);
    pid.kp = 20.0 * u(rng);
    pid.ki = 200.0 * u(rng);
    FeedforwardPidController fp(model, ff, pid);
    OpenLoopParams olp;
    olp.feedforward = ff;
    olp.pressure_gain = 2.0 * u(rng);
    olp.position = pid;
    OpenLoopController ol(model, olp);
    CascadeParams cp;
    cp.feedforward = ff;
    cp.position = pid;
    cp.pressure.kp = 50.0 * u(rng);
    cp.pressure.sample_time = tc;
    CascadePwmController cc(model, cp);
    const int which = trial % 3;
    std::size_t k = 0, commands = 0;
    rig.run(3.0, tc, [&](const RigOutputs& o) {
      double ref = offset + amp * std::sin(2 * M_PI * f * k * tc);
      if (k % 997 == 0) ref = std::nan("");  // a broken reference sample now and then
      ++k;
      RigInputs in;
      const double y = (k % 501 == 0) ? std::numeric_limits<double>::infinity() : o.contraction_measured;
      const double p = o.pressure_measured * 1e-6;
      if (which == 0) {
        in.pressure_command = fp.step(ref, ref, y);
      } else if (which == 1) {
        in.pressure_command = ol.step(ref, ref, y, p);
      } else {
        in.mode = Actuation::switching_valves;
        in.pwm_duty = cc.step(ref, ref, y, p);
        EXPECT_GE(in.pwm_duty, -1.0);
        EXPECT_LE(in.pwm_duty, 1.0);
        in.pressure_command = cc.desired_pressure();
      }
      EXPECT_TRUE(std::isfinite(in.pressure_command)) << "trial " << trial << " k " << k;
      EXPECT_GE(in.pressure_command, 0.0) << "trial " << trial;
      EXPECT_LE(in.pressure_command, 0.6) << "trial " << trial;
      ++commands;
      return in;
    });
    EXPECT_EQ(commands, 3000u);
    EXPECT_TRUE(rig.ok());
  }
}

TEST(Compensation, StepsDoNotAllocate) {
  const GpiParams model = rig_like_gpi();
  FeedforwardParams ff;
  ff.lag_time_constant = 0.05;
  FeedforwardPidController fp(model, ff, gpi_paper_pid(1e-3));
  OpenLoopParams olp;
  olp.feedforward = ff;
  OpenLoopController ol(model, olp);
  CascadeParams cp;
  cp.feedforward = ff;
  cp.position = gpi_paper_pid(1e-3);
  cp.pressure.kp = 20;
  CascadePwmController cc(model, cp);
  const std::size_t before = hysteron_test::allocations();
  double acc = 0;
  for (int k = 0; k < 5000; ++k) {
    const double r = 0.05 + 0.04 * std::sin(0.002 * k);
    acc += fp.step(r, r, r - 0.001) + ol.step(r, r, r, 0.3) + cc.step(r, r, r, 0.3);
  }
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_TRUE(std::isfinite(acc));
}

TEST(Compensation, InvalidParametersAreRejected) {
  FeedforwardParams ff;
  ff.pressure_limits = {0.6, 0.0};
  EXPECT_THROW(InverseFeedforward(rig_like_gpi(), ff), Error);
  ff = {};
  ff.sample_time = 0;
  EXPECT_THROW(InverseFeedforward(rig_like_gpi(), ff), Error);
  OpenLoopParams ol;
  ol.pressure_gain = -1;
  EXPECT_THROW(OpenLoopController(rig_like_gpi(), ol), Error);
}

// A PID at another sample time than the loop's integrated with its own T_s without a word.
TEST(Compensation, PidAtAnotherSampleTimeIsRejected) {
  FeedforwardParams ff;
  ff.sample_time = 0.01;
  const auto message = [](auto&& make) -> std::string {
    try {
      make();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string m = message([&] { FeedforwardPidController(rig_like_gpi(), ff, gpi_paper_pid(1e-3)); });
  EXPECT_NE(m.find("pid.sample_time = 0.001 s differs from the loop's sample_time = 0.01 s"), std::string::npos) << m;
  EXPECT_NO_THROW(FeedforwardPidController(rig_like_gpi(), ff, gpi_paper_pid(0.01)));
  OpenLoopParams ol;
  ol.feedforward = ff;  // the position PID unused (no gains): its sample time does not matter
  EXPECT_NO_THROW(OpenLoopController(rig_like_gpi(), ol));
  ol.position = gpi_paper_pid(1e-3);
  EXPECT_NE(message([&] { OpenLoopController(rig_like_gpi(), ol); }).find("position.sample_time"), std::string::npos);
  ol.position.sample_time = 0.01;
  EXPECT_NO_THROW(OpenLoopController(rig_like_gpi(), ol));
  CascadeParams cp;
  cp.feedforward = ff;
  cp.position = gpi_paper_pid(0.01);
  cp.pressure.kp = 20;  // sample_time left at 1e-3
  EXPECT_NE(message([&] { CascadePwmController(rig_like_gpi(), cp); }).find("pressure.sample_time"),
            std::string::npos);
  cp.pressure.sample_time = 0.01;
  EXPECT_NO_THROW(CascadePwmController(rig_like_gpi(), cp));
  cp.position.sample_time = 1e-3;
  EXPECT_NE(message([&] { CascadePwmController(rig_like_gpi(), cp); }).find("position.sample_time"),
            std::string::npos);
}

TEST(Experiment, UnknownNameAndBadOptionsAreRejected) {
  ExperimentOptions o;
  o.name = "gpi-pdi";
  EXPECT_THROW(run_experiment(o), Error);
  o.name = "gpi-pid";
  o.control_period = 0.5;
  EXPECT_THROW(run_experiment(o), Error);
}

TEST(Experiment, ARigWhoseDtDoesNotDivideTheControlPeriodIsRefused) {
  // it ran every 11 steps of 9.52e-5 s (1.0472 ms) with controllers discretised at 1 ms
  ExperimentOptions o;
  o.name = "gpi-pid";
  o.rig.simulation.dt = 9.52e-5;
  std::string msg = test::error_of([&] { o.validate(); });
  EXPECT_NE(msg.find("experiment: rig: control_period = 0.001 s is not a whole multiple of the rig's simulation.dt = "
                     "9.52e-05 s"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find("nearest dt that divides it is 9.0909090909"), std::string::npos) << msg;
  o.rig.simulation.dt = 5e-5;  // 20 steps
  EXPECT_NO_THROW(o.validate());
  o.tracking_rig = o.rig;
  o.tracking_rig->simulation.dt = 9.52e-5;
  msg = test::error_of([&] { o.validate(); });
  EXPECT_NE(msg.find("experiment: tracking rig: control_period = 0.001 s"), std::string::npos) << msg;
}

TEST(Experiment, GpiPidEndToEnd) {
  ExperimentOptions o;
  o.name = "gpi-pid";
  o.seed = 3;
  o.learning_periods = 2;
  // pinned: the learning and adaptive variants need a kind of the PI family whose identified
  // loop admits a learning filter (auto chooses kp on this rig: no adaptive run)
  o.model = FitModel::mpi_asym;
  const ExperimentResult r = run_experiment(o);
  const auto j = r.to_json();
  for (const char* v : {"compensated", "faithful", "baseline"})
    for (const char* k : {"max_error_mm", "mae_mm", "rms_error_mm"}) {
      ASSERT_TRUE(j[v].contains(k)) << v << "." << k;
      EXPECT_TRUE(std::isfinite(j[v][k].get<double>()));
    }
  EXPECT_DOUBLE_EQ(j["published"]["rms_error_mm"].get<double>(), 0.8701);
  // Hysteresis compensation must beat the same loop without it.
  EXPECT_LT(j["compensated"]["rms_error_mm"].get<double>(), j["baseline"]["rms_error_mm"].get<double>());
  EXPECT_LT(j["faithful"]["rms_error_mm"].get<double>(), j["baseline"]["rms_error_mm"].get<double>());
  // The variants, in the registry's order, with the learning run's periods.
  EXPECT_EQ(j["variants"], nlohmann::json({"faithful", "compensated", "learning", "adaptive", "baseline"}));
  // every run's loop names the rig's pressure limits: result.json never leaves them to the model
  ASSERT_FALSE(r.runs.empty());
  for (const TrackingRun& run : r.runs)
    EXPECT_EQ(run.controller.feedforward.pressure_limits, (Limits{0.0, r.pressure_limit_mpa})) << run.variant;
  for (const char* v : {"faithful", "compensated", "learning", "adaptive", "baseline"}) {
    EXPECT_TRUE(j[v]["controller"]["feedforward"]["pressure_min_mpa"].is_number()) << v;
    EXPECT_EQ(j[v]["controller"]["feedforward"]["pressure_max_mpa"].get<double>(), r.pressure_limit_mpa) << v;
  }
  ASSERT_EQ(j["learning"]["periods"].size(), 2u);
  EXPECT_EQ(experiments().front().variants,
            std::vector<std::string>({"faithful", "compensated", "learning", "adaptive", "baseline"}));
  for (const char* k : {"max_error_mm", "mae_mm", "rms_error_mm"}) EXPECT_TRUE(j["adaptive"].contains(k)) << k;
  // The paper's reference lies within the nominal rig's reach: tracked as published.
  ASSERT_EQ(r.reference_ranges.size(), 1u);
  EXPECT_FALSE(r.reference_ranges[0].scaled);
  EXPECT_TRUE(r.reference_ranges[0].reachable);
  EXPECT_NEAR(r.reference_ranges[0].max_mm, 95.0, 1e-9);
  EXPECT_LT(r.reference_ranges[0].max_mm, r.reach_max_mm);
  // Reproducible bit for bit with the same seed.
  const ExperimentResult r2 = run_experiment(o);
  ASSERT_EQ(r.runs.size(), r2.runs.size());
  EXPECT_EQ(r.runs[0].measured_mm, r2.runs[0].measured_mm);
}

// A heavier load than the actuator can lift to the paper's 95 mm at 0.6 MPa: the reference is
// scaled into the reach the identification run measured (its top where the rig was on its
// ascent at 0.57 MPa), said in the messages, and the compensated loop then tracks it without
// holding the command at the limit; with the published reference it sits at the limit and
// the result says the reference is out of reach.
TEST(Experiment, ReferenceAboveTheRigsReachIsScaledOrReported) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.load.mass = 35.0;
  const auto top_of_id_ascent = [](const ExperimentResult& r) {  // least contraction at >= 0.57 MPa
    double top = INFINITY;
    for (std::size_t k = 0; k < r.identification.pressure_mpa.size(); ++k)
      if (r.identification.pressure_mpa[k] >= 0.57) top = std::min(top, r.identification.contraction_mm[k]);
    return top;
  };
  const auto compensated = [](const ExperimentResult& r) -> const TrackingRun& {
    for (const auto& run : r.runs)
      if (run.variant == "compensated") return run;
    throw std::runtime_error("no compensated run");
  };
  const ExperimentResult scaled = run_experiment(o);
  ASSERT_EQ(scaled.reference_ranges.size(), 1u);
  const ReferenceRange& rr = scaled.reference_ranges[0];
  EXPECT_TRUE(rr.scaled);
  EXPECT_TRUE(rr.reachable);
  EXPECT_NEAR(rr.paper_max_mm, 95.0, 1e-9);
  EXPECT_NEAR(rr.min_mm, rr.paper_min_mm, 1e-9);  // scaled about its bottom
  EXPECT_LT(rr.max_mm, scaled.reach_max_mm);
  EXPECT_NEAR(rr.max_mm, top_of_id_ascent(scaled), 0.5);  // the 11-sample mean against the raw samples
  const TrackingRun& c = compensated(scaled);
  EXPECT_NEAR(*std::max_element(c.reference_mm.begin(), c.reference_mm.end()), rr.max_mm, 1e-6);
  EXPECT_EQ(c.saturated, 0u);
  EXPECT_TRUE(test::said(scaled, "reference sine mapped onto"));

  o.fit_references = false;
  const ExperimentResult paper = run_experiment(o);
  ASSERT_EQ(paper.reference_ranges.size(), 1u);
  EXPECT_FALSE(paper.reference_ranges[0].scaled);
  EXPECT_FALSE(paper.reference_ranges[0].reachable);
  const TrackingRun& p = compensated(paper);
  EXPECT_NEAR(*std::max_element(p.reference_mm.begin(), p.reference_mm.end()), 95.0, 1e-6);
  EXPECT_GT(p.saturated, 100u);  // held at 0.6 MPa near every top
  EXPECT_GT(p.errors.rms_error_mm, 1.5 * c.errors.rms_error_mm);
  EXPECT_FALSE(test::said(paper, "levelled off"));  // the actuator reaches 0.6 MPa: not a cap
  EXPECT_TRUE(test::said(paper, "out of this rig's reach"));
}

// TrackingRun::saturated counts the scored samples only (those `errors` is over: after the warm-up
// or pre-roll; a learning run's last period), as the saturation note does: recounted here from the
// run's own series, its scored_from_s and the result's pressure limit. On the 35 kg rig with the
// published reference the command sits at the limit near every top, in the scored samples and
// before them.
TEST(Experiment, SaturatedSamplesAreTheScoredOnes) {
  ExperimentOptions o = test::quick_experiment("gpi-pid", 2);
  o.rig.load.mass = 35.0;
  o.fit_references = false;
  const ExperimentResult r = run_experiment(o);
  const double p_max = r.pressure_limit_mpa;
  bool learning = false;
  std::size_t whole_run_more = 0;
  for (const TrackingRun& run : r.runs) {
    const auto from = static_cast<std::size_t>(
        std::lower_bound(run.t.begin(), run.t.end(), run.scored_from_s) - run.t.begin());
    ASSERT_LT(from, run.t.size()) << run.variant;
    const std::size_t to = run.t.size();  // a learning run's series end with its last period
    learning = learning || !run.periods.empty();
    std::size_t scored = 0, all = 0;
    for (std::size_t k = 0; k < run.pressure_command_mpa.size(); ++k) {
      const bool at_limit = run.pressure_command_mpa[k] <= 0.0 || run.pressure_command_mpa[k] >= p_max;
      all += at_limit;
      scored += at_limit && k >= from && k < to;
    }
    EXPECT_EQ(run.saturated, scored) << run.variant << " " << run.reference;
    whole_run_more += all > scored;
  }
  EXPECT_TRUE(learning) << "no learning run: the test shows nothing of its periods";
  EXPECT_GT(whole_run_more, 0u) << "no run saturates before its scored samples: the test shows nothing";
}

// A muscle whose stroke ends below the papers' references (15 % of 0.5 m: a hard stop at 75
// mm, reached at about 0.42 MPa): the reach's top was taken at 0.57 MPa, i.e. on the stop, and
// the references were mapped onto the stop, where the contraction no longer answers the
// pressure (compensated max 1.86 mm against 0.93 nominal). The stop is found in the
// identification run and the reach keeps the pressure headroom below it, as below the
// actuator's top; the nominal rig (its stroke, 25 %, beyond the reach) is not flagged, in each
// experiment.
TEST(Experiment, AStrokeEndBelowTheReferencesIsKeptOutOfTheReach) {
  for (const char* name : {"gpi-pid", "mpi-pwm"}) {
    SCOPED_TRACE(name);
    ExperimentOptions o = test::quick_experiment(name);
    o.rig.muscle.max_contraction = std::string(name) == "gpi-pid" ? 0.15 : 0.08;
    const double stop_mm = 1e3 * o.rig.muscle.max_contraction * o.rig.muscle.rest_length;
    const ExperimentResult r = run_experiment(o);
    EXPECT_TRUE(test::said(r, "stops growing at")) << name;
    EXPECT_NEAR(r.reach_max_mm, stop_mm, 0.5);
    // the top where the ascent reached 95 % of the stop's pressure: below the stop by more than
    // the noise, and at a pressure below the actuator's headroom line
    EXPECT_LT(r.reach_top_mm, stop_mm - 1.0);
    EXPECT_LT(r.reach_top_pressure_mpa, 0.95 * r.pressure_limit_mpa);
    for (const ReferenceRange& rr : r.reference_ranges) {
      EXPECT_TRUE(rr.scaled) << rr.reference;
      EXPECT_LE(rr.max_mm, r.reach_top_mm + 1e-9) << rr.reference;
    }
    const ExperimentResult nominal = run_experiment(test::quick_experiment(name));
    EXPECT_FALSE(test::said(nominal, "stops growing")) << name;
  }
}

// A displacement sensor with 2 mm of noise and no stop (the stroke ends at 125 mm): the stop's
// band was 3 noise widths of the raw reading but compared with the 11-sample mean, whose noise is
// sqrt(11) = 3.3x smaller, and near 0.6 MPa, where the slope is small, it spanned about 48 kPa:
// "the contraction stops growing at 101.2 mm ... the muscle's stroke end or a hard stop", and the
// sine was mapped to 5..90.3 mm (x0.948; nominal top 96.5 mm). Neither now: no stop is said, and
// the reach's top is the nominal rig's within 3 noise widths of the mean.
TEST(Experiment, ANoisyDisplacementSensorIsNoStrokeEnd) {
  const ExperimentResult nominal = run_experiment(test::quick_experiment("gpi-pid"));
  ASSERT_TRUE(std::isfinite(nominal.reach_top_mm));
  const double noise_mm = 2.0, sigma_mean = noise_mm / std::sqrt(11.0);
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    ExperimentOptions o = test::quick_experiment("gpi-pid");
    o.rig.sensors.displacement_noise = noise_mm * 1e-3;
    o.seed = seed;
    const ExperimentResult r = run_experiment(o);
    EXPECT_FALSE(test::said(r, "stops growing")) << fmt::format("{}", fmt::join(r.messages, "\n"));
    EXPECT_GT(r.reach_top_mm, nominal.reach_top_mm - 3.0 * sigma_mean);
    ASSERT_EQ(r.reference_ranges.size(), 1u);
    EXPECT_GT(r.reference_ranges[0].max_mm, std::min(95.0, nominal.reach_top_mm) - 3.0 * sigma_mean);
  }
}

// A pressure sensor with 20 kPa of noise: the reach's top was the least contraction at the first
// raw pressure sample at or above 0.57 MPa, which a noise peak reaches early (90.8 mm against the
// nominal 96.5); it is now taken on the pressure's 11-sample mean, as the contraction's.
TEST(Experiment, PressureNoiseDoesNotShrinkTheReach) {
  const ExperimentResult nominal = run_experiment(test::quick_experiment("gpi-pid"));
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.sensors.pressure_noise = 20e3;  // [Pa]
  const ExperimentResult r = run_experiment(o);
  EXPECT_GT(r.reach_top_mm, nominal.reach_top_mm - 1.0);
  ASSERT_EQ(r.reference_ranges.size(), 1u);
  EXPECT_FALSE(r.reference_ranges[0].scaled);
}

// A light load (20 N, gravity 1 m/s^2) on 400 N s/m falls at about 50 mm/s with the muscle vented:
// gpi-pid's sine (5..95 mm, 0.2 Hz: up to pi 0.2 90 = 56.5 mm/s) descends faster, and the
// result says so with the numbers; a return spring's preload lets it fall fast enough (no
// note), and so does the nominal 20 kg.
TEST(Experiment, ADescentFasterThanTheLoadCanFallIsSaid) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.load.gravity = 1.0;
  const ExperimentResult light = run_experiment(o);
  const std::string v_max = fmt::format("where the terminal speed is {:.1f} mm/s", 20.0 * 1.0 / 400.0 * 1e3);
  EXPECT_TRUE(test::said(light, "descend faster than the vented load's terminal speed"))
      << fmt::format("{}", fmt::join(light.messages, "\n"));
  EXPECT_TRUE(test::said(light, v_max)) << v_max;
  const double v_ref = std::numbers::pi * 0.2 * 90.0;  // the sine's fastest descent [mm/s]
  EXPECT_TRUE(test::said(light, fmt::format("descends at {:.1f} mm/s", v_ref))) << v_ref;
  o.rig.load.spring_preload = 100.0;  // (20 + 100) / 400 = 300 mm/s
  EXPECT_FALSE(test::said(run_experiment(o), "descend faster"));
  EXPECT_FALSE(test::said(run_experiment(test::quick_experiment("gpi-pid")), "descend faster"));
}

// A horizontal rig with a 1 N return spring: the vented muscle, held by the creep element, falls
// only at the creep's pace below the upper part of its reach (docs/plant.md, "A weak return
// force"); the result says so, naming the reference that goes below the stall. The nominal rig
// gets no such note.
TEST(Experiment, AWeakReturnForceIsSaid) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.load.gravity = 0.0;
  o.rig.load.spring_preload = 1.0;
  const ExperimentResult weak = run_experiment(o);
  EXPECT_TRUE(test::said(weak, "the return force is weak against the creep element"))
      << fmt::format("{}", fmt::join(weak.messages, "\n"));
  EXPECT_TRUE(test::said(weak, "the references go below the stall (sine down to 5.0 mm)"))
      << fmt::format("{}", fmt::join(weak.messages, "\n"));
  // no loop gets the vented muscle down: the compensation is not below the baseline, and says so
  EXPECT_EQ(weak.not_below_baseline(), std::vector<std::string>{"compensated (sine)"}) << weak.table();
  EXPECT_EQ(weak.to_json()["status"], "not_below_baseline");
  EXPECT_NE(weak.table().find("NOT BELOW THE BASELINE: compensated (sine)"), std::string::npos);
  const ExperimentResult nominal = run_experiment(test::quick_experiment("gpi-pid"));
  EXPECT_FALSE(test::said(nominal, "weak against the creep"));
  EXPECT_TRUE(nominal.not_below_baseline().empty()) << nominal.table();
  EXPECT_EQ(nominal.to_json()["status"], "ok");
}

// Which runs are not below the baseline: hysteron's loops only (not the paper's faithful one), each
// against the baseline of its own reference; equal or NaN is not below.
TEST(Experiment, NotBelowBaselineNamesHysteronsLoopsAgainstTheirReferencesBaseline) {
  ExperimentResult r;
  const auto add = [&](const char* variant, const char* reference, double rms) {
    TrackingRun run;
    run.variant = variant;
    run.reference = reference;
    run.errors.rms_error_mm = rms;
    r.runs.push_back(run);
  };
  add("faithful", "sine", 5.0);       // above its baseline: the paper's loop, not counted
  add("compensated", "sine", 0.5);    // below
  add("learning", "sine", 2.0);       // equal: not below
  add("adaptive", "sine", std::nan(""));
  add("baseline", "sine", 2.0);
  add("compensated", "triangle", 1.5);  // below the triangle's baseline, above the sine's
  add("baseline", "triangle", 3.0);
  EXPECT_EQ(r.not_below_baseline(), (std::vector<std::string>{"learning (sine)", "adaptive (sine)"}));
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["status"], "not_below_baseline");
  EXPECT_EQ(j["not_below_baseline"], nlohmann::json({"learning (sine)", "adaptive (sine)"}));
  r.runs[2].errors.rms_error_mm = 1.999;
  r.runs[3].errors.rms_error_mm = 0.1;
  EXPECT_TRUE(r.not_below_baseline().empty());
  EXPECT_EQ(r.to_json()["status"], "ok");
  r.runs.erase(r.runs.begin() + 4);  // no baseline for the sine: nothing to compare with
  r.runs[1].errors.rms_error_mm = 9.0;
  EXPECT_TRUE(r.not_below_baseline().empty());
}

// A displacement sensor 30 times noisier than the nominal one (0.3 mm): every RMS the sensor
// reads has the noise in it, and the result says how wide it is, estimated from the
// identification run (within 15 % of the rig's 0.3 mm); the nominal 0.01 mm sensor gets no note.
TEST(Experiment, ADisplacementSensorsNoiseFloorIsSaid) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.sensors.displacement_noise = 3e-4;  // [m]
  const ExperimentResult noisy = run_experiment(o);
  std::string note;
  for (const std::string& m : noisy.messages)
    if (m.find("the displacement sensor's noise, about") != std::string::npos) note = m;
  ASSERT_FALSE(note.empty()) << fmt::format("{}", fmt::join(noisy.messages, "\n"));
  const double sigma_mm = std::stod(note.substr(note.find("about ") + 6));
  EXPECT_NEAR(sigma_mm, 0.3, 0.045) << note;
  for (const TrackingRun& run : noisy.runs) EXPECT_GT(run.errors.rms_error_mm, 0.9 * sigma_mm) << run.variant;
  EXPECT_FALSE(test::said(run_experiment(test::quick_experiment("gpi-pid")), "the displacement sensor's noise"));
}

// A supply of 5 bar absolute (0.4 MPa gauge) caps the muscle's pressure below the 0.6 MPa the
// loops may command: the identification run commands 0.6 MPa but measures at most about 0.4,
// so the reach's top is taken at 95 % of the pressure measured there, not at 0.57 MPa (which
// the run never reaches: the paper's 95 mm top was kept, the loops held the command at the
// limit and the compensated RMS was 9.1 mm). The nominal supply is not flagged.
TEST(Experiment, SupplyBelowTheCommandCapsTheReach) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.air.supply_pressure = 5e5;  // [Pa abs]
  const ExperimentResult r = run_experiment(o);
  const IdentificationRun& id = r.identification;
  const double p_meas_max = *std::max_element(id.pressure_mpa.begin(), id.pressure_mpa.end());
  EXPECT_GT(p_meas_max, 0.37);  // supply 0.5 MPa abs - 0.1 MPa atmosphere, less the regulator's drop
  EXPECT_LT(p_meas_max, 0.42);
  EXPECT_NEAR(r.reach_pressure_max_mpa, p_meas_max, 0.01);  // the 11-sample mean against the raw samples
  EXPECT_NEAR(r.reach_top_pressure_mpa, 0.95 * r.reach_pressure_max_mpa, 1e-12);
  double top = INFINITY;  // least contraction on the record at or above that pressure
  for (std::size_t k = 0; k < id.size(); ++k)
    if (id.pressure_mpa[k] >= r.reach_top_pressure_mpa) top = std::min(top, id.contraction_mm[k]);
  ASSERT_TRUE(std::isfinite(top));
  ASSERT_EQ(r.reference_ranges.size(), 1u);
  const ReferenceRange& rr = r.reference_ranges[0];
  EXPECT_TRUE(rr.scaled);
  EXPECT_TRUE(rr.reachable);
  EXPECT_NEAR(rr.max_mm, top, 0.5);
  EXPECT_LT(rr.max_mm, 80.0);  // well below the paper's 95 mm
  EXPECT_TRUE(test::said(r, "cap it below the 0.60 MPa"));
  EXPECT_FALSE(test::said(r, "pressure sensor's range ends"));
  for (const auto& run : r.runs)
    if (run.variant == "compensated") {
      EXPECT_LT(run.errors.rms_error_mm, 1.0) << "was 9.1 mm with the 95 mm top kept";
    }

  // A pressure sensor whose range ends at 0.5 MPa: its reading stops there while the regulator
  // delivers the 0.6 MPa commanded and the muscle goes on contracting. The reach is still kept
  // where the sensor sees (the models are fitted on its reading), but the note names the
  // sensor, not the supply (it named the supply, regulator or valves before 2026-11-29).
  o.rig = PamRigParams{};
  o.rig.sensors.pressure_range = 5e5;  // [Pa]
  const ExperimentResult s = run_experiment(o);
  EXPECT_NEAR(s.reach_pressure_max_mpa, 0.5, 0.005);
  EXPECT_NEAR(s.reach_top_pressure_mpa, 0.95 * s.reach_pressure_max_mpa, 1e-12);
  EXPECT_TRUE(test::said(s, "the pressure sensor's range ends below the actuator's pressure"));
  EXPECT_TRUE(test::said(s, "the muscle went on contracting with the command"));
  EXPECT_FALSE(test::said(s, "cap it below"));

  o.rig = PamRigParams{};
  const ExperimentResult n = run_experiment(o);
  EXPECT_NEAR(n.reach_top_pressure_mpa, 0.57, 1e-12);
  EXPECT_FALSE(test::said(n, "cap it below"));
}

// The supply drops to 4 bar absolute after the identification (--tracking-plant): the references
// fitted to the identified rig's reach need 0.6 MPa and the loops hold the command there. The
// saturation note names the level the pressure was capped at, the identified rig's reach, and
// that the rig changed (before 2026-11-29 it gave the generic wording only).
TEST(Experiment, SupplyDropAfterIdentificationNamesTheCap) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  PamRigParams tracking;
  tracking.air.supply_pressure = 4e5;  // [Pa abs]
  o.tracking_rig = tracking;
  const ExperimentResult r = run_experiment(o);
  EXPECT_TRUE(test::said(r, "the pressure reading levelled off at 0.3"));
  EXPECT_TRUE(test::said(r, "where the identification run reached 0.5"));
  EXPECT_TRUE(test::said(r, "identify on the rig as it is now"));
}

// A displacement sensor whose offset changes by 2 mm after the identification (--tracking-plant):
// the loops track the reading, so the true contraction is 2 mm off the reference while the
// errors, the sensor's, stay small (compensated 0.37 mm). A note gives the true errors and
// names the changed offset; the same offset on the identified rig too is the sensor's zero, not
// a hidden error (no note), and the nominal rig has none.
TEST(Experiment, DisplacementOffsetAfterIdentificationIsNamed) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  PamRigParams shifted;
  shifted.sensors.displacement_offset = 2e-3;  // [m]
  o.tracking_rig = shifted;
  const ExperimentResult r = run_experiment(o);
  EXPECT_TRUE(test::said(r, "the displacement sensor's reading hides part of the tracking error"));
  EXPECT_TRUE(test::said(r, "the reading 2.00"));
  EXPECT_TRUE(test::said(r, "its offset changed after the identification, 0.000 -> 2.000 mm"));
  for (const TrackingRun& run : r.runs)
    if (run.variant == "compensated") {
      EXPECT_LT(run.errors.rms_error_mm, 1.0);  // the sensor's: small
    }
  o.tracking_rig.reset();
  o.rig = shifted;  // the same sensor throughout: its zero, not an error
  EXPECT_FALSE(test::said(run_experiment(o), "hides part of the tracking error"));
  o.rig = PamRigParams{};
  EXPECT_FALSE(test::said(run_experiment(o), "hides part of the tracking error"));
}

// A pressure sensor that reads 60 kPa low tops out below the commands like a capped supply, and
// was named as one ("the supply, regulator or valves cap it"). The reading sits that far below
// the command all along the run, which a cap does not: the note names the sensor. A supply of
// 5 bar absolute (a cap at 0.4 MPa) keeps the cap's note.
TEST(Experiment, APressureSensorThatReadsLowIsNotNamedAsACap) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.sensors.pressure_offset = -60e3;
  const ExperimentResult low = run_experiment(o);
  EXPECT_TRUE(test::said(low, "a pressure sensor that reads low (an offset: zero it at atmospheric pressure)"));
  EXPECT_FALSE(test::said(low, "the supply, regulator or valves cap it"));
  o.rig = PamRigParams{};
  o.rig.air.supply_pressure = 5e5;
  const ExperimentResult capped = run_experiment(o);
  EXPECT_TRUE(test::said(capped, "the supply, regulator or valves cap it"));
  EXPECT_FALSE(test::said(capped, "a pressure sensor that reads low"));
}

// A --tracking-plant that differs only in what the experiment's actuation never reads (the
// valves' PWM timing for gpi-pid, which drives the regulator) is no changed rig: the audit of
// 2026-11-29 saw "differs in 2 parameter(s) ... not re-tuned" on bit-identical results. It
// is named as such; a parameter the regulator does read is a changed rig.
TEST(Experiment, TrackingRigChangedOnlyWhereTheActuationDoesNotReadIsNoChange) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  PamRigParams other;
  other.valves.pwm_frequency = 50.0;
  other.valves.on_delay = other.valves.off_delay = 2e-3;
  o.tracking_rig = other;
  const ExperimentResult r = run_experiment(o);
  EXPECT_FALSE(test::said(r, "which differs from the identified one (--plant) in")) << "a changed rig named";
  EXPECT_TRUE(test::said(r, "only in parameters this experiment does not drive (valves.off_delay: 0.001 -> 0.002; "
                            "valves.on_delay: 0.001 -> 0.002; valves.pwm_frequency: 200.0 -> 50.0)"));
  other.regulator.time_constant = 0.1;
  o.tracking_rig = other;
  const ExperimentResult changed = run_experiment(o);
  EXPECT_TRUE(test::said(changed, "which differs from the identified one (--plant) in 1 parameter(s): "
                                  "regulator.time_constant: 0.05 -> 0.1;"));
  EXPECT_FALSE(test::said(changed, "only in parameters this experiment does not drive"));
}

// A muscle twice as long (1 m) contracts twice as far per kPa: the paper's 5..95 mm sinusoid
// needs only about 0.34 MPa on the ascent, and the paper's 0..0.6 MPa identification input
// spends half its range where the loops never go. hysteron's model is then identified on
// the inputs scaled to that pressure plus twice the reach's headroom (0.06 MPa); the nominal
// muscle, whose 95 mm top needs about 0.56 MPa, keeps the paper's input.
TEST(Experiment, ModelIsIdentifiedOverThePressureTheReferencesNeed) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.muscle.rest_length = 1.0;
  o.rig.sensors.displacement_range = 0.3;
  const ExperimentResult r = run_experiment(o);
  double p_need = 0.0;  // the most pressure at which the record's contraction was at or below 95 mm
  for (std::size_t k = 0; k < r.identification.pressure_mpa.size(); ++k)
    if (r.identification.contraction_mm[k] <= 95.0) p_need = std::max(p_need, r.identification.pressure_mpa[k]);
  EXPECT_GT(p_need, 0.25);
  EXPECT_LT(p_need, 0.45);
  EXPECT_NEAR(r.model_id_top_mpa, p_need + 0.06, 0.01);  // 11-sample means against raw samples
  EXPECT_TRUE(test::said(r, "identified on the paper's pressure inputs scaled"));
  // the paper's own fit stays on the paper's input (the faithful variant is as published)
  const std::vector<double>& paper_command = r.identification.pressure_command_mpa;
  EXPECT_GT(*std::max_element(paper_command.begin(), paper_command.end()), 0.59);
  for (const auto& run : r.runs)
    if (run.variant == "compensated") {
      EXPECT_LT(run.errors.rms_error_mm, 1.0) << "1.150 mm with the model identified over 0..0.6 MPa";
    }

  o.rig = PamRigParams{};
  const ExperimentResult n = run_experiment(o);
  EXPECT_EQ(n.model_id_top_mpa, 0.0);
}

// A 0.2 m muscle strokes 2.5x less per kPa than the 0.5 m one: mpi-openloop's identification
// input, 0..0.5 MPa, never lifts it to the references' 40 mm top, so the rig's reach there was
// unknown and the model was extrapolated above the run (compensated max 2.51 / 2.62 mm). The
// reach and hysteron's model now come from the input extended to the actuator's 0.6 MPa; the
// paper's model stays on the paper's run.
TEST(Experiment, IdentificationIsExtendedToTheActuatorsTopWhereThePapersInputFallsShort) {
  ExperimentOptions o = test::quick_experiment("mpi-openloop");
  o.rig.muscle.rest_length = 0.2;
  const ExperimentResult r = run_experiment(o);
  EXPECT_TRUE(test::said(r, "scaled to 0.600 MPa, the actuator's top"));
  // the paper's own run, the one the faithful variant's model is fitted on, is unchanged
  const std::vector<double>& paper_command = r.identification.pressure_command_mpa;
  EXPECT_LE(*std::max_element(paper_command.begin(), paper_command.end()), 0.5 + 1e-12);
  double reached = 0.0;  // the paper's run's most contraction
  for (double x : r.identification.contraction_mm) reached = std::max(reached, x);
  EXPECT_LT(reached, 40.0);
  EXPECT_GT(r.model_id_top_mpa, 0.5);
  ASSERT_TRUE(std::isfinite(r.reach_top_mm)) << "the reach at the actuator's top was not measured";
  EXPECT_GT(r.reach_top_mm, reached);
  ASSERT_EQ(r.reference_ranges.size(), 2u);
  for (const ReferenceRange& rr : r.reference_ranges) EXPECT_LE(rr.max_mm, r.reach_top_mm + 1e-9);
  int compensated = 0;
  for (const auto& run : r.runs)
    if (run.variant == "compensated") {
      ++compensated;
      // the paper's maxima, 1.29 (triangle) and 1.38 mm (sine), on a muscle it was not run on
      EXPECT_LT(run.errors.max_error_mm, 1.29) << run.reference << ": 2.51 / 2.62 mm extrapolated";
    }
  EXPECT_EQ(compensated, 2);

  // the run hysteron's model was fitted on, the paper's input extended to 0.6 MPa, is kept
  const IdentificationRun& ext = r.model_identification;
  ASSERT_FALSE(ext.empty());
  EXPECT_EQ(ext.pressure_command_mpa.size(), ext.size());
  EXPECT_EQ(ext.contraction_mm.size(), ext.size());
  EXPECT_NEAR(*std::max_element(ext.pressure_command_mpa.begin(), ext.pressure_command_mpa.end()), 0.6, 1e-9);
  EXPECT_GT(*std::max_element(ext.contraction_mm.begin(), ext.contraction_mm.end()), reached);

  o.rig = PamRigParams{};
  const ExperimentResult n = run_experiment(o);
  EXPECT_FALSE(test::said(n, "the actuator's top (the paper's model"));
  EXPECT_GT(n.model_id_top_mpa, 0.0);
  EXPECT_LT(n.model_id_top_mpa, 0.5);  // scaled down, as before
  const IdentificationRun& scaled = n.model_identification;
  ASSERT_FALSE(scaled.empty());
  EXPECT_NEAR(*std::max_element(scaled.pressure_command_mpa.begin(), scaled.pressure_command_mpa.end()),
              n.model_id_top_mpa, 1e-9);

  // written as model_identification.csv and read back; removed where a later run into the same
  // directory fitted its model on the paper's run
  test::TempDir dir;
  const std::string out = dir.file("out");
  n.write(out);
  ASSERT_TRUE(std::filesystem::exists(dir.file("out/model_identification.csv")));
  const ExperimentResult back = report::read_experiment_dir(out);
  const IdentificationRun& read = back.model_identification;
  ASSERT_EQ(read.size(), scaled.size());
  for (std::size_t k = 0; k < scaled.size(); k += 997) {
    EXPECT_NEAR(read.t[k], scaled.t[k], 1e-12);
    EXPECT_NEAR(read.pressure_command_mpa[k], scaled.pressure_command_mpa[k], 1e-12);
    EXPECT_NEAR(read.pressure_mpa[k], scaled.pressure_mpa[k], 1e-12);
    EXPECT_NEAR(read.contraction_mm[k], scaled.contraction_mm[k], 1e-12);
  }
  ExperimentResult on_paper_run = n;
  on_paper_run.model_identification = {};
  on_paper_run.write(out);
  EXPECT_FALSE(std::filesystem::exists(dir.file("out/model_identification.csv")));
  EXPECT_TRUE(report::read_experiment_dir(out).model_identification.empty());
  EXPECT_TRUE(ExperimentResult::is_output_file("model_identification.csv"));
}

// A displacement sensor reading 10 mm high: the muscle at rest reads 10 mm, so the paper's
// 5 mm bottom is out of reach (venting cannot go below rest). The reference is mapped onto
// 10..95 mm (its top unchanged, within reach), and the compensated loop tracks it.
TEST(Experiment, ReferenceBelowTheRestPositionIsMappedUp) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.rig.sensors.displacement_offset = 0.010;
  const ExperimentResult r = run_experiment(o);
  ASSERT_EQ(r.reference_ranges.size(), 1u);
  const ReferenceRange& rr = r.reference_ranges[0];
  EXPECT_TRUE(rr.scaled);
  EXPECT_NEAR(r.reach_min_mm, 10.0, 0.1);
  EXPECT_NEAR(rr.min_mm, r.reach_min_mm, 1e-9);
  EXPECT_NEAR(rr.max_mm, 95.0, 1e-9);
  for (const auto& run : r.runs) {
    EXPECT_GE(*std::min_element(run.reference_mm.begin(), run.reference_mm.end()), rr.min_mm - 1e-6) << run.variant;
    if (run.variant == "compensated") { EXPECT_LT(run.errors.rms_error_mm, 1.0); }  // 1.48 mm before the mapping
  }
}

// The rig starts vented. mpi-openloop's references start at once, at rest: scored from the
// first sample, the loop spent its first 0.1 s filling the muscle to lift-off while the
// triangle rose at 16 mm/s (1.367 mm, its largest error). They are now preceded by an
// unscored 1.5 s hold of their first value, which fills the muscle first; gpi-pid's sine
// keeps its unscored warm-up period and gets no hold.
TEST(Experiment, ReferencesWithoutAWarmUpStartAfterAPreRoll) {
  const ExperimentResult r = run_experiment(test::quick_experiment("mpi-openloop"));
  bool seen = false;
  for (const auto& run : r.runs) {
    ASSERT_GT(run.t.size(), 2000u) << run.variant;
    const double tc = run.t[1] - run.t[0];
    const auto k0 = static_cast<std::size_t>(std::lround(run.scored_from_s / tc));
    EXPECT_NEAR(run.scored_from_s, 1.5, 1e-9) << run.variant << " " << run.reference;
    ASSERT_LT(k0, run.t.size());
    for (std::size_t k = 0; k <= k0; ++k) ASSERT_EQ(run.reference_mm[k], run.reference_mm[0]) << k;
    EXPECT_GT(run.reference_mm[k0 + 1000], run.reference_mm[k0] + 1.0) << "the reference starts after the hold";
    EXPECT_LT(run.pressure_mpa[0], 0.01) << "the rig starts vented";
    if (run.variant != "compensated" || run.reference != "triangle") continue;
    seen = true;
    EXPECT_GT(run.pressure_mpa[k0], 0.05) << "the hold filled the muscle towards lift-off";
    // the scored errors are those from k0 on, and the largest of them is not at the start
    double worst = 0.0;
    std::size_t at = 0;
    for (std::size_t k = k0; k < run.t.size(); ++k)
      if (std::abs(run.reference_mm[k] - run.measured_mm[k]) > worst)
        worst = std::abs(run.reference_mm[k] - run.measured_mm[k]), at = k;
    EXPECT_NEAR(run.errors.max_error_mm, worst, 1e-9);
    EXPECT_GT(run.t[at] - run.t[k0], 0.3) << "largest error " << worst << " mm right after the start";
    EXPECT_LT(worst, 1.29) << "the paper's maximum error; 1.367 mm from a cold start";
  }
  EXPECT_TRUE(seen);

  ExperimentOptions g = test::quick_experiment("gpi-pid");
  const ExperimentResult gr = run_experiment(g);
  for (const auto& run : gr.runs) EXPECT_NEAR(run.scored_from_s, 5.0, 1e-9) << "gpi-pid's warm-up period";
}

// A displacement sensor zeroed 3 mm above the muscle's rest reads 0 (its limit) for every
// contraction below 3 mm, so mpi-openloop's references, which start at 0, kept the muscle in a
// region the sensor cannot see. The clipped record is detected from the record alone, said,
// and the reach's bottom kept 3 noise widths above the limit, where the sensor sees the
// muscle; the nominal sensor, whose noise also reaches 0 at rest (about half its rest samples
// read 0), is not flagged. What it does not fix (docs/control.md section 5): the loop starts
// from rest, below the sensor's zero, where its error is at most that margin.
TEST(Experiment, ClippedDisplacementSensorIsDetectedAndKeptOutOfTheReach) {
  ExperimentOptions o = test::quick_experiment("mpi-openloop");
  o.rig.sensors.displacement_offset = -0.003;
  const ExperimentResult r = run_experiment(o);
  EXPECT_TRUE(test::said(r, "the displacement sensor clips"));
  ASSERT_EQ(r.reference_ranges.size(), 2u);
  for (const ReferenceRange& rr : r.reference_ranges) {
    EXPECT_TRUE(rr.scaled) << rr.reference;
    EXPECT_GT(rr.min_mm, 0.02) << rr.reference;  // 3 noise widths above the sensor's 0
    EXPECT_LT(rr.min_mm, 0.2) << rr.reference;
    EXPECT_NEAR(rr.max_mm, 40.0, 1e-9) << rr.reference;
  }
  const ExperimentResult n = run_experiment(test::quick_experiment("mpi-openloop"));
  EXPECT_FALSE(test::said(n, "clips"));
  for (const ReferenceRange& rr : n.reference_ranges) EXPECT_FALSE(rr.scaled) << rr.reference;
  // The model is fitted as censored data (FitOptions::censor_passes): the true error (the
  // reference against the actual contraction in the sensor's frame, actual - 3 mm), over the
  // scored part of each compensated run, is within 2.5x the nominal sensor's RMS (fitted to the
  // limit as recorded: 0.306 and 0.738 mm, the sine's 2.9x; censored 0.247 and 0.521 mm).
  EXPECT_TRUE(std::any_of(r.best_fit.warnings.begin(), r.best_fit.warnings.end(),
                          [](const std::string& w) { return test::has(w, "fitted as censored data"); }));
  for (const char* ref : {"triangle", "sine"}) {
    auto true_rms = [&](const ExperimentResult& e, double offset_mm) {
      for (const TrackingRun& t : e.runs)
        if (t.variant == "compensated" && t.reference == ref) {
          double s2 = 0.0;
          std::size_t m = 0;
          for (std::size_t k = 0; k < t.t.size(); ++k)
            if (t.t[k] >= t.scored_from_s) {
              const double d = t.reference_mm[k] - (t.actual_mm[k] + offset_mm);
              s2 += d * d;
              ++m;
            }
          return std::sqrt(s2 / static_cast<double>(m));
        }
      return std::numeric_limits<double>::infinity();
    };
    EXPECT_LT(true_rms(r, -3.0), 2.5 * true_rms(n, 0.0)) << ref;
  }
}

// A displacement sensor with 1 um of noise (below its 2.3 um step), zeroed at the muscle's rest:
// most rest samples read exactly 0, the record is taken as clipped there, and the bottom kept 3
// noise widths (0.004 mm) above it: "reference triangle mapped onto the rig's reach: 0.0..40.0 mm
// instead of the published 0.0..40.0 mm (scale 1.000)", scaled. A change the record does not
// resolve (3 noise widths of the 11-sample mean, at least the sensor's step) maps nothing; the
// 3 mm offset above still maps (ClippedDisplacementSensorIsDetectedAndKeptOutOfTheReach).
TEST(Experiment, AMappingTheRecordDoesNotResolveIsNotMade) {
  ExperimentOptions o = test::quick_experiment("mpi-openloop");
  o.rig.sensors.displacement_noise = 1e-6;
  const ExperimentResult r = run_experiment(o);
  ASSERT_EQ(r.reference_ranges.size(), 2u);
  for (const ReferenceRange& rr : r.reference_ranges) {
    EXPECT_FALSE(rr.scaled) << rr.reference;
    EXPECT_TRUE(rr.reachable) << rr.reference;
    EXPECT_EQ(rr.min_mm, rr.paper_min_mm) << rr.reference;
  }
  EXPECT_FALSE(test::said(r, "mapped onto")) << fmt::format("{}", fmt::join(r.messages, "\n"));
}

// ---- the actuator's limit is the rig's (muscle.max_pressure, regulator.max_command) --------

namespace {

// The most and least pressure command of every logged sample of a result: the identification
// runs (the paper's and hysteron's model's) and every tracking run, learning included [MPa].
std::pair<double, double> command_range(const ExperimentResult& r) {
  double lo = INFINITY, hi = -INFINITY;
  const auto see = [&](const std::vector<double>& v) {
    for (double p : v) lo = std::min(lo, p), hi = std::max(hi, p);
  };
  see(r.identification.pressure_command_mpa);
  see(r.model_identification.pressure_command_mpa);
  for (const TrackingRun& run : r.runs) see(run.pressure_command_mpa);
  return {lo, hi};
}

}  // namespace

// A muscle rated 0.4 MPa: no pressure command of any run of the three experiments leaves
// 0..0.4 MPa (before, every one ran up to the fixed 0.6 MPa), the relays switched inside it,
// the loops' limits are it, and the result says so. The papers' identification inputs (up to
// 0.6 MPa) are scaled to it.
TEST(Experiment, MuscleRatedBelowThePapersRangeIsNeverCommandedAbove) {
  for (const char* name : {"gpi-pid", "mpi-openloop", "mpi-pwm"}) {
    SCOPED_TRACE(name);
    ExperimentOptions o = test::quick_experiment(name, 2);
    o.adaptive = true;
    o.rig.muscle.max_pressure = 400e3;  // [Pa]
    const ExperimentResult r = run_experiment(o);
    EXPECT_EQ(r.pressure_limit_mpa, 0.4);
    const auto [lo, hi] = command_range(r);
    EXPECT_GE(lo, 0.0);
    EXPECT_LE(hi, 0.4);
    EXPECT_GT(hi, 0.3);  // the range is used, not shrunk further
    for (const char* v : {"faithful", "compensated", "learning", "adaptive", "baseline"})
      EXPECT_TRUE(std::any_of(r.runs.begin(), r.runs.end(), [&](const TrackingRun& t) { return t.variant == v; })) << v;
    // the relays switched inside the limit
    EXPECT_LE(r.dynamics.position_relay_level_mpa + r.dynamics.position_relay_amplitude_mpa, 0.4 + 1e-12);
    EXPECT_LE(r.dynamics.relay_level_mpa, 0.4);
    // the loops' own limits (result.json "controller")
    for (const TrackingRun& run : r.runs) {
      EXPECT_EQ(run.controller.feedforward.pressure_limits.hi, 0.4) << run.variant;
      if (run.controller.pid) {
        EXPECT_LE(run.controller.pid->out_max, 0.4) << run.variant;
      }
    }
    EXPECT_TRUE(test::said(r, "the actuator's limit is 0..0.400 MPa")) << name;
    EXPECT_TRUE(test::said(r, "muscle.max_pressure = 400 kPa")) << name;
    // the paper's identification input, 0.6 MPa at its top for gpi-pid and mpi-pwm, scaled to the limit
    if (std::string(name) != "mpi-openloop") {
      const std::vector<double>& id = r.identification.pressure_command_mpa;
      EXPECT_NEAR(*std::max_element(id.begin(), id.end()), 0.4, 1e-12);
    }
  }
}

// A regulator whose command range ends at 0.3 MPa: the regulator experiments never command
// more (before, the identification ran to 0.6 MPa and the rig clipped it without a word); the
// valves of mpi-pwm have no command range, so its limit stays the muscle's.
TEST(Experiment, RegulatorCommandRangeBoundsTheRegulatorExperiments) {
  for (const char* name : {"gpi-pid", "mpi-openloop"}) {
    SCOPED_TRACE(name);
    ExperimentOptions o = test::quick_experiment(name);
    o.rig.regulator.max_command = 300e3;  // [Pa]
    const ExperimentResult r = run_experiment(o);
    EXPECT_EQ(r.pressure_limit_mpa, 0.3);
    const auto [lo, hi] = command_range(r);
    EXPECT_GE(lo, 0.0);
    EXPECT_LE(hi, 0.3);
    EXPECT_TRUE(test::said(r, "regulator.max_command = 300 kPa")) << name;
  }
  PamRigParams rig;
  rig.regulator.max_command = 300e3;
  EXPECT_EQ(pressure_command_limit(rig, Actuation::regulator), 300e3);
  EXPECT_EQ(pressure_command_limit(rig, Actuation::switching_valves), 600e3);
  rig.muscle.max_pressure = 250e3;
  EXPECT_EQ(pressure_command_limit(rig, Actuation::regulator), 250e3);
  EXPECT_EQ(pressure_command_limit(rig, Actuation::switching_valves), 250e3);
}

// A tracking rig (--tracking-plant) rated lower than the identified one bounds every run too.
TEST(Experiment, TrackingRigRatedLowerBoundsTheRun) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  PamRigParams tracking;
  tracking.muscle.max_pressure = 450e3;
  o.tracking_rig = tracking;
  const ExperimentResult r = run_experiment(o);
  EXPECT_EQ(r.pressure_limit_mpa, 0.45);
  const auto [lo, hi] = command_range(r);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 0.45);
  EXPECT_TRUE(test::said(r, "the tracking rig's muscle.max_pressure = 450 kPa"));
}

// An impossible rating is refused, naming the key, from the rig file and from the options.
TEST(Experiment, ImpossibleMuscleRatingIsRefusedNamingTheKey) {
  for (const char* text : {R"({"muscle":{"max_pressure":0}})", R"({"muscle":{"max_pressure":-4e5}})",
                           R"({"muscle":{"max_pressure":"6 bar"}})"}) {
    const std::string what =
        test::error_of([&] { (void)rig_params_from_json(nlohmann::json::parse(text), "rig.json"); });
    EXPECT_NE(what.find("rig.json.muscle.max_pressure"), std::string::npos) << text << ": " << what;
  }
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    ExperimentOptions o = test::quick_experiment("gpi-pid");
    o.rig.muscle.max_pressure = bad;
    const std::string what = test::error_of([&] { (void)run_experiment(o); });
    EXPECT_NE(what.find("muscle.max_pressure"), std::string::npos) << bad << ": " << what;
    o = test::quick_experiment("gpi-pid");
    o.tracking_rig = PamRigParams{};
    o.tracking_rig->muscle.max_pressure = bad;
    const std::string tracking = test::error_of([&] { (void)run_experiment(o); });
    EXPECT_NE(tracking.find("tracking rig.muscle.max_pressure"), std::string::npos) << bad << ": " << tracking;
  }
  // a load the muscle cannot lift even at its rating is refused, naming the keys (the position
  // relay failed with a message that did not name the load)
  for (const bool spring : {false, true}) {
    ExperimentOptions o = test::quick_experiment("gpi-pid");
    (spring ? o.rig.load.spring_preload : o.rig.load.mass) = spring ? 5000.0 : 600.0;
    const std::string what = test::error_of([&] { (void)run_experiment(o); });
    EXPECT_NE(what.find("the muscle cannot lift its load"), std::string::npos) << what;
    EXPECT_NE(what.find(spring ? "rig.load.spring_preload = 5000 N" : "rig.load.mass x rig.load.gravity = 5886.0 N"),
              std::string::npos)
        << what;
  }
  // a rig without a return force (a horizontal rig: load.gravity = 0) is refused, naming the key
  for (const bool tracking : {false, true}) {
    ExperimentOptions o = test::quick_experiment("mpi-pwm");
    if (tracking) o.tracking_rig = PamRigParams{};
    (tracking ? *o.tracking_rig : o.rig).load.gravity = 0.0;
    const std::string what = test::error_of([&] { (void)run_experiment(o); });
    EXPECT_NE(what.find(tracking ? "tracking rig.load.gravity = 0 with no return spring"
                                 : "rig.load.gravity = 0 with no return spring"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("nothing extends the muscle"), std::string::npos) << what;
  }
  // ... and accepted with a return spring, either part of it (P5)
  for (const bool preload : {false, true}) {
    ExperimentOptions o = test::quick_experiment("mpi-pwm");
    o.rig.load.gravity = 0.0;
    (preload ? o.rig.load.spring_preload : o.rig.load.spring_rate) = 100.0;
    EXPECT_NO_THROW(o.validate()) << preload;
  }
  // written and read back
  PamRigParams p;
  p.muscle.max_pressure = 8e5;
  EXPECT_EQ(rig_params_from_json(rig_params_to_json(p), "rig").muscle.max_pressure, 8e5);
  EXPECT_EQ(rig_params_to_json(PamRigParams{})["muscle"]["max_pressure"].get<double>(), 600e3);
}

// The user's own reference (--reference): a sine at another frequency and amplitude than the
// paper's, through every mechanism of the paper's (reach, gain trial, learning), named by its kind.
TEST(Experiment, AUserSineIsTrackedInsteadOfThePapers) {
  ExperimentOptions o = test::quick_experiment("gpi-pid", 2);
  o.references = parse_references({"sine:amplitude=15,offset=50,frequency=0.5,periods=2"});
  const ExperimentResult r = run_experiment(o);
  ASSERT_EQ(r.reference_ranges.size(), 1u);
  EXPECT_EQ(r.reference_ranges[0].reference, "sine");
  EXPECT_NEAR(r.reference_ranges[0].min_mm, 35.0, 1e-6);
  EXPECT_NEAR(r.reference_ranges[0].max_mm, 65.0, 1e-6);
  const TrackingRun* comp = nullptr;
  const TrackingRun* base = nullptr;
  const TrackingRun* learning = nullptr;
  for (const TrackingRun& run : r.runs) {
    EXPECT_EQ(run.reference, "sine");
    EXPECT_TRUE(std::isfinite(run.errors.rms_error_mm) && std::isfinite(run.errors.max_error_mm)) << run.variant;
    for (double p : run.pressure_command_mpa) {
      ASSERT_GE(p, 0.0) << run.variant;
      ASSERT_LE(p, r.pressure_limit_mpa) << run.variant;
    }
    if (run.variant == "compensated") comp = &run;
    if (run.variant == "baseline") base = &run;
    if (run.variant == "learning") learning = &run;
  }
  ASSERT_TRUE(comp && base && learning);
  EXPECT_LT(comp->errors.rms_error_mm, base->errors.rms_error_mm);
  // the tracked reference is the user's: 2 periods of 2 s after the 1.5 s pre-roll, 35..65 mm
  EXPECT_NEAR(comp->t.size() * r.control_period_s, 1.5 + 4.0, 1e-6);
  EXPECT_NEAR(*std::max_element(comp->reference_mm.begin(), comp->reference_mm.end()), 65.0, 1e-6);
  EXPECT_EQ(learning->periods.size(), 2u);
  // the learning run starts after the same pre-roll (the sine starts at 35 mm, not at rest): its
  // first period, before anything is learnt, is near the compensated loop's (its PID is the
  // learning rule's, lower), not the fill from rest (6.7 mm RMS at 0.5 Hz from 30 mm)
  EXPECT_NEAR(learning->t.size() * r.control_period_s, 1.5 + 4.0, 1e-6);
  EXPECT_LT(learning->periods[0].rms_error_mm, 3.0 * comp->errors.rms_error_mm);
  EXPECT_LT(learning->errors.rms_error_mm, base->errors.rms_error_mm);
  ASSERT_EQ(r.gain_trials.size(), 1u);
  EXPECT_EQ(r.gain_trials[0].reference, "sine");
  // no paper tracked it: no published figures
  ASSERT_EQ(r.published.errors.size(), 1u);
  EXPECT_EQ(r.published.errors[0].reference, "sine");
  EXPECT_TRUE(std::isnan(r.published.errors[0].rms_error_mm));
  EXPECT_NE(r.table().find(fmt::format("  {:<10} {:<12} {:>9} {:>9} {:>9}\n", "sine", "published", "-", "-", "-")),
            std::string::npos)
      << r.table();
}

// A record as the reference (file:PATH): not periodic, so no learning run, and the result says why.
TEST(Experiment, ANonPeriodicFileReferenceRunsWithoutLearning) {
  test::TempDir dir;
  std::string csv = "t [s],x [mm]\n";
  for (int k = 0; k <= 300; ++k) {  // 3 s at 10 ms: a ramp from 30 to 60 mm and a hold
    const double t = 0.01 * k;
    csv += fmt::format("{},{}\n", t, t < 2.0 ? 30.0 + 15.0 * t : 60.0);
  }
  const std::string path = dir.write("ref.csv", csv);
  ExperimentOptions o = test::quick_experiment("gpi-pid", 2);
  o.references = parse_references({"file:" + path + ",name=ramp"});
  const ExperimentResult r = run_experiment(o);
  bool said = false;
  for (const auto& m : r.messages) said = said || m.find("learning (ramp) not run: the reference is not periodic") == 0;
  EXPECT_TRUE(said) << fmt::format("{}", fmt::join(r.messages, "\n"));
  ASSERT_FALSE(r.runs.empty());
  for (const TrackingRun& run : r.runs) {
    EXPECT_EQ(run.reference, "ramp");
    EXPECT_NE(run.variant, "learning");
    EXPECT_TRUE(std::isfinite(run.errors.rms_error_mm));
  }
  // interpolated at 1 ms, after the pre-roll: 1.5 s + 3.001 s
  EXPECT_EQ(r.runs[0].t.size(), 1500u + 3001u);
  EXPECT_NEAR(r.runs[0].reference_mm[1500 + 1000], 45.0, 1e-9);
}

// The limit-cycle guard restarts at the end of a pre-roll: a user sine from 50 mm fills the muscle
// from rest during it, no ringing of the loop; the guard cut the gains then (to x0.63, "the gain
// trial's gains are too high for this reference") and they stayed cut over the scored part.
TEST(Experiment, TheGuardRestartsAfterAUserReferencesPreRoll) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.model = FitModel::gpi;
  o.references = parse_references({"sine:amplitude=5,offset=55,frequency=0.2,periods=2"});
  const ExperimentResult r = run_experiment(o);
  bool compensated = false;
  for (const TrackingRun& run : r.runs) {
    if (run.variant != "compensated") continue;
    compensated = true;
    EXPECT_EQ(run.controller.guard_cuts, 0u);
    EXPECT_EQ(run.controller.guard_final_scale, 1.0);
    ASSERT_TRUE(run.controller.pid.has_value());
    EXPECT_TRUE(run.controller.pid->guard.enabled());  // the guard is on, and restarted after the pre-roll
  }
  EXPECT_TRUE(compensated);
  for (const auto& m : r.messages) EXPECT_EQ(m.find("limit-cycle guard cut"), std::string::npos) << m;
}

// A file reference's units: a header's unit that is no time (or no length) is refused; time_unit=
// and unit= give them (checked against the header's); a column whose name suggests a unit but
// gives none is refused; a time column's unit from nowhere is read as s with a note saying so.
TEST(Experiment, FileReferenceUnitsAreGivenOrSaid) {
  test::TempDir dir;
  const auto message = [](const std::string& spec) {
    try {
      (void)parse_references({spec});
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const auto record = [&](const std::string& name, const std::string& header, double dt, double scale) {
    std::string csv = header + "\n";
    for (int k = 0; k <= 40; ++k) csv += fmt::format("{},{}\n", k * dt, scale * (40.0 + 10.0 * std::sin(0.2 * k)));
    return dir.write(name, csv);
  };
  const std::string ms = record("ms.csv", "time_ms,x_mm", 10.0, 1.0);  // 0.4 s in ms, no unit in brackets
  EXPECT_NE(message("file:" + ms).find("the time column time_ms of " + ms + " gives no unit but its name suggests ms"),
            std::string::npos)
      << message("file:" + ms);
  const auto in_ms = parse_references({"file:" + ms + ",time_unit=ms"});
  EXPECT_NEAR(in_ms[0].t_s.back(), 0.4, 1e-12);
  EXPECT_TRUE(in_ms[0].note.empty()) << in_ms[0].note;
  EXPECT_NE(message("file:" + ms + ",time_unit=min").find("time_unit = \"min\": expected s, ms or us"),
            std::string::npos);
  // a header's unit that is no time unit; one that disagrees with time_unit=
  const std::string t_mm = record("t_mm.csv", "t [mm],x [mm]", 0.01, 1.0);
  EXPECT_NE(message("file:" + t_mm).find("the time column 0 of " + t_mm + " is in \"mm\", not a time unit"),
            std::string::npos)
      << message("file:" + t_mm);
  const std::string t_s = record("t_s.csv", "t [s],x [mm]", 0.01, 1.0);
  EXPECT_NE(message("file:" + t_s + ",time_unit=ms").find("time_unit=ms but " + t_s + " gives the time column 0 the "
                                                          "unit \"s\""),
            std::string::npos)
      << message("file:" + t_s + ",time_unit=ms");
  EXPECT_TRUE(parse_references({"file:" + t_s + ",time_unit=s"})[0].note.empty());
  // the contraction in metres: named so without a unit, refused; unit=m reads it
  const std::string m = record("m.csv", "t,x_m", 0.01, 1e-3);
  EXPECT_NE(message("file:" + m).find("the contraction column x_m of " + m + " gives no unit but its name suggests m"),
            std::string::npos)
      << message("file:" + m);
  const auto in_m = parse_references({"file:" + m + ",unit=m"});
  EXPECT_NEAR(in_m[0].x_mm[0], 40.0, 1e-9);
  EXPECT_NE(message("file:" + t_s + ",unit=m").find("unit=m but " + t_s + " gives the contraction column 1 the unit"),
            std::string::npos);
  // a name saying s ("t_s", hysteron's own tracking CSVs) gives s: no note
  EXPECT_TRUE(parse_references({"file:" + record("t_s_name.csv", "t_s,x", 0.01, 1.0)})[0].note.empty());
  // no unit from anywhere, no name suggesting one: s, and a note with the duration and samples
  const auto plain = parse_references({"file:" + m + ",unit=m,name=plain"});
  EXPECT_EQ(plain[0].note, fmt::format("--reference 'file:{},unit=m,name=plain': 41 samples over 0.4 s: time read as s "
                                       "(its header gives no unit; time_unit=ms if it is not)",
                                       m));
}

TEST(Experiment, UserReferenceSpecsAreCheckedNamingTheKey) {
  const auto message = [](const std::vector<std::string>& specs) {
    try {
      (void)parse_references(specs);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({"sine:amplitude=10,offset=50,frequency=1,periods=2,phase=3"}).find("unknown key \"phase\""),
            std::string::npos);
  EXPECT_NE(message({"sine:amplitude=10,offset=50,periods=2"}).find("missing key \"frequency\""), std::string::npos);
  EXPECT_NE(message({"sine:amplitude=10,offset=50,frequency=0,periods=2"}).find("frequency = 0 Hz must be > 0"),
            std::string::npos);
  EXPECT_NE(message({"sine:amplitude=-1,offset=50,frequency=1,periods=2"}).find("amplitude = -1 mm must be >= 0"),
            std::string::npos);
  EXPECT_NE(message({"triangle:amplitude=nan,offset=50,frequency=1,periods=2"}).find("amplitude = \"nan\" is not a "
                                                                                      "finite number"),
            std::string::npos);
  EXPECT_NE(message({"triangle:amplitude=1,offset=50,frequency=1,periods=0"}).find("periods = 0"), std::string::npos);
  EXPECT_NE(message({"sine:amplitude=1,offset=50,frequency=1,periods=1,"}).find("empty KEY=VALUE"), std::string::npos);
  EXPECT_NE(message({"square:amplitude=1"}).find("--reference 'square:amplitude=1': expected sine:"), std::string::npos);
  EXPECT_NE(message({"file:/nonexistent/ref.csv"}).find("/nonexistent/ref.csv"), std::string::npos);
  EXPECT_NE(message({"file:/data/my,step.csv"}).find("unknown key \"step.csv\" (a file reference takes "),
            std::string::npos);
  EXPECT_NE(message({"file:/data/my,step.csv"}).find("a PATH cannot contain a comma"), std::string::npos);
  // names result.json puts beside the references' names are reserved (it would not read back)
  for (const char* reserved : {"source", "max_error_mm", "mae_mm", "rms_error_mm"})
    EXPECT_NE(message({fmt::format("sine:amplitude=1,offset=50,frequency=1,periods=1,name={}", reserved)})
                  .find(fmt::format("name = \"{}\" is reserved: result.json keys the references by name beside source, "
                                    "max_error_mm, mae_mm, rms_error_mm",
                                    reserved)),
              std::string::npos)
        << reserved;
  const std::string twice = message({"sine:amplitude=1,offset=50,frequency=1,periods=1,name=a",
                                     "triangle:amplitude=1,offset=50,frequency=1,periods=1,name=a"});
  EXPECT_NE(twice.find("its name \"a\" is that of"), std::string::npos) << twice;
  // two of a kind are ref1, ref2
  const auto two = parse_references({"sine:amplitude=1,offset=50,frequency=1,periods=1",
                                     "sine:amplitude=2,offset=50,frequency=0.5,periods=1",
                                     "triangle:amplitude=2,offset=50,frequency=0.5,periods=1"});
  EXPECT_EQ(two[0].name, "ref1");
  EXPECT_EQ(two[1].name, "ref2");
  EXPECT_EQ(two[2].name, "triangle");
  // a learning run longer than kMaxLearningSeconds: refused before anything runs
  {
    ExperimentOptions slow;
    slow.learning_periods = 1000;
    slow.references = parse_references({"sine:amplitude=10,offset=40,frequency=0.01,periods=1"});
    try {
      slow.validate();
      ADD_FAILURE() << "a 100000 s learning run was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("its learning run of 1000 periods (--learning-periods) of 100 s would last "
                                           "100000 s, more than the 3600 s"),
                std::string::npos)
          << e.what();
    }
    slow.learning_periods = 36;
    EXPECT_NO_THROW(slow.validate());
  }
  // finer than the control period resolves: refused before anything runs
  ExperimentOptions o;
  o.references = parse_references({"sine:amplitude=10,offset=50,frequency=30,periods=2"});
  try {
    o.validate();
    ADD_FAILURE() << "a 30 Hz sine at 1 ms was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frequency = 30 Hz needs more than the control period resolves"),
              std::string::npos)
        << e.what();
  }
}

// A user reference beyond the rig's reach goes through the reach mapping as a paper's does:
// mapped with a note that calls it given (not published), or tracked as given with the note
// that it is out of reach (fit_references = false, --paper-references).
TEST(Experiment, AUserReferenceOutOfReachIsMappedOrKeptAsGiven) {
  ExperimentOptions o = test::quick_experiment("gpi-pid");
  o.references = parse_references({"triangle:amplitude=30,offset=110,frequency=0.5,periods=1,name=high"});
  const ExperimentResult mapped = run_experiment(o);
  ASSERT_EQ(mapped.reference_ranges.size(), 1u);
  EXPECT_TRUE(mapped.reference_ranges[0].scaled);
  EXPECT_NEAR(mapped.reference_ranges[0].paper_max_mm, 140.0, 1e-6);
  EXPECT_LT(mapped.reference_ranges[0].max_mm, 100.0);
  bool said = false;
  for (const auto& m : mapped.messages)
    said = said || (m.find("reference high mapped onto the rig's reach") == 0 && m.find("instead of the given") !=
                                                                                  std::string::npos);
  EXPECT_TRUE(said) << fmt::format("{}", fmt::join(mapped.messages, "\n"));
  o.fit_references = false;
  const ExperimentResult kept = run_experiment(o);
  ASSERT_EQ(kept.reference_ranges.size(), 1u);
  EXPECT_FALSE(kept.reference_ranges[0].scaled);
  EXPECT_FALSE(kept.reference_ranges[0].reachable);
  EXPECT_NEAR(kept.reference_ranges[0].max_mm, 140.0, 1e-6);
  for (const TrackingRun& run : kept.runs)
    for (double p : run.pressure_command_mpa) ASSERT_TRUE(p >= 0.0 && p <= kept.pressure_limit_mpa) << run.variant;
}

// The samples a user reference is tracked on: the papers' sine (O - A cos, from its bottom), a
// periodic record (one period, its last sample closing it) repeated, its units from its header.
TEST(Experiment, UserReferencesAreSampledAtTheControlPeriod) {
  const auto sine = experiment::user_references(
      parse_references({"sine:amplitude=15,offset=50,frequency=0.5,periods=2"}), 1e-3);
  ASSERT_EQ(sine.size(), 1u);
  EXPECT_EQ(sine[0].ref_m.size(), 4000u);
  EXPECT_EQ(sine[0].period, 2000u);
  EXPECT_NEAR(sine[0].ref_m[0], 0.035, 1e-12);
  EXPECT_NEAR(sine[0].ref_m[1000], 0.065, 1e-12);
  EXPECT_NEAR(sine[0].ref_m[500], 0.050, 1e-12);
  test::TempDir dir;
  // one period of a triangle, 2 s, in ms and m: 0.03 .. 0.06 m
  std::string csv = "time [ms],x [m]\n";
  for (int k = 0; k <= 200; ++k) csv += fmt::format("{},{}\n", 10 * k, 0.03 + 0.03 * (1.0 - std::abs(1.0 - k / 100.0)));
  const std::string path = dir.write("tri.csv", csv);
  const auto file = parse_references({"file:" + path + ",periodic,periods=3"});
  EXPECT_EQ(file[0].name, "file");
  EXPECT_NEAR(file[0].t_s.back(), 2.0, 1e-12);
  EXPECT_NEAR(file[0].x_mm[100], 60.0, 1e-9);
  const auto tri = experiment::user_references(file, 1e-3);
  EXPECT_EQ(tri[0].period, 2000u);
  EXPECT_EQ(tri[0].ref_m.size(), 6000u);
  EXPECT_NEAR(tri[0].ref_m[1000], 0.060, 1e-12);
  EXPECT_NEAR(tri[0].ref_m[2000 + 500], 0.045, 1e-12);
  // a periodic record that does not close is refused
  const std::string unclosed = dir.write("open.csv", "t,x\n0,30\n1,60\n2,45\n");
  EXPECT_THROW((void)parse_references({"file:" + unclosed + ",periodic"}), Error);
  EXPECT_NO_THROW((void)parse_references({"file:" + unclosed}));
}
