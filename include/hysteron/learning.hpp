#pragma once
// Iterative learning control (ILC) for periodic references: a P-type update with
// a phase lead and a zero-phase binomial Q-filter, run on top of a closed loop
// by modifying the loop's reference (docs/control.md):
//
//   r'_j(k)     = r(k) + c_j(k)                              modified reference
//   c_{j+1}(k)  = sum_{m=-h..h} q_m [ c_j(k+m) + L e_j(k+m+d) ]   (c's index mod N)
//   q_m         = binom(2h, m+h) / 2^(2h)                    |Q(w)| = cos^(2h)(w/2)
//
// The error's index runs in time: e_j(k) for k < 0 or k >= N is the error of the period
// before or after, at k mod N (the class keeps e_{j-1}; the end of c_{j+1} is completed in
// period j+1, the first d + h samples, when those errors are measured).
//
// j the period, N samples per period, e = r - y the tracking error, L the
// learning gain, d the phase lead [samples]. With T(z) the closed loop from r'
// to y, the correction converges monotonically (in the 2-norm over a period)
// when  sup_w |Q(w) (1 - L e^{i w d} T(e^{i w}))| < 1  (learning_contraction()).
//
// Supervision (optional, LearningParams::rise_tolerance): the bound above holds for the
// identified linear loop, not for the rig. The class keeps the best correction, the one
// whose period had the least mean squared error, from the second period on (the first
// starts from the loop's initial state, so its error is not comparable). When a completed
// period's mean squared error exceeds (1 + rise_tolerance)^2 times the best's, the next
// period applies the best correction again (re-measuring it) and L is halved for the updates
// from then on: as L -> 0 every frequency contracts by |Q(w)| < 1, whatever T is. Until that
// first halving, L may grow (LearningParams::max_gain): doubled after every new best period.
// Bookkeeping only swaps buffers at the period's end (no copy, no burst).
//
// step() never allocates, never throws and is deterministic; its cost is 2r + 1 taps per sample,
// r = binomial_reach(h) = min(h, ~6.4 sqrt(h)) (the taps q_m >= 1e-18 q_0; the update of c_{j+1} is
// computed progressively, learning_update_delay() samples behind the errors it needs, instead of
// in one burst per period).
#include <complex>
#include <cstddef>
#include <limits>
#include <span>
#include <vector>

namespace hysteron {

struct LearningParams {
  std::size_t period = 0;       // N [samples], in [2, kMaxLearningPeriod]
  double gain = 0.5;            // L, in (0, 2)
  std::size_t lead = 0;         // d [samples]
  std::size_t half_width = 0;   // h: binomial Q-filter of order 2h (0: no filter), <= kMaxLearningHalfWidth
  std::size_t lookahead = 0;    // largest `ahead` of correction() (e.g. the loop's preview)
  double max_correction = std::numeric_limits<double>::infinity();  // |c| limit, > 0
  // Relative rise of a period's RMS error over the least before it that halves L, >= 0
  // (infinity: no supervision, L fixed).
  double rise_tolerance = std::numeric_limits<double>::infinity();
  // After this many halvings of L the supervisor holds the best correction: no more updates
  // (0: at L's floor, after kMaxLearningCuts halvings; a larger count holds there too). Each
  // update is c <- Q(c + L e), so with L near 0 an update only smooths the best correction by Q,
  // and the period after it is worse again. A held correction is applied unchanged from then on,
  // whatever the errors of the periods after it: it is never re-checked (reset() starts again).
  std::size_t hold_after_cuts = 0;
  // Largest L of the supervisor's growth (0: L never grows; else in [gain, 2)). Until the first
  // halving, L is doubled (up to max_gain) after every period that is the new best: a design
  // whose contraction bound holds only for a small L on the identified loop converges slowly
  // (a factor of about 1 - L per period) on a rig where a larger L also contracts. The first
  // period above the best restores the best correction and halves L, as above, and L grows no
  // more. Needs supervision (a finite rise_tolerance).
  double max_gain = 0.0;
  // Throws hysteron::Error naming the field; also when lead + 2 binomial_reach(half_width) +
  // lookahead >= period (the taps summed must fit in one period; h itself may exceed it).
  void validate() const;
};

inline constexpr std::size_t kMaxLearningHalfWidth = 10'000'000;  // h; its reach is 20,358 samples
inline constexpr std::size_t kMaxLearningPeriod = 10'000'000;     // N [samples]
// L's floor: after this many halvings (L = the L before the first one x 2^-10, about 1e-3 of it)
// the supervisor holds the best correction whatever hold_after_cuts says. Below it an update is
// c <- Q c in all but name: without the floor (hold_after_cuts = 0) L went on halving to 0 through
// the subnormals on a noisy loop, and the best correction, re-measured after every rise and kept
// whatever its error, was smoothed away period after period (docs/control.md, section 3, Hold).
inline constexpr std::size_t kMaxLearningCuts = 10;

// The taps of the binomial Q-filter of half-width h that the update sums, |m| <= reach: the
// largest m with q_m >= 1e-18 q_0 (h itself up to h = 31; about 6.4 sqrt(h) for large h). The
// others change no sum beyond its rounding.
std::size_t binomial_reach(std::size_t half_width) noexcept;

// How many samples the progressive update runs behind the errors: c_{j+1}(i) is computed at phase
// i + D of period j, and the last D samples of c_{j+1} in period j + 1 (with the L in use then:
// where the supervisor doubled or halved L at the period's end, those D samples use the new L).
// D = d + h where the whole window fits (d + 2h + lookahead < N, as before 2026-11-28), else
// d + binomial_reach(h).
std::size_t learning_update_delay(const LearningParams& p) noexcept;

// Frequency response of the binomial Q-filter of half-width h at w [rad/sample]: cos^(2h)(w/2).
double binomial_response(std::size_t half_width, double w) noexcept;

// sup over the grid of |Q(w_l)(1 - L e^{i w_l d} T_l)| for a closed loop sampled at
// w_l in (0, pi] (T_l = T(e^{i w_l})). < 1: the update contracts at every frequency.
double learning_contraction(const LearningParams& p, std::span<const double> w,
                            std::span<const std::complex<double>> T) noexcept;

class IterativeLearning {
 public:
  explicit IterativeLearning(const LearningParams& params);  // allocates O(N)

