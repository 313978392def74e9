// A learning run's iterative learning in generated C (export_loop.hpp): IterativeLearning
// (src/core/learning.cpp) transcribed operation by operation, with the Q-filter's taps read
// from the object the parameters build, and the learning loop's step (step(Controller&,
// IterativeLearning&, ...), src/core/loop_design.cpp). Keep them in step:
// tests/test_export_loop.cpp compares them sample by sample.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <string>

#include "export_c_text.hpp"
#include "export_loop.hpp"
#include "hysteron/error.hpp"
#include "hysteron/learning.hpp"

namespace hysteron::io::detail {

namespace {

constexpr std::string_view kLearningDeclarations = R"(
/* ---- the loop's iterative learning ---- */

/* Samples per period of the reference the loop learns: the reference must repeat every
 * $U_LEARNING_PERIOD samples. */
#define $U_LEARNING_PERIOD $N

/* The learning's state (hysteron::IterativeLearning), $BYTES bytes: declare it static (or
 * global). Set with $P_learning_reset (or $P_learning_warm_start) before the first step. */
typedef struct $P_learning {
  double c[$NC][$U_LEARNING_PERIOD]; /* corrections [m]: c_j, c_(j+1)$BEST */
  double e[2][$U_LEARNING_PERIOD];  /* errors [m]: this period's, the period's before */
  int cur, next, best, e_cur, e_prev;  /* which buffer is which (the library swaps them) */
  size_t k, j;                      /* phase in the period, completed periods */
  double gain;                      /* the learning gain L in use */
  double sse, least_mse;            /* sum of e^2 over this period; mean e^2 of the best period */
  int tail_from_best, best_valid, skip_tail, held;
  unsigned long faults;             /* non-finite errors, recorded as 0 */
  unsigned long overflows;          /* updates whose sum overflowed: the correction before kept */
  unsigned long cuts, raises;       /* times the supervisor halved L; doubled it */
} $P_learning;

#ifdef __cplusplus
extern "C" {
#endif

/* Zero corrections, phase 0 of period 0, L at its design value (IterativeLearning::reset()). */
void $P_learning_reset($P_learning *l);
/* As $P_learning_reset, but period 0 applies `correction` (n = $U_LEARNING_PERIOD values [m],
 * clipped to the correction limit), e.g. a correction learnt in an earlier session (a learning
 * run's correction_mm over its last period / 1000). Returns 0, or -1 with *l unchanged if n is
 * not the period or a value is not finite (IterativeLearning::reset(correction)). */
int $P_learning_warm_start($P_learning *l, const double *correction, size_t n);
/* The correction [m] to add to the reference `ahead` samples after the current one (ahead is
 * at most $LOOKAHEAD, the loop's lead: larger values are taken as it). Call before
 * $P_learning_step. */
double $P_learning_correction(const $P_learning *l, size_t ahead);
/* Records the tracking error e = r - y [m] of the current sample and advances one sample; a
 * non-finite error is recorded as 0 and counted in l->faults. An update whose sum overflows
 * (errors of the order of 1e308) keeps that sample's correction of the period before and is
 * counted in l->overflows: a correction is never inf or NaN. */
void $P_learning_step($P_learning *l, double error_m);
/* One sample of the learning loop (step(Controller&, IterativeLearning&, ...), loop_design.hpp):
 * $P_loop_step fed reference_m + c(0) and preview_m + c(lead); then the error
 * reference_m - measured_m is learnt, or 0 where the command is at a pressure limit. The
 * arguments and the result are $P_loop_step's; reference_m is the periodic reference itself,
 * preview_m its feedforward preview (for a periodic reference, wrapped around the period). */
double $P_loop_learning_step($P_loop *c, $P_learning *l, double reference_m, double preview_m, double measured_m,
                             double pressure_mpa, double *duty);

#ifdef __cplusplus
}
#endif
)";

constexpr std::string_view kLearningDefinitions = R"(
/* sum_s q[s] (c[s] + L e[s]) over n contiguous samples, in four partial sums (learning.cpp's
 * weighted_sum: the same order, so the same rounding). */
static double $P_learning_sum(const double *q, const double *c, const double *e, double L, ptrdiff_t n)
{
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  ptrdiff_t s = 0;
  for (; s + 4 <= n; s += 4) {
    a0 += q[s] * (c[s] + L * e[s]);
    a1 += q[s + 1] * (c[s + 1] + L * e[s + 1]);
    a2 += q[s + 2] * (c[s + 2] + L * e[s + 2]);
    a3 += q[s + 3] * (c[s + 3] + L * e[s + 3]);
  }
  for (; s < n; ++s) a0 += q[s] * (c[s] + L * e[s]);
  return (a0 + a1) + (a2 + a3);
}

static ptrdiff_t $P_learning_min(ptrdiff_t a, ptrdiff_t b)
{
  return b < a ? b : a;
}

/* c_new(i) = clamp(sum_m q_m [c(i + m) + L e(i + m + d)]) (IterativeLearning::update_at): `c`
 * the previous generation, the errors this period's (measured) or the period's before; the taps
 * are summed in contiguous runs that end where an index wraps around the period. */
static double $P_learning_update($P_learning *l, size_t i, const double *c, int tail)
{
  const ptrdiff_t N = (ptrdiff_t)$U_LEARNING_PERIOD, h = (ptrdiff_t)$P_learning_reach;
  const ptrdiff_t d = (ptrdiff_t)$P_learning_lead, ii = (ptrdiff_t)i;
  const double *q = $P_learning_q + $P_learning_reach; /* q[m], m = -h..h */
  double acc = 0.0;
  ptrdiff_t m;
  for (m = -h; m <= h;) {
    ptrdiff_t ci = ii + m, len, t;
    const double *e;
    if (ci < 0) ci += N;
    if (ci >= N) ci -= N;
    len = $P_learning_min(h - m + 1, N - ci);
    t = ii + m + d;
    if (tail) { /* i in [N - d - h, N): t >= N is this period's error at t - N */
      if (t >= N) {
        e = l->e[l->e_cur] + (t - N);
      } else {
        e = l->e[l->e_prev] + t;
        len = $P_learning_min(len, N - t);
      }
    } else {    /* t <= the current phase; t < 0 is the period's before */
      if (t < 0) {
        e = l->e[l->e_prev] + (t + N);
        len = $P_learning_min(len, -t);
      } else {
        e = l->e[l->e_cur] + t;
      }
    }
    acc += $P_learning_sum(q + m, c + ci, e, l->gain, len);
    m += len;
  }
  if (!$P_finite(acc)) { /* overflowed (inf, or NaN from inf - inf): c(i) stays */
    ++l->overflows;
    return c[i];
  }
  return $P_clamp(acc, -$P_learning_max_correction, $P_learning_max_correction);
}

static void $P_learning_swap(int *a, int *b)
{
  const int t = *a;
  *a = *b;
  *b = t;
}

/* The end of a period (IterativeLearning::end_period): the corrections' generations move on;
 * with supervision, the best period's correction is kept, restored after a worse period (L
 * halved), and L doubled after a new best until the first halving. */
static void $P_learning_end_period($P_learning *l)
{
  const double mse = l->sse / (double)$U_LEARNING_PERIOD;
  /* the first period starts from the loop's initial state: supervision starts after it */
  const int supervise = $P_learning_supervised && l->j != 0;
  const double allowed = 1.0 + $P_learning_rise_tolerance;
  l->sse = 0.0;
  l->skip_tail = 0;
  if (l->held) {
    /* the best correction stays */
  } else if (supervise && (!l->best_valid || mse < l->least_mse)) {
    $P_learning_swap(&l->best, &l->cur);
    $P_learning_swap(&l->cur, &l->next);
    l->tail_from_best = 1;
    l->least_mse = mse;
    l->best_valid = 1;
    if (l->cuts == 0 && l->gain < $P_learning_max_gain) {
      const double g = 2.0 * l->gain;
      l->gain = $P_learning_max_gain < g ? $P_learning_max_gain : g;
      ++l->raises;
    }
  } else if (supervise && mse > allowed * allowed * l->least_mse) {
    $P_learning_swap(&l->cur, &l->best);
    l->best_valid = 0;
    l->skip_tail = 1;
    l->gain *= 0.5;
    ++l->cuts;
    /* held after hold_after_cuts halvings, and at L's floor (max_cuts) whatever it says */
    l->held = l->cuts >= $P_learning_max_cuts ||
              ($P_learning_hold_after_cuts > 0 && l->cuts >= $P_learning_hold_after_cuts);
  } else {
    $P_learning_swap(&l->cur, &l->next);
    l->tail_from_best = 0;
  }
  $P_learning_swap(&l->e_cur, &l->e_prev);
  l->k = 0;
  ++l->j;
}

void $P_learning_reset($P_learning *l)
{
  size_t i, b;
  for (b = 0; b < $NCu; ++b)
    for (i = 0; i < $U_LEARNING_PERIOD; ++i) l->c[b][i] = 0.0;
  for (b = 0; b < 2u; ++b)
    for (i = 0; i < $U_LEARNING_PERIOD; ++i) l->e[b][i] = 0.0;
  l->cur = 0;
  l->next = 1;
  l->best = $BEST_INDEX;
  l->e_cur = 0;
  l->e_prev = 1;
  l->k = l->j = 0;
  l->faults = l->overflows = l->cuts = l->raises = 0;
  l->gain = $P_learning_gain;
  l->sse = 0.0;
  l->least_mse = HUGE_VAL;
  l->tail_from_best = l->best_valid = l->skip_tail = l->held = 0;
}

int $P_learning_warm_start($P_learning *l, const double *correction, size_t n)
{
  size_t i;
  if (n != $U_LEARNING_PERIOD || !correction) return -1;
  for (i = 0; i < n; ++i)
    if (!$P_finite(correction[i])) return -1;
  $P_learning_reset(l);
  for (i = 0; i < n; ++i)
    l->c[l->cur][i] = $P_clamp(correction[i], -$P_learning_max_correction, $P_learning_max_correction);
  return 0;
}

double $P_learning_correction(const $P_learning *l, size_t ahead)
{
  size_t p;
  if ($P_learning_lookahead < ahead) ahead = $P_learning_lookahead;
  p = l->k + ahead;
  return p < $U_LEARNING_PERIOD ? l->c[l->cur][p] : l->c[l->held ? l->cur : l->next][p - $U_LEARNING_PERIOD];
}

/* At phase k of period j, after recording e_j(k): c_(j+1)(k - D), D = delay (every error it needs
 * is measured), or for j >= 1 and k < D the end of c_j, c_j(N + k - D), which needed this
 * period's first errors (IterativeLearning::step). */
void $P_learning_step($P_learning *l, double error_m)
{
  const size_t dh = $P_learning_delay;
  if (!$P_finite(error_m)) {
    error_m = 0.0;
    ++l->faults;
  }
  l->e[l->e_cur][l->k] = error_m;
  l->sse += error_m * error_m;
  if (l->held) {
    /* the best correction, held: nothing to update */
  } else if (l->k >= dh) {
    l->c[l->next][l->k - dh] = $P_learning_update(l, l->k - dh, l->c[l->cur], 0);
  } else if (l->j >= 1 && !l->skip_tail) {
    l->c[l->cur][$U_LEARNING_PERIOD + l->k - dh] =
        $P_learning_update(l, $U_LEARNING_PERIOD + l->k - dh, l->c[l->tail_from_best ? l->best : l->next], 1);
  }
  if (++l->k == $U_LEARNING_PERIOD) $P_learning_end_period(l);
}

double $P_loop_learning_step($P_loop *c, $P_learning *l, double reference_m, double preview_m, double measured_m,
                             double pressure_mpa, double *duty)
{
  const double cmd = $P_loop_step(c, reference_m + $P_learning_correction(l, 0u),
                                  preview_m + $P_learning_correction(l, $P_lead), measured_m, pressure_mpa, duty);
  const int saturated = cmd <= $P_pressure_lo || cmd >= $P_pressure_hi;
  $P_learning_step(l, saturated ? 0.0 : reference_m - measured_m);
  return cmd;
}
)";

}  // namespace

