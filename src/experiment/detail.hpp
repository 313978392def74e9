#pragma once
// Private to the experiments (src/experiment/): the rig runs, fits and tracking
// loop every experiment shares, and the spec each experiment registers.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <complex>

#include "hysteron/experiment.hpp"
#include "hysteron/control.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/learning.hpp"

namespace hysteron::experiment {

// [MPa] The papers' actuator range, 0..0.6 MPa (the Festo DMSP-20's rated maximum operating
// pressure): the pressures their identification inputs are defined at (paper_pressure_input).
// A run's own limit is the rig's (run_pressure_limit), carried in Context::pressure_max.
inline constexpr double kPaperPressureMax = 0.6;
// A pressure that levels off more than this fraction below the run's limit while the command
// sits there is capped (capped_top), not still rising through the regulator's lag
inline constexpr double kCapMargin = 0.05;

// What a controller sees each control period and what it commands.
struct Sample {
  double reference_m, preview_m, measured_m, pressure_mpa;
  std::size_t k;  // control sample index since the start of the run
};
using Law = std::function<RigInputs(const Sample&)>;

// The actuator limit of a run of `o` [MPa]: pressure_command_limit of its rig, and of its
// tracking rig if it has one (the less), under the experiment's actuation (valves or regulator).
double run_pressure_limit(const ExperimentOptions& o, bool valves);
// A paper's identification input (defined at fixed pressures within 0..kPaperPressureMax)
// for a run whose limit is p_max [MPa]: scaled by p_max / kPaperPressureMax where the limit is
// below the papers' range, unchanged otherwise (a rig rated higher keeps the papers' inputs;
// extended_input_top extends them to its limit where the references need it).
std::vector<double> paper_pressure_input(std::vector<double> input, double p_max);

RigInputs regulator(double p_mpa, double p_max);       // regulator command, clamped to 0..p_max [MPa]
RigInputs valves(double duty, double desired_mpa);     // PWM duty, clamped to [-1, 1]

// A reference of one experiment. `period` > 0 marks a periodic reference: ref_m from
// `periodic_from` holds (at least) one period, repeated by the learning variant.
struct Reference {
  std::string name;
  std::vector<double> ref_m;     // [m] at the control period
  std::size_t score_from = 0;    // first scored sample
  std::size_t period = 0;        // samples per period (0: not periodic)
  std::size_t periodic_from = 0; // first sample of the periodic part (after a pre-roll)
  bool user = false;             // the user's (ExperimentOptions::references), not the paper's
  std::size_t pre_roll = 0;      // samples of add_pre_roll's hold before it (0: none)
};

// ---- the user's references (user_reference.cpp) ----
// ExperimentOptions::references at the control period tc (score_from 0: add_pre_roll's hold).
std::vector<Reference> user_references(const std::vector<UserReference>& refs, double tc);
// Throws hysteron::Error where a user reference needs more than the control period tc
// resolves (kMinReferencePeriodSamples, kReferenceResolution), is longer than
// kMaxReferenceSeconds, or two share a name (ExperimentOptions::validate).
void check_user_references(const std::vector<UserReference>& refs, double tc);

// Seconds a reference without a warm-up is held at its first value before it starts
// (unscored), the loop running: the rig starts vented (add_pre_roll, docs/control.md
// section 5). The relay tests settle for as long at their level.
inline constexpr double kPreRollS = 1.5;

// Zero-vibration input shaper (Singer and Seering 1990) for the identified load mode (w_n,
// zeta < 1): two impulses a1 = 1 / (1 + K), a2 = K / (1 + K), K = exp(-zeta pi / sqrt(1 - zeta^2)),
// half a damped period D = pi / w_d apart; the residual vibration of that mode is zero. Shifted
// `advance` = round(a2 D) samples earlier so that its mean delay is zero (the reference is known
// ahead): r_s(k) = a1 r(k + advance) + a2 r(k + advance - D), indices clamped to the record.
struct ZvShaper {
  double a1 = 1.0, a2 = 0.0;
  std::size_t delay = 0, advance = 0;  // D and the advance [samples]
  bool active() const noexcept { return a2 > 0.0 && delay > 0; }
};

// Everything an experiment's control laws may use: the fitted models and what
// was identified from the rig at hand (never the nominal rig's values).
struct Context {
  const ExperimentOptions& options;
  const ExperimentResult& result;  // fit, best_fit, baseline_model, lead_s
  const RigDynamics& dynamics;     // identified from the identification run
  double tc;                       // control period [s]
  std::size_t lead;                // preview [samples] of the compensated variants
  PidParams pressure_loop;         // valve experiments: PI of the pressure loop (relay test)
  bool learning = false;           // the loop is built for the learning variant (robust PID rule)
  double gain_scale = 1.0;         // factor on the classic rule's PID gains (the gain trial's choice)
  ZvShaper shaper{};               // the feedforward's shaper (the gain trial's choice; inactive: none)
  const Reference* reference = nullptr;  // the reference the loop is built for
  // The tuned PIDs' limit-cycle guard amplitude [m] (PidGuard; 0: off, as in the gain trial):
  // set from the gain trial's error at the chosen loop (guard_amplitude).
  double guard_amplitude_m = 0.0;
  double pressure_max = kPaperPressureMax;  // the run's actuator limit [MPa] (run_pressure_limit)
};

// One variant's loop, built fresh for each run.
struct Loop {
  Law law;
  std::string description;
  PidParams position;  // the position loop's PID (the learning variant's design uses it)
  std::function<std::string()> note = {};  // after the run: a note for the result's messages ("" for none)
  std::optional<PidParams> pressure = {};  // the valves' inner pressure loop (duty per MPa), if any
  double pressure_gain = 0.0;              // k_p of a proportional pressure loop (0: none)
  LoopDesign::Kind kind = LoopDesign::Kind::feedforward_pid;  // the controller's structure
  FeedforwardParams feedforward = {};      // the inverse feedforward's limits, scale and lag
  std::optional<PwmParams> pwm = {};       // the valves' modulator (cascade_pwm)
  std::optional<LoopDesign::Adaptation> adaptation = {};  // the adaptive variant's RLS (adaptation_of)
  // After the run: the position PID's state (its limit-cycle guard's cuts and gain scale).
  std::function<PidState()> position_state = {};
  // Restarts the position PID's limit-cycle guard (the gains as tuned, no half-cycles counted):
  // called at the end of a reference's pre-roll (Reference::pre_roll), whose fill from rest is
  // no ringing of the loop. Empty for a loop without a position PID.
  std::function<void()> restart_guard = {};
};

struct Variant {
  std::string name;  // faithful | compensated | adaptive | baseline
  bool preview = false;  // the feedforward is fed Context::lead samples ahead
  std::function<Loop(const Context&)> make;
};

struct Spec {
  std::string name, title, summary;
  FitModel model = FitModel::gpi;
  int operators = 10;
  std::function<std::vector<double>(double tc)> id_pressure;   // paper's identification input
  std::function<std::vector<double>(double tc)> id2_pressure;  // second run (best model's validation)
  double train_seconds = 5.0;                                  // the major loop
  std::function<std::vector<Reference>(double tc)> references;
  PublishedFigures published;
  std::vector<Variant> variants;            // run in this order; `learning` after `compensated`
  std::string learning_on = "compensated";  // the loop the learning variant runs on
  bool valves = false;                      // run the relay test of the valves' pressure loop
  // Without valves: k_p of the proportional pressure loop the hysteron variants put around the
  // regulator (command = p_d + k_p (p_d - p_measured)); the identification and the relay tests
  // run through it too, so the dynamics identified are those of the actuator the loops use.
  double pressure_loop_gain = 0.0;
};

const Spec& gpi_pid_spec();
const Spec& mpi_openloop_spec();
const Spec& mpi_pwm_spec();
const std::vector<const Spec*>& registry();
const Spec* find_spec(const std::string& name) noexcept;

// ---- the adaptive variant (adaptive_loop.cpp, docs/control.md) ----------------------
// The best fitted model as an AdaptiveInverse for the reference of `c`: forgetting factor
// lambda = 1 - 1 / N with N the samples of one period of the reference (its whole length if
// it is not periodic), the identification run as the prior, pressure limits 0..c.pressure_max.
// frozen: no adaptation (the compensated loop's inverse, for comparisons).
std::shared_ptr<AdaptiveInverse> adaptive_inverse(const Context& c, bool frozen = false);
// The adaptive loops' feedforward: learns from each measured pair (pressure, contraction),
// hands the weights to the inverse (AdaptiveInverse::commit) at the bottom of each loop of the
// previewed reference (falling, then not falling), and returns the pressure [MPa] that makes
// the model in use reach preview_m. Why not every sample: handed over every sample (or every
// second) the weights follow the branch being tracked and modulate the feedforward within a
// loop; on the wide-band rig that was worse than the fixed inverse (docs/control.md).
class AdaptiveFeedforward {
 public:
  // p_max: the run's actuator limit [MPa], the command's clamp
  AdaptiveFeedforward(std::shared_ptr<AdaptiveInverse> a, double p_max) : a_(std::move(a)), p_max_(p_max) {}
  double step(const Sample& s) noexcept;
  const AdaptiveInverse& model() const noexcept { return *a_; }