  // Correction to add to the reference `ahead` samples after the current one
  // (ahead <= params.lookahead). Call before step() for the current sample.
  double correction(std::size_t ahead = 0) const noexcept;
  // Records the tracking error e = r - y of the current sample and advances one
  // sample. A non-finite error is recorded as 0 and counted (faults()). An update whose sum
  // overflows the double range (finite errors of the order of 1e308) keeps that sample's
  // correction of the period before and is counted (overflows()): a correction is never inf or NaN.
  void step(double error) noexcept;
  // Zero corrections, back to phase 0 of period 0.
  void reset() noexcept;
  // As reset(), but period 0 applies c_0 = `correction` (N values, clipped to +-max_correction)
  // instead of zeros, and learning goes on from it: a correction learnt before (an earlier
  // session on the rig; an experiment's correction_mm over its last period, in the loop's units)
  // warm-starts the loop. Throws hysteron::Error, the state unchanged, if it does not have N
  // values or one is not finite. Does not allocate.
  void reset(std::span<const double> correction);

  std::size_t phase() const noexcept { return k_; }
  std::size_t iteration() const noexcept { return j_; }  // completed periods
  std::size_t faults() const noexcept { return faults_; }
  std::size_t overflows() const noexcept { return overflows_; }  // updates that overflowed (see step())
  double gain() const noexcept { return gain_; }             // L in use (params().gain until halved)
  std::size_t gain_cuts() const noexcept { return cuts_; }   // times the supervisor reverted and halved L
  std::size_t gain_raises() const noexcept { return raises_; }  // times it doubled L (max_gain)
  // the best correction is held (after hold_after_cuts halvings, or kMaxLearningCuts: L's floor)
  bool held() const noexcept { return held_; }
  const LearningParams& params() const noexcept { return p_; }
  // The binomial Q-filter as built: the 2r + 1 taps q_m, m = -r..r, r = filter_reach() =
  // binomial_reach(h), that the per-sample update sums (their sum is 1; the others, below 1e-18
  // of q_0, are not kept). For a transcription of the update (hysteron export --loop of a
  // learning run).
  std::span<const double> filter_taps() const noexcept { return q_; }
  std::size_t filter_reach() const noexcept { return reach_; }

 private:
  double update_at(std::size_t i, const double* c, bool tail) noexcept;  // counts overflows_
  void end_period() noexcept;  // swaps the generations; supervision (see above)

  LearningParams p_;
  std::vector<double> q_;                 // 2 reach_ + 1 filter taps, q_[reach_] = q_0
  std::size_t reach_ = 0;                 // taps m with |m| <= reach_ are summed (the rest < 1e-18 of q_0)
  std::size_t delay_ = 0;                 // learning_update_delay(p_)
  std::vector<double> c_cur_, c_next_;    // c_j, c_{j+1}
  std::vector<double> c_best_;            // supervision: the correction of the best period
  // c_{j-1}, from which the end of c_j is computed, is in c_best_ (else c_next_); a flag, not a
  // pointer into the buffers, so that a copy of the object stays valid
  bool tail_from_best_ = false;
  bool best_valid_ = false;               // c_best_ holds a measured correction
  bool skip_tail_ = false;                // c_j is a restored best: complete already
  bool held_ = false;                     // c_cur_ is held: no more updates
  std::vector<double> e_cur_, e_prev_;    // e_j, e_{j-1}
  std::size_t k_ = 0, j_ = 0, faults_ = 0, overflows_ = 0;
  double gain_ = 0.0;                     // L in use
  double sse_ = 0.0;                      // sum of e^2 over this period so far
  double least_mse_ = 0.0;                // mean squared error of c_best_'s period
  std::size_t cuts_ = 0, raises_ = 0;
};

}  // namespace hysteron