void append_learning_c(const LoopDesign& d, LoopC& out) {
  const LoopDesign::Learning& ln = *d.learning;
  const LearningParams& p = ln.params;
  p.validate();
  const std::string period = count_literal(p.period, "learning.period");
  const std::string lead = count_literal(p.lead, "learning.lead");
  const std::string lookahead = count_literal(p.lookahead, "learning.lookahead");
  if (p.hold_after_cuts > kMaxCount)
    throw Error(fmt::format("learning.hold_after_cuts = {} is more than generated C holds (at most {})",
                            p.hold_after_cuts, kMaxCount));
  const std::string hold = fmt::format("{}u", p.hold_after_cuts);
  const bool supervised = std::isfinite(p.rise_tolerance);
  const std::size_t nc = supervised ? 3 : 2;  // c_j, c_(j+1) and the best period's
  // The state is one object of (nc + 2) N doubles: it must fit the largest object a 32-bit
  // target addresses (PTRDIFF_MAX = 2^31 - 1 bytes).
  const double bytes = static_cast<double>((nc + 2) * sizeof(double)) * static_cast<double>(p.period);
  if (bytes > static_cast<double>(kMaxCount))
    throw Error(fmt::format("learning.period = {} samples: the learning's state ({} x {} doubles, {:.0f} bytes) is "
                            "more than generated C holds in one object (at most {} bytes)",
                            p.period, nc + 2, p.period, bytes, kMaxCount));
  // The Q-filter as the library builds it. Its taps depend on h alone, so it is built on the
  // shortest period that h, d and the lookahead allow (no N-sized buffers here).
  LearningParams shortest = p;
  shortest.period = std::max<std::size_t>(2, p.lead + 2 * binomial_reach(p.half_width) + p.lookahead + 1);
  const IterativeLearning ilc(shortest);
  const std::size_t reach = ilc.filter_reach();
  const std::span<const double> q = ilc.filter_taps();

  // ---- the comment
  std::string& cm = out.comment;
  cm += " *\n * Iterative learning around the loop (hysteron::IterativeLearning, learning.hpp; docs/control.md,\n";
  cm += " * section 3), for a reference of period N samples, e = r - y:\n";
  cm += " *   r'(k) = r(k) + c_j(k), preview'(k) = preview(k) + c_j(k + lead),\n";
  cm += " *   c_(j+1)(k) = clamp(sum_m q_m [c_j(k + m) + L e_j(k + m + d)], +-c_max), m = -h..h,\n";
  cm += " *   e = 0 where the command is at a pressure limit;\n";
  cm += fmt::format(" *   N = {}, L = {}, d = {}, h = {} (binomial Q-filter; {} taps summed), c_max = {} m,\n",
                    p.period, num(p.gain), p.lead, p.half_width, 2 * reach + 1, num(p.max_correction));
  cm += fmt::format(" *   contraction bound {} on the identified loop (< 1: the update contracts)\n",
                    num(ln.contraction_bound));
  if (supervised)
    cm += fmt::format(" *   supervision: after a period whose mean squared error is above (1 + {})^2 x the best's,\n"
                      " *     the best correction again and L / 2; L x 2 (up to {}) after a new best until then;\n"
                      " *     {}\n",
                      num(p.rise_tolerance), num(p.max_gain),
                      fmt::format("the best correction held after {} halvings{}",
                                  p.hold_after_cuts > 0 ? std::min(p.hold_after_cuts, kMaxLearningCuts) : kMaxLearningCuts,
                                  p.hold_after_cuts > 0 && p.hold_after_cuts < kMaxLearningCuts ? "" : " (L's floor)"));
  else
    cm += " *   no supervision: L fixed\n";
  cm += fmt::format(" *   state: {} doubles ({:.0f} bytes)\n", (nc + 2) * p.period, bytes);

  // ---- declarations
  std::string dc(kLearningDeclarations);
  replace_all(dc, "$NC]", fmt::format("{}]", nc));
  replace_all(dc, "$N\n", period + "\n");
  replace_all(dc, "$BYTES", fmt::format("{:.0f}", bytes));
  replace_all(dc, "$BEST", supervised ? ", the best period's" : "");
  replace_all(dc, "$LOOKAHEAD", std::to_string(p.lookahead));
  out.declarations += dc;

  // ---- definitions
  std::string& df = out.definitions;
  df += "\n/* ---- the learning's constants ---- */\n";
  df += fmt::format("static const size_t $P_learning_lead = {};  /* d, the phase lead [samples] */\n", lead);
  df += fmt::format("static const size_t $P_learning_lookahead = {};  /* the largest `ahead` of a correction */\n",
                    lookahead);
  df += fmt::format("static const double $P_learning_gain = {};  /* L after a reset */\n", num(p.gain));
  df += fmt::format("static const double $P_learning_max_gain = {};  /* L's growth limit (0: none) */\n",
                    num(p.max_gain));
  df += fmt::format("static const double $P_learning_max_correction = {};  /* c_max [m] */\n", num(p.max_correction));
  df += fmt::format("static const int $P_learning_supervised = {};\n", supervised ? 1 : 0);
  df += fmt::format("static const double $P_learning_rise_tolerance = {};  /* {} */\n",
                    num(supervised ? p.rise_tolerance : 0.0), supervised ? "the supervisor's" : "unused");
  df += fmt::format("static const unsigned long $P_learning_hold_after_cuts = {};  /* 0: held at L's floor only */\n",
                    hold);
  df += fmt::format("static const unsigned long $P_learning_max_cuts = {}u;  /* L's floor: held after this many "
                    "halvings (kMaxLearningCuts) */\n",
                    kMaxLearningCuts);
  df += fmt::format("static const size_t $P_learning_reach = {}u;  /* taps m = -reach..reach are summed */\n", reach);
  df += fmt::format("static const size_t $P_learning_delay = {}u;  /* D: the update runs D samples behind the errors "
                    "(learning_update_delay) */\n",
                    learning_update_delay(p));
  df += fmt::format("/* q_m, m = -reach..reach (the others are below 1e-18 of q_0) */\nstatic const double "
                    "$P_learning_q[{}] = {{",
                    2 * reach + 1);
  for (std::size_t i = 0; i <= 2 * reach; ++i)
    df += fmt::format("{}{}", i % 4 == 0 ? "\n  " : " ", num(q[i])) + (i < 2 * reach ? "," : "");
  df += "\n};\n";
  std::string body(kLearningDefinitions);
  replace_all(body, "$NCu", fmt::format("{}u", nc));
  replace_all(body, "$BEST_INDEX", supervised ? "2" : "0");
  df += body;
}

}  // namespace hysteron::io::detail