 private:
  std::shared_ptr<AdaptiveInverse> a_;
  double p_max_;
  double r1_ = std::numeric_limits<double>::quiet_NaN(), r2_ = std::numeric_limits<double>::quiet_NaN();
};
// "adaptive (REF): ..." counters and the guard's verdict, for the result's messages.
std::string adaptive_note(const AdaptiveInverse& a, const std::string& reference);
std::string adaptive_description(const AdaptiveInverse& a);
// The adaptive loop's RLS in result.json's "controller" (LoopDesign::adaptation).
LoopDesign::Adaptation adaptation_of(const AdaptiveInverse& a);

// ---- shared machinery (common.cpp) ------------------------------------------------
// What turns a desired pressure [MPa] into the rig's inputs, given its outputs: the
// proportional regulator, or the switching valves behind a pressure loop.
using Actuator = std::function<RigInputs(double desired_mpa, const RigOutputs&)>;
// The identification run: `pressure` [MPa] at the control period through `actuator` (the
// one the experiment's loops use, so that the dynamics identified on it are theirs).
// Logs the desired pressure, clamped to 0..p_max [MPa] (the run's limit), as pressure_command_mpa.
IdentificationRun identification_run(const PamRigParams& rp, std::uint64_t seed, const std::vector<double>& pressure,
                                     double tc, const Actuator& actuator, double p_max);
IdentificationRun decimate(const IdentificationRun& r, std::size_t every);
// The models' input_limits are 0..p_max [MPa], the run's limit (the inverses saturate there).
ModelParams straight_line(const IdentificationRun& r, double p_max);
// fit() with its model checked: a failed fit or a model that cannot be inverted is a
// hysteron::Error; `status` (if given) receives the fit's status either way.
FitReport fit_checked(const IdentificationRun& r, FitOptions fo, const std::string& what, double p_max,
                      FitStatus* status = nullptr);
TrackingErrors errors_of(const TrackingRun& run, std::size_t from, std::size_t to);
// The samples in [from, to) whose pressure command sat at 0 or at p_max [MPa], the run's limit
// (TrackingRun::saturated: over the samples errors_of scores).
std::size_t saturated_samples(const TrackingRun& run, std::size_t from, std::size_t to, double p_max);
// The pressure at which a run's command sat at its limit p_max [MPa] long enough to level off,
// where that is more than kCapMargin below it; nullopt otherwise.
struct CappedTop {
  double level_mpa = 0.0;  // the reading's mean over the last third of the longest stretch at the top
  double stretch_s = 0.0;  // that stretch's length
};
std::optional<CappedTop> capped_top(const TrackingRun& run, std::size_t from, std::size_t to, double p_max);
// A note for the result's messages when the pressure command sat at 0 or p_max on at
// least 1 % of the samples in [from, to) (their count, the RMS error there and elsewhere, and
// the level the pressure was capped at, capped_top); "" otherwise. Uses run.variant and
// run.reference. reach_mpa: the most the identification run's pressure reached; rig_changed:
// the run is on --tracking-plant's rig.
std::string saturation_note(const TrackingRun& run, std::size_t from, std::size_t to, double reach_mpa,
                            bool rig_changed, double p_max);
// "" unless the run's limit-cycle guard cut its position PID's gains (run.controller.guard_cuts):
// how often, to which scale, at which period; rig_changed: the run tracked on a rig other than
// the one it was tuned on (--tracking-plant), the likely cause.
std::string guard_note(const TrackingRun& run, bool rig_changed);
// The scored RMS error of a run against the true contraction in the identified sensor's frame
// (actual_mm + frame_mm, the identified rig's displacement offset: what that sensor would read
// without noise; the simulator's, which a real rig does not have) where it is above
// kSensorGapRatio times the sensor's and kSensorGapFloorMm above it: a sensor whose offset
// changed after the identification, or an ADC too coarse for the errors, hides that much (the
// sensor's noise alone makes the sensor's error the larger). "" otherwise; else a clause for
// sensor_gap_note, which gathers a result's clauses into one note ("" if none).
inline constexpr double kSensorGapRatio = 1.25;
inline constexpr double kSensorGapFloorMm = 0.01;
std::string sensor_gap(const TrackingRun& run, std::size_t from, std::size_t to, double frame_mm);
std::string sensor_gap_note(const std::vector<std::string>& gaps, const PamRigParams& identified,
                            const PamRigParams& tracked);
// Runs one tracking experiment: `reference` sampled at the control period, the
// preview `lead` samples ahead (wrapping around for a periodic reference). Its saturated samples
// are counted once the scored samples are known (saturated_samples).
TrackingRun track(const ExperimentOptions& o, std::uint64_t seed, const std::vector<double>& ref_m,
                  std::size_t lead, bool periodic, const Law& law);
// Throws hysteron::Stopped where o.stop_requested says stop (ExperimentOptions::stop_requested).
void check_stop(const ExperimentOptions& o);

}  // namespace hysteron::experiment

namespace hysteron::experiment {

// ---- tuning from the rig's own data (tuning.cpp, docs/control.md) ----------------
// First order plus dead time around the fitted model (RigDynamics), by least squares
// over a grid of (theta, tau) on the identification run at the control period;
// `lead` receives the best pure delay (tau = 0) [samples], the feedforward's preview.
RigDynamics identify_dynamics(const ModelParams& model, const IdentificationRun& r, double tc, std::size_t& lead);
// The grid's bound on the dead time, the lag and the lead [s] (identify_dynamics).
inline constexpr double kMaxDynamicsDelay = 0.3;
// The note of a fit of identify_dynamics that sits on the grid's bound (a dead time, lag or
// lead of kMaxDynamicsDelay): the rig is slower than the grid resolves, or the run's response
// is not a lag (a load that does not follow); empty where none is on it.
std::string dynamics_bound_note(const RigDynamics& d, double lead_s, double tc);
// SIMC rule (Skogestad 2003) for the position PI on the FOPDT (K, tau, theta), tight
// tuning tau_c = theta:  K_c = tau / (K (tau_c + theta)),  T_i = min(tau, 4 (tau_c + theta)).
PidParams simc_pid(const RigDynamics& d, double tc, double out_min, double out_max);
// Closed loop from the (modified) reference to the contraction, on the identified FOPDT
// with the feedforward fed `lead` samples ahead and the PID `pid` (the inverse model
// taken as exact): T = G (z^lead + K (K_p + I(z))) / (1 + G K C(z)), at w [rad/sample].
std::complex<double> closed_loop(const RigDynamics& d, const PidParams& pid, std::size_t lead, double tc, double w);
// The level of both relay tests [MPa]: the middle of the pressure range the loops can use,
// 0..p_max (the run's limit), or 0..top where the supply caps the actuator below p_max. A rig
// rated above the papers' 0.6 MPa keeps 0.3 MPa, the middle of the range their identification
// inputs (kept, paper_pressure_input) measure: at 0.4 MPa on a 0.8 MPa rating the nominal rig's
// relay gave other gains, and gpi-pid's compensated RMS rose from 0.364 to 0.416 mm.
constexpr double relay_level(double p_max) noexcept {
  return 0.5 * (p_max < kPaperPressureMax ? p_max : kPaperPressureMax);
}
// Relay test (Astrom-Hagglund) of the valves' pressure loop: fill to relay_level(p_max), then duty
// +-h switched on the measured pressure around it with a hysteresis of 3 noise standard
// deviations (measured with the valves closed). Where that does not oscillate and the highest
// pressure measured is below twice the level (a supply that caps the rig), the test runs once
// more around half that highest pressure. Fills relay_gain, relay_period_s and
// relay_level_mpa of `d`; throws hysteron::Error if it does not oscillate.
// The relay switches at relay_decision_period(tc, dt), not at every sample of a faster loop
// (kRelayDecisionPeriod); K_u and T_u are a limit cycle's, the same in seconds at every rate.
void relay_test(const PamRigParams& rp, std::uint64_t seed, double tc, RigDynamics& d, double p_max);
// [s] The period the valves' pressure relay (relay_test) decides at in a faster loop. The valves
// take one duty per PWM period (5 ms nominal), but the relay can switch at every sample in
// between: its hysteresis, 3 noise standard deviations, bounds a switch on noise per decision,
// so 25 decisions per PWM period at 0.2 ms switched on the noise and the PWM ripple 5x as often
// as at 1 ms (single inlet periods): T_u 26.8 ms and K_u 137 /MPa for 32.5 ms and 151 at 1 ms,
// a pressure PI of Kp 42.8, Ki 725 for 47.1, 660, and mpi-pwm's compensated triangle 0.293 mm
// RMS for 0.192 (docs/control.md, section 7). Decided at this period the test is the 1 ms one.
inline constexpr double kRelayDecisionPeriod = 1e-3;
// The sample time relay_test runs its relay (its own rig run) at for a loop of sample time tc
// [s] on a rig of step dt [s]: tc itself at 1 ms and above; below, kRelayDecisionPeriod where
// it is a whole number of dt (0.2, 0.3, 0.5, 0.7 ms loops on the 1e-4 s rig: all the 1 ms
// test), else the whole number of tc nearest it.
double relay_decision_period(double tc, double dt);
// Relay test of the position loop through an actuator (desired pressure [MPa] and the rig's
// outputs -> the rig's inputs; `make_actuator` gives a fresh one, e.g. with a reset pressure
// loop, per run): hold p0 until settled, then switch the pressure p0 +- h on the measured
// contraction around its settled level, with a hysteresis of 3 noise standard deviations.
// `top` [MPa] is the actuator's usable top pressure (p_max, the run's limit, or less where the
// identification run found it capped): p0 = relay_level(p_max) where that + the first h is
// within it, else top / 2.
// h = kPositionRelayAmplitude, doubled while the contraction does not oscillate (a rig whose
// hysteresis band is wider than h) and p0 +- h stays within 0..top. Fills
// position_relay_gain, position_relay_period_s, position_relay_amplitude_mpa and
// position_relay_level_mpa. With `stroke` known (mid_mpa > 0): p0 = stroke.mid_mpa where
// p0 - h would be below stroke.floor_mpa (a heavy load that p0 - h lets down onto its rest),
// and where no amplitude oscillates around p0, the same is tried around stroke.mid_mpa.
// Throws hysteron::Error naming every level and amplitude tried if none oscillates.
inline constexpr double kPositionRelayAmplitude = 0.05;  // [MPa], the first h tried
// The noise sigma of y[from..to) from its first differences, sigma^2 = E[(y_k - y_{k-1})^2] / 2
// for white noise: a slow drift (a load still settling) adds little, where the samples' spread
// around their mean would count it. Needs to - from >= 2.
double first_difference_sigma(const std::vector<double>& y, std::size_t from, std::size_t to);
// The pressures of an identification run's stroke [MPa] (stroke_pressures in reach.cpp):
// floor_mpa, the least at which the contraction is off its rest (above its least by 2 % of
// its span and by 3 noise sigmas; on the descent, where the hysteresis puts it lowest);
// mid_mpa, the mean where the contraction is within 5 % of its span of the middle of the
// stroke. 0: not known.
struct StrokePressures {
  double floor_mpa = 0.0, mid_mpa = 0.0;
};
void position_relay_test(const PamRigParams& rp, std::uint64_t seed, double tc,
                         const std::function<Actuator()>& make_actuator, RigDynamics& d, double p_max,
                         double top, StrokePressures stroke = {});
// The second-order mode through the relay's point (RigDynamics::mode_*): with F the
// FOPDT at w_u = 2 pi / T_u and 1/H = (1 - r^2) + 2 i zeta r = -F K_u (r = w_u / w_n):
//   1 - r^2 = Re(-F K_u),  2 zeta r = Im(-F K_u).
void fit_load_mode(RigDynamics& d);
// Where no mode puts the FOPDT through the relay's point (fit_load_mode left mode_frequency_hz
// at 0) because the FOPDT alone has more phase lag at w_u than the relay measured, its dead
// time and lag are split again, theta + tau kept, so that w_u theta + atan(w_u tau) = pi
// (docs/control.md, section 1, "Where the FOPDT has more phase lag than the relay measured").
// The slope is kept; the gain at w_u is not matched. Returns whether it changed d.
bool fit_fopdt_to_relay_phase(RigDynamics& d);
// The FOPDT with its slope K kept put through the relay's whole point, gain and phase:
//   |F(i w_u)| = 1 / K_u:  tau = sqrt((K K_u)^2 - 1) / w_u,   arg F(i w_u) = -pi:  theta = (pi - atan(w_u tau)) / w_u.
// Only where no mode was fitted and K K_u > 1; returns whether it changed d. A fallback of the
// learning design where no filter contracts on the identified FOPDT (docs/control.md,
// section 3, "Where no filter contracts on the identified loop's neighbours").
bool fit_fopdt_through_relay_point(RigDynamics& d);
// Which models the learning design must contract on (learning_neighbours).
enum class Neighbours {
  all,         // every neighbour below
  with_mode,   // where a mode was fitted, only the neighbours that keep it (through the relay's point)
};
// The models the learning design must contract on (docs/control.md, section 3): the identified
// FOPDT with and without its load mode, dead time x1 and x1.5, lag and slope each x0.67, x1,
// x1.5; each neighbour's mode fitted through the relay's point again (fit_load_mode), and
// dropped where its FOPDT alone explains the point (its twin without a mode is in the list).
// Neighbours::with_mode leaves out the twins without a mode where d has one: they do not pass
// through the relay's point, so the relay may have ruled them out.
std::vector<RigDynamics> learning_neighbours(const RigDynamics& d, Neighbours which = Neighbours::all);
// Tests only: whether the learning variant's feedforward goes through the shaper the gain
// trial chose for the compensated loop (default true). Returns the previous setting.
bool set_learning_shaper(bool on);
// ---- The notes of a result (notes.cpp; each empty where there is nothing to say) ----
// References that descend faster than the vented load's terminal speed on `rig`.
std::string descent_note(const PamRigParams& rig, const std::vector<Reference>& refs, double tc);
// A rig (`which`: "rig" or "tracking rig") whose vented muscle stalls high in its reach after a hold at the top.
std::string weak_return_note(const PamRigParams& rig, std::string_view which, const std::vector<Reference>& refs);
// A displacement sensor whose noise (estimated on `id`) is at least half the least RMS of the compensating runs.
std::string noise_floor_note(const ExperimentResult& res, const IdentificationRun& id);
// A run whose actuator limit is not the papers' 0..0.6 MPa: where it comes from, and what changes.
std::string limit_note(const ExperimentOptions& o, const Spec& spec, double p_max);
// Throws hysteron::Error where nothing extends the vented muscle or the muscle cannot lift its load.
void check_return_force(const PamRigParams& rig, const char* which);
// The note for a learning run whose last period's RMS error is above `base`'s (the loop it
// learns on): whether it was still falling and, at the last period's rate of decrease, how many
// more periods would bring it below (or that it would not within 100: it has stalled); and why:
// below `base` in an earlier period (which), or never (its first period, on a slower loop).
std::string learning_above_note(const TrackingRun& learning, const TrackingRun& base);
// The note of a compensated, adaptive or learning run whose RMS error is not below the
// baseline run's on the same reference; empty where it is below.
// rig_changed: the tracking rig differs from the identified one (ExperimentOptions::tracking_rig),
// which the note then names as the likelier cause.
std::string above_baseline_note(const TrackingRun& run, const TrackingRun& base, bool rig_changed = false);
// The note of an adaptive run whose RMS error is above the compensated run's (empty if not).
std::string adaptive_above_note(const TrackingRun& adaptive, const TrackingRun& compensated, bool rig_changed = false);
// The note of a compensated run whose RMS error is above the faithful run's (the paper's loop and
// published gains) on the same reference; empty where it is not above.
std::string faithful_below_note(const TrackingRun& compensated, const TrackingRun& faithful, bool rig_changed = false);
// The note of a run tracking on another rig than the identified one: the parameters that differ.
std::string changed_rig_note(const PamRigParams& identified, const PamRigParams& tracking);
// "section.key: a -> b; ..." for every rig parameter that differs (count: how many, if given).
std::string changed_rig_list(const PamRigParams& identified, const PamRigParams& tracking,
                             std::size_t* count = nullptr);
// PID from the position relay test, derivative filter T_u / 30:
//   classic         Ziegler-Nichols (1942)  K_c = 0.6 K_u,  T_i = T_u / 2,  T_d = T_u / 8
//   some_overshoot  (robust, for learning)  K_c = K_u / 3,  T_i = T_u / 2,  T_d = T_u / 3
enum class PidRule { classic, some_overshoot };
PidParams relay_pid(const RigDynamics& d, double tc, double out_min, double out_max, PidRule rule);
// The position PID of a compensated loop in context `c`: the classic rule with its gains
// times c.gain_scale; learning_pid (below) when learning, times c.gain_scale where that is
// below 1 (the gain trial found the relay's gains too high on the rig).
PidParams position_pid(const Context& c);
// The limit-cycle guard of the tuned PIDs (docs/control.md, section 2): period the position
// relay's T_u, amplitude c.guard_amplitude_m; off where either is 0 (the gain trial's loops).
PidGuard pid_guard(const Context& c);
// The guard's amplitude [m] from a gain trial: 2 sqrt(2) times the RMS error of the chosen loop
// on the trapezoid, the amplitude of a sine with twice that RMS (0: no finite RMS).
double guard_amplitude(const GainTrial& g);
// The identified feedback loop's peaks, L = G K C (G, K as in closed_loop), over 0.05 Hz .. a
// quarter of the sampling rate: max_w |1 / (1 + L)| (sensitivity) and max_w |L / (1 + L)|
// (complementary sensitivity: the resonance the learning's T carries).
struct LoopPeaks {
  double sensitivity = 0.0, complementary = 0.0;
};
LoopPeaks loop_peaks(const RigDynamics& d, const PidParams& pid, double tc);
// The learning loop's PID: Ziegler-Nichols "some overshoot" (K_c = K_u / 3, T_i = T_u / 2) with
// the derivative time of T_u / 3 (the rule's), T_u / 2 or 2 T_u / 3 whose loop has the least
// complementary peak among those whose sensitivity peak is at most the rule's (ties: the shorter).
// Output limits +-p_max [MPa], the run's limit.
PidParams learning_pid(const RigDynamics& d, double tc, double p_max);
// The shaper (ZvShaper, above) for the identified mode. Inactive when no underdamped mode was
// identified (mode_frequency_hz = 0 or damping >= 1).
ZvShaper zv_shaper(const RigDynamics& d, double tc);
std::vector<double> shaped(const std::vector<double>& r, const ZvShaper& z);

// Where position_pid(c)'s gains come from, for the loops' descriptions: "a relay test,
// Ziegler-Nichols x1.26 by a gain trial" or "a relay test, Ziegler-Nichols some overshoot".
std::string pid_origin(const Context& c);
// Tyreus-Luyben PI from the relay test: K_c = K_u / 3.2, T_i = 2.2 T_u (duty per MPa).
PidParams tyreus_luyben_pi(const RigDynamics& d, double tc);
// The learning gains the design tries, largest first (docs/control.md, section 3).
inline constexpr double kLearningGains[] = {0.5, 0.3, 0.2, 0.1, 0.05};
// LearningParams::rise_tolerance of the learning variant: the design promises a monotone
// decrease, so L is halved after any period whose RMS error is above the least before it
// (docs/control.md, section 3). At the noise floor a halving only lowers the noise the
// learning feeds back.
inline constexpr double kLearningRiseTolerance = 0.0;
// LearningParams::hold_after_cuts of the learning variant: after 3 halvings (L / 8) an update
// only smooths the best correction by Q, and every other period was worse than the best (25
// periods of mpi-openloop's triangle: 0.050 / 0.060 mm RMS alternating from the 13th on, L
// halved 8 times; held: 0.051-0.052). Ten periods of the demo and the documented sweep never
// reach 3 halvings (docs/control.md, section 3).
inline constexpr std::size_t kLearningHoldAfterCuts = 3;
// Which Q-filters the learning design tries (half-width h; the window, with the lead and the
// loop's preview, must fit in one period).
enum class FilterWindow {
  whole,        // the filter's whole window, 2h + 1 taps at kLearningWindowPeriod (below): the widest bands
  summed_taps,  // the taps the update sums, 2 binomial_reach(h) + 1 (about 13 sqrt(h)): also
                // the narrower bands that end below a lightly damped mode
};
// [s] The sample time FilterWindow::whole counts the filter's window at. The binomial Q-filter of
// half-width h is about a Gaussian of sigma = sqrt(h / 2) samples: the same filter in seconds
// has h ~ 1 / T_s^2, its whole window 2h + 1 samples ~ 1 / T_s^2 while the period has ~ 1 / T_s
// samples. Counted at the loop's own T_s the rule would cap the band lower the faster the loop
// (at 0.5 ms it kept the band above the relay's floor: gpi-pid's learning 2x worse than at 1 ms).
// Counted at this fixed period (the loops' default), the window is 2h (T_s / 1 ms) samples of
// the loop: the same filter in seconds at every rate, the rule unchanged at 1 ms. Counting a slower
// loop's own 2h + 1 taps instead was tried (2026-11-30): gpi-pid's learning at 10 ms ended at
// 0.083 mm RMS against 0.065 counted at 1 ms (mpi-openloop, mpi-pwm the same).
inline constexpr double kLearningWindowPeriod = 1e-3;
// LearningParams::max_gain of the learning variant for the design `p`: the largest gain of
// kLearningGains (at least p.gain) whose contraction bound, with p's lead and Q-filter, is below 1
// on the loop `d` itself. The design's L contracts on every neighbour of d, a worst case; the
// supervisor doubles L after every new best period, until the first rise, but only as far as d
// itself still promises a monotone decrease (docs/control.md, section 3, "Growth"). Gpi-pid with
// load damping 200 N s/m: design L = 0.05, limit 0.5, 0.488 -> 0.231 mm RMS after 10 periods;
// a 63 kg load with stiffer creep (w08 of the wide seed-31 draw): design 0.05, limit 0.1.
double learning_growth_limit(const RigDynamics& d, const PidParams& pid, std::size_t lead, const LearningParams& p,
                             double tc);
// The learning variant's ILC: the largest gain L of kLearningGains, the phase lead d (<= 0.5 s) and the Q-filter's width
// chosen on the identified closed loop so that learning_contraction() < 1 with the
// widest filter band (docs/control.md). Sets `contraction` to that bound.
LearningParams design_learning(const RigDynamics& d, const PidParams& pid, std::size_t lead, std::size_t period,
                               double tc, double& contraction, Neighbours which = Neighbours::all,
                               FilterWindow window = FilterWindow::whole);


// ---- The rig's reach and the model's identification range (reach.cpp) ----

// Pressure headroom kept below the actuator's limit at a reference's top [fraction of
// the run's limit]: the position loop needs pressure above the feedforward's to correct an error
// there. The papers' references keep more on the nominal rig (gpi-pid's 95 mm top is reached
// at about 0.56 MPa, docs/control.md section 5).
inline constexpr double kPressureHeadroom = 0.05;

// The largest element of v; 0 where v is empty.
inline double max_of(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

// [s] Half the window of the centred moving mean the reach is read from: 5 samples at 1 ms (an
// 11-sample mean), 10 at 0.5 ms: (2 lround(5 ms / T_s) + 1) T_s, 10.5-11 ms at 1 ms and faster
// (14 ms at 2 ms, 30 ms at 10 ms, where the half-window is 1 sample).
inline constexpr double kSmoothingHalfWindow = 5e-3;
// Centred moving mean of 2 h + 1 samples [mm or MPa] (reach.cpp).
std::vector<double> smoothed(const std::vector<double>& x, std::size_t h);
// h of a record sampled every tc [s]: kSmoothingHalfWindow / tc, at least 1.
std::size_t smoothing_half_width(double tc);

// The identification run's contraction [mm] and measured pressure [MPa], each as its centred
// moving mean over about 11 ms (kSmoothingHalfWindow; 11 samples at 1 ms): what the reach and the
// model's identification range are read from.
struct SmoothedRun {
  std::vector<double> x_mm, p;
  std::size_t window = 1;  // the samples each mean is over, 2 h + 1 (a sensor's white noise / sqrt(window) in it)
  SmoothedRun(const IdentificationRun& id, double tc)
      : x_mm(smoothed(id.contraction_mm, smoothing_half_width(tc))),
        p(smoothed(id.pressure_mpa, smoothing_half_width(tc))),
        window(2 * smoothing_half_width(tc) + 1) {}
};

// The top pressure the loops can use and why (usable_top, reach.cpp).
struct ActuatorTop {
  double mpa = 0.0;             // the usable top
  double reached_mpa = 0.0;     // the reading's top
  bool sensor_limited = false;  // the reading stopped short of the commands, the muscle did not
  double slope_ratio = 0.0;     // the contraction's slope on the command at the reading's top / the run's
  double x_lo_mm = 0.0, x_hi_mm = 0.0, cmd_lo_mpa = 0.0, cmd_hi_mpa = 0.0;  // over those samples
  // the reading's median shortfall below the command over the run's middle commands (rising
  // and falling alike, so that the regulator's lag cancels) [MPa]: a sensor that reads low
  // (or an actuator short everywhere) shows it all along, a cap only at the top
  double offset_mpa = 0.0;
  bool reads_low = false;  // offset_mpa is at least half the shortfall at the top
};
ActuatorTop usable_top(const IdentificationRun& id, const SmoothedRun& sm, double p_max);
StrokePressures stroke_pressures(const IdentificationRun& id, const SmoothedRun& sm);
// ExperimentOptions::fit_references: the references mapped onto the rig's reach (notes into `res`).
std::vector<Reference> fit_to_reach(const ExperimentOptions& o, const IdentificationRun& id, const SmoothedRun& sm,
                                    const ActuatorTop& actuator_top, std::vector<Reference> refs,
                                    ExperimentResult& res, double p_max);
void add_pre_roll(std::vector<Reference>& refs, double tc);

// The pressure hysteron's model is identified up to (model_identification_range, reach.cpp).
struct IdentificationRange {
  double top_mm = 0.0, p_need_mpa = 0.0, p_id_mpa = 0.0, input_max_mpa = 0.0;
  std::string note() const;  // the result's message
};
IdentificationRange model_identification_range(const SmoothedRun& sm, const std::vector<Reference>& refs,
                                               const std::vector<double>& input, double p_max);
// `input` scaled so that its maximum is top_mpa: down only, or with `up_too` either way.
std::vector<double> scaled_to(std::vector<double> input, double top_mpa, bool up_too = false);
double extended_input_top(const std::vector<double>& input, const SmoothedRun& sm, const std::vector<Reference>& refs,
                          double p_top, double p_max);

// ---- hysteron's model for the compensated variants (model_choice.cpp) ----

// The fit options of a candidate kind: the paper's options with the kind, its number of
// operators, the decimated record's sample time and the whole record.
FitOptions candidate_fit_options(const FitOptions& paper, FitModel kind, const Spec& spec, double fit_dt);
// A rate-pi fitted at the decimated record's sample period, run at the control period tc (a note
// into `messages`); other kinds unchanged.
void to_control_rate(ModelParams& m, double tc, std::vector<std::string>& messages);
// Fits the candidates on `idf` and keeps (res.best_fit) the one with the least RMS on `id2`;
// fills res.candidates, res.model_choice and res.model_reason.
void choose_model(const ExperimentOptions& o, const Spec& spec, const IdentificationRun& idf,
                  const IdentificationRun& id2, const FitOptions& fo, double fit_dt, double p_max,
                  ExperimentResult& res);

}  // namespace hysteron::experiment
