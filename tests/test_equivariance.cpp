// Identification that holds on anyone's record (issue 10): the units map of every
// model kind, fits that are equivariant to offsets, scales and the output's sign, no
// kind worse than the reference PI, bounded inverse slopes, honest status, `auto`.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>

#include "hysteron/error.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/models.hpp"
#include "../src/identify/detail.hpp"

using namespace hysteron;

namespace {

std::vector<ModelParams> sample_models() {
  PiParams pi;
  pi.q = 0.4;
  pi.r = {0.1, 0.3, 0.6};
  pi.p = {0.5, 0.2, 0.1};
  GpiParams gpi;
  gpi.envelope = Envelope::tanh(2.0, 0.4, -1.2, 1.5);
  gpi.q = 1.0, gpi.n = 6, gpi.rho = 0.5, gpi.tau = 1.5, gpi.alpha = 0.1;
  MpiDeadzoneParams dz;
  dz.q = 0.8, dz.r = {0.2, 0.5}, dz.p = {0.3, 0.2}, dz.g0 = 1.0, dz.z = {0.8, -0.5}, dz.g = {0.5, 0.3};
  MpiAsymParams as;
  as.ascending = Envelope::tanh(2.0, 0.5, -0.5, 1.0);
  as.descending = Envelope::tanh(1.8, 0.45, -0.3, 1.0);
  as.q = 0.5, as.r = {0.1, 0.3}, as.p = {0.3, 0.2};
  as.input_limits = Limits{-10.0, 10.0};
  return {pi, gpi, dz, as};
}

// Triangle with decaying amplitudes around `centre` (the identification run).
std::vector<double> triangle(std::initializer_list<double> amplitudes, int per_leg, double centre = 0.0) {
  std::vector<double> x;
  for (double a : amplitudes) {
    for (int k = 0; k < per_leg; ++k) x.push_back(centre + a * k / per_leg);
    for (int k = 0; k < per_leg; ++k) x.push_back(centre + a * (1.0 - static_cast<double>(k) / per_leg));
  }
  return x;
}

// A record of another signal type: a sine with a slowly varying amplitude and offset (minor loops).
std::vector<double> wandering_sine(std::size_t n, double amplitude) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(n);
    const double a = amplitude * (0.35 + 0.25 * std::sin(2 * M_PI * 1.5 * t));
    x[k] = amplitude * 0.5 + a * std::sin(2 * M_PI * 9 * t) - amplitude * 0.5 * std::cos(2 * M_PI * 0.5 * t) * 0.3;
  }
  return x;
}

std::vector<double> noisy(std::vector<double> y, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, sigma);
  for (double& v : y) v += nd(rng);
  return y;
}

struct Record {
  std::vector<double> x, y;
};

// The transforms a user's record may differ by: offsets, scales, a flipped output.
struct Transform {
  const char* name;
  std::function<double(double)> fx, fy;
};
const std::vector<Transform>& transforms() {
  static const std::vector<Transform> t{
      {"identity", [](double v) { return v; }, [](double v) { return v; }},
      {"output offset", [](double v) { return v; }, [](double v) { return v + 3000.0; }},
      {"output negated", [](double v) { return v; }, [](double v) { return -v; }},
      {"output scaled", [](double v) { return v; }, [](double v) { return 1e-3 * v; }},
      {"input offset", [](double v) { return v + 101.3; }, [](double v) { return v; }},
      {"input scaled", [](double v) { return 1e3 * v; }, [](double v) { return v; }},
      {"all", [](double v) { return 7.5 * v - 40.0; }, [](double v) { return 55.0 - 300.0 * v; }},
  };
  return t;
}

Record apply(const Transform& t, const Record& r) {
  Record out;
  for (double v : r.x) out.x.push_back(t.fx(v));
  for (double v : r.y) out.y.push_back(t.fy(v));
  return out;
}

// Every kind fit() identifies; the PI family (which must never be worse than the
// reference PI, itself a PI).
const auto& kKinds = fit_model_kinds;
const FitModel kPiFamily[] = {FitModel::pi, FitModel::gpi, FitModel::mpi_deadzone, FitModel::mpi_asym};

FitOptions options_for(FitModel kind) {
  FitOptions o;
  o.model = kind;
  o.compute_covariance = false;
  o.num_threads = 1;
  o.sample_time = 1e-3;  // rate-pi
  return o;
}

// Validation RMS in % of span of `kind` fitted on train (range) and run on val.
double validation_error(FitModel kind, const Record& train, const Record& val, IndexRange range = {},
                        FitStatus* status = nullptr, IndexRange val_range = {}) {
  FitOptions o = options_for(kind);
  o.train = range;
  const FitReport r = fit(train.x, train.y, o);
  if (status) *status = r.status;
  EXPECT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence ||
              r.status == FitStatus::poor_fit)
      << fit_model_name(kind) << ": " << r.message;
  if (r.status == FitStatus::invalid_input || r.status == FitStatus::failed) return std::nan("");
  return evaluate(r.model, val.x, val.y, val_range).rms_percent_span;
}

// ../shared/data next to the checkout, or $HYSTERON_SHARED_DATA (a worktree elsewhere).
std::filesystem::path shared_data() {
  if (const char* dir = std::getenv("HYSTERON_SHARED_DATA"); dir && *dir) return dir;
  return std::filesystem::path(HYSTERON_SOURCE_DIR) / ".." / "shared" / "data";
}

// The Festo records' directory; a test that needs them skips where it is absent (a user's checkout).
std::filesystem::path festo_dir() { return shared_data() / "pam-force-pressure"; }
#define SKIP_WITHOUT_FESTO()                                                                  \
  if (!std::filesystem::exists(festo_dir() / "festo10mm_20cm_test8.csv"))                      \
  GTEST_SKIP() << "measured data not found at " << festo_dir()                                 \
               << " (../shared/data is absent in this checkout; HYSTERON_SHARED_DATA can name it)"

// Every `step`-th row of columns (in, out) of a shared record (read by hysteron's CSV reader).
Record shared_record(const std::filesystem::path& file, std::size_t in, std::size_t out, std::size_t step) {
  const std::vector<double> x = io::read_column(file.string(), std::to_string(in));
  const std::vector<double> y = io::read_column(file.string(), std::to_string(out));
  Record r;
  for (std::size_t k = 0; k < x.size(); k += step) r.x.push_back(x[k]), r.y.push_back(y[k]);
  return r;
}

}  // namespace

// ---- the units map ---------------------------------------------------------------

namespace {
// The mapped model on the raw inputs um.from_model(xm) (returned in xr) against the core on xm
// mapped to raw output: the largest relative deviation.
double map_deviation(const ModelParams& core, const ModelParams& mapped, const UnitsMap& um,
                     const std::vector<double>& xm, std::vector<double>& xr) {
  Model m0(core), m1(mapped);
  xr.clear();
  double worst = 0;
  for (double v : xm) {
    const double raw = um.from_model(v);
    xr.push_back(raw);
    const double expected = um.output(m0.step(v));
    worst = std::max(worst, std::abs(m1.step(raw) - expected) / (1 + std::abs(expected)));
  }
  return worst;
}

// Two models on the same inputs: the largest deviation of a from b, relative to 1 + |b|.
double relative_deviation(const ModelParams& a, const ModelParams& b, const std::vector<double>& x) {
  Model ma(a), mb(b);
  double dev = 0;
  for (double v : x) {
    const double ya = ma.step(v), yb = mb.step(v);
    dev = std::max(dev, std::abs(ya - yb) / (1 + std::abs(yb)));
  }
  return dev;
}
}  // namespace

TEST(UnitsMap, ModelAndInverseApplyTheMapExactly) {
  const UnitsMap um{3.0, 2.5, -7.0, -4.0};
  const std::vector<double> x = wandering_sine(3000, 8.0);
  for (const ModelParams& core : sample_models()) {
    ModelParams mapped = core;
    units_map(mapped) = um;
    if (std::holds_alternative<MpiAsymParams>(mapped)) std::get<MpiAsymParams>(mapped).input_limits = Limits{-22, 28};
    std::vector<double> xr;
    EXPECT_LT(map_deviation(core, mapped, um, x, xr), 1e-12) << model_name(core);
    // a negative gain makes the model decreasing; its inverse is still exact
    Model fwd(mapped);
    Inverse inv(mapped);
    double err = 0;
    for (double v : xr) err = std::max(err, std::abs(inv.step(fwd.step(v)) - v));
    EXPECT_LT(err, 1e-9) << model_name(core);
    // absorb_scales: the same model with input_scale 1 and |gain| 1
    const ModelParams absorbed = absorb_scales(mapped);
    EXPECT_EQ(units_map(absorbed).input_scale, 1.0);
    EXPECT_EQ(units_map(absorbed).output_gain, -1.0);
    EXPECT_LT(relative_deviation(absorbed, mapped, xr), 1e-11) << model_name(core);
  }
}

// A negative input_scale mirrors the input: y = off + g M((x - o) / s), s < 0. The model is
// the core run on the mirrored input, its inverse inverts it inside the raw input limits and
// saturates at the limit in the output's direction, absorb_scales keeps it mirrored, and the
// model file keeps it.
TEST(UnitsMap, NegativeInputScaleMirrorsTheInput) {
  const std::vector<double> xm = wandering_sine(3000, 8.0);  // model coordinates
  for (const UnitsMap um : {UnitsMap{3.0, -2.5, -7.0, -4.0}, UnitsMap{-1.0, -0.5, 2.0, 3.0}}) {
    for (const ModelParams& core : sample_models()) {
      SCOPED_TRACE(fmt::format("{}, input_scale {}, output_gain {}", model_name(core), um.input_scale, um.output_gain));
      ModelParams mapped = core;
      units_map(mapped) = um;
      // raw limits around the raw inputs (the core's in model coordinates: [-4, 13])
      const Limits raw{std::min(um.from_model(-4.0), um.from_model(13.0)), std::max(um.from_model(-4.0), um.from_model(13.0))};
      std::visit([&](auto& m) { m.input_limits = raw; }, mapped);
      ASSERT_NO_THROW(validate_model(mapped));
      EXPECT_TRUE(um.mirrored());
      EXPECT_EQ(um.increasing(), um.output_gain < 0);
      std::vector<double> xr;
      EXPECT_LT(map_deviation(core, mapped, um, xm, xr), 1e-12);
      // the inverse inverts it and respects the raw limits
      Model fwd(mapped);
      Inverse inv(mapped);
      EXPECT_EQ(inv.limits(), raw);
      double err = 0;
      for (double v : xr) {
        const double xi = inv.step(fwd.step(v));
        err = std::max(err, std::abs(xi - v));
        ASSERT_TRUE(xi >= raw.lo && xi <= raw.hi) << xi;
      }
      EXPECT_LT(err, 1e-9);
      // beyond any output: the limit in the output's direction (model hi is raw lo when mirrored)
      const double up = um.increasing() ? 1e12 : -1e12;
      EXPECT_EQ(inv.step(up), raw.hi);
      EXPECT_TRUE(inv.saturated());
      EXPECT_EQ(inv.step(-up), raw.lo);
      EXPECT_TRUE(inv.saturated());
      // absorb_scales keeps the mirror (input_scale -1)
      const ModelParams absorbed = absorb_scales(mapped);
      EXPECT_EQ(units_map(absorbed).input_scale, -1.0);
      EXPECT_EQ(units_map(absorbed).output_gain, um.output_gain < 0 ? -1.0 : 1.0);
      EXPECT_LT(relative_deviation(absorbed, mapped, xr), 1e-11);
      // the model file keeps it (and a round trip gives the same outputs)
      const ModelParams back = io::model_from_json(io::parse_json(io::model_to_json(mapped).dump(), "t"), "t");
      EXPECT_EQ(units_map(back), um);
      EXPECT_EQ(input_limits(back), raw);
      Model mr(back), mo(mapped);
      for (double v : xr) ASSERT_EQ(mr.step(v), mo.step(v));
    }
  }
}

TEST(UnitsMap, ModelFilesKeepTheMapAndOldFilesLoad) {
  for (ModelParams m : sample_models()) {
    units_map(m) = UnitsMap{1.5, 0.25, -3.0, -2.0};
    const auto j = io::model_to_json(m);
    EXPECT_EQ(j.at("input_origin").get<double>(), 1.5);
    EXPECT_EQ(j.at("output_gain").get<double>(), -2.0);
    EXPECT_EQ(units_map(io::model_from_json(j, "test")), units_map(m));
    // identity maps are not written; files without the keys load as the identity
    ModelParams plain = m;
    units_map(plain) = UnitsMap{};
    const auto jp = io::model_to_json(plain);
    EXPECT_FALSE(jp.contains("input_origin"));
    EXPECT_TRUE(units_map(io::model_from_json(jp, "test")).identity());
    auto bad = j;
    bad["input_scale"] = 0.0;
    try {
      io::model_from_json(bad, "bad.json");
      ADD_FAILURE() << "input_scale = 0 accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("input_scale"), std::string::npos) << e.what();
    }
    bad = j;
    bad["output_gain"] = 0.0;
    EXPECT_THROW(io::model_from_json(bad, "bad.json"), Error);
  }
}

// ---- equivariance --------------------------------------------------------------

// Fit on an identification run (triangles), validate on another signal type (a wandering
// sine), for every kind and every transform: the validation error in % of span moves by
// less than 1 % (relative).
TEST(Equivariance, SyntheticRecordsEveryKindEveryTransform) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record train, val;
  train.x = triangle({6, 4, 5, 2, 3.5, 1}, 200);
  val.x = wandering_sine(2400, 6.0);
  train.y = noisy(simulate_record(truth, train.x), 0.01, 1);
  val.y = noisy(simulate_record(truth, val.x), 0.01, 2);
  for (FitModel kind : kKinds) {
    const double ref = validation_error(kind, train, val);
    ASSERT_TRUE(std::isfinite(ref)) << fit_model_name(kind);
    for (const Transform& t : transforms()) {
      const double e = validation_error(kind, apply(t, train), apply(t, val));
      EXPECT_NEAR(e, ref, 0.01 * ref) << fit_model_name(kind) << " under " << t.name;
    }
  }
}

TEST(Equivariance, FestoRecordEveryKindEveryTransform) {
  SKIP_WITHOUT_FESTO();
  const auto dir = festo_dir();
  const Record train = shared_record(dir / "festo10mm_20cm_test8.csv", 1, 0, 3);
  const Record val = shared_record(dir / "festo10mm_20cm_test9.csv", 1, 0, 3);
  for (FitModel kind : kKinds) {
    const double ref = validation_error(kind, train, val);
    for (const Transform& t : transforms()) {
      if (std::string(t.name) == "identity") continue;
      const double e = validation_error(kind, apply(t, train), apply(t, val));
      EXPECT_NEAR(e, ref, 0.01 * ref) << fit_model_name(kind) << " under " << t.name;
    }
  }
}

// A negated input (a sensor wired the other way round) is a mirrored record: every kind's
// fit is the mirror image of the plain record's, so that it validates the same. The training
// range starts at a sample that is not 0 (the state at its start comes from the record).
// preisach and kp were not: relays / kernels alike over the training rows got their weight by
// the grid's order, which the mirror reverses (kp 6.0 % vs 21.7 % on the Festo record).
namespace {
Record input_negated(const Record& r) {
  Record out = r;
  for (double& v : out.x) v = -v;
  return out;
}

// Reversal curves from one top: a fast rise (2 samples) to top, a slow fall (per_leg
// samples) to each bottom in turn (pressure steps up, slow releases).
std::vector<double> reversal_curves(double start, double top, std::initializer_list<double> bottoms, int per_leg) {
  std::vector<double> x{start};
  for (double b : bottoms) {
    x.push_back(0.5 * (x.back() + top));
    for (int i = 0; i < per_leg; ++i) x.push_back(top + (b - top) * i / per_leg);
  }
  return x;
}

// a: the mpi-asym fit of a record, b: of the record with its input negated. b is a's mirror
// image: the same kind's parameters, the input's origin and scale negated (one of them
// mirrored), and the same predictions (bit for bit up to rounding) on val and on val negated.
void expect_mirror_images(const FitReport& a, const FitReport& b, const Record& val) {
  const auto& ma = std::get<MpiAsymParams>(a.model);
  const auto& mb = std::get<MpiAsymParams>(b.model);
  const auto rel = [](double u, double v) { return std::abs(u - v) / std::max({std::abs(u), std::abs(v), 1e-300}); };
  EXPECT_EQ(ma.units.input_scale, -mb.units.input_scale);
  EXPECT_EQ(ma.units.input_origin, -mb.units.input_origin);
  EXPECT_EQ(ma.units.output_gain, mb.units.output_gain);
  EXPECT_LT(rel(ma.units.output_offset, mb.units.output_offset), 1e-12);
  EXPECT_EQ(ma.input_limits.lo, -mb.input_limits.hi);
  EXPECT_EQ(ma.input_limits.hi, -mb.input_limits.lo);
  EXPECT_LT(rel(ma.q, mb.q), 1e-12) << ma.q << " plain, " << mb.q << " negated";
  ASSERT_EQ(ma.p.size(), mb.p.size());
  for (std::size_t i = 0; i < ma.p.size(); ++i) EXPECT_LT(rel(ma.p[i], mb.p[i]), 1e-12) << i;
  for (std::size_t i = 0; i < ma.r.size(); ++i) EXPECT_LT(rel(ma.r[i], mb.r[i]), 1e-12) << i;
  for (int k : {0, 1}) {
    const Envelope& e = k ? ma.descending : ma.ascending;
    const Envelope& f = k ? mb.descending : mb.ascending;
    EXPECT_EQ(e.kind, f.kind) << k;
    for (int c = 0; c < 4; ++c) EXPECT_LT(rel(e.c[c], f.c[c]), 1e-12) << k << " c" << c;
  }
  EXPECT_EQ(a.inverse.increasing, !b.inverse.increasing);
  EXPECT_LT(rel(a.train.rms, b.train.rms), 1e-12) << a.train.rms << " plain, " << b.train.rms << " negated";
  const std::vector<double> ya = simulate_record(a.model, val.x), yb = simulate_record(b.model, input_negated(val).x);
  double dev = 0, span = 0;
  for (std::size_t k = 0; k < ya.size(); ++k) dev = std::max(dev, std::abs(ya[k] - yb[k])), span = std::max(span, std::abs(ya[k]));
  EXPECT_LE(dev, 1e-12 * span) << "predictions of the plain and the negated record's fits";
}
}  // namespace

TEST(Equivariance, InputNegatedSyntheticEveryKind) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record train, val;
  // as the Festo records: relays alike over the training rows (all on by each step up)
  train.x = reversal_curves(0.7, 6.2, {3.0, 1.0, 0.0, 2.5, 1.2, 4.0, 0.6, 3.2, 1.8, 5.0, 0.3}, 150);
  val.x = wandering_sine(2400, 6.0);
  for (double& v : val.x) v += 0.4;  // starts elsewhere
  train.y = noisy(simulate_record(truth, train.x), 0.01, 8);
  val.y = noisy(simulate_record(truth, val.x), 0.01, 9);
  const IndexRange range{450, train.x.size()};
  for (FitModel kind : kKinds) {
    // mpi-asym included: its play max{u_a - r, min{u_d + r, y}} gives the ascending bound priority
    // where the envelopes cross by more than 2 r, so the mirror of a model is no mpi-asym; the fit
    // tries both orientations (the mirrored one as input_scale < 0) and keeps the better one (it
    // was 1.60 % plain vs 2.45 % negated here before it did)
    const double ref = validation_error(kind, train, val, range);
    ASSERT_TRUE(std::isfinite(ref)) << fit_model_name(kind);
    const double e = validation_error(kind, input_negated(train), input_negated(val), range);
    EXPECT_NEAR(e, ref, 0.01 * ref) << fit_model_name(kind) << ": " << ref << " % plain, " << e << " % negated";
  }
}

// A record whose first input lies inside its range (the Festo records start at their least
// pressure, the grid's lower edge, where the relaxed state is all off either way): preisach and kp
// start virgin, relaxed at the fitted origin inside the grid, and a negated input must give the
// mirrored fit. kp's relaxed ramps were centred half a grid cell low, so it did not: the piezo
// record from row 17000 trained at 0.340 % of span plain and 0.267 % negated.
TEST(Equivariance, InputNegatedRecordStartingInsideItsRange) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record train, val;
  train.x = reversal_curves(3.3, 6.2, {3.0, 1.0, 0.0, 2.5, 1.2, 4.0, 0.6, 3.2, 1.8, 5.0, 0.3}, 150);
  train.x.insert(train.x.begin(), 3.3);
  val.x = wandering_sine(2400, 6.0);
  train.y = noisy(simulate_record(truth, train.x), 0.01, 8);
  val.y = noisy(simulate_record(truth, val.x), 0.01, 9);
  for (FitModel kind : {FitModel::kp}) {
    FitOptions o = options_for(kind);
    const FitReport a = fit(train.x, train.y, o);
    const Record neg = input_negated(train);
    const FitReport b = fit(neg.x, neg.y, o);
    ASSERT_TRUE(has_model(a.status) && has_model(b.status)) << a.message << " / " << b.message;
    EXPECT_NEAR(b.train.rms, a.train.rms, 1e-6 * a.train.rms)
        << fit_model_name(kind) << ": train RMS " << a.train.rms << " plain, " << b.train.rms << " negated";
    const double va = evaluate(a.model, val.x, val.y).rms, vb = evaluate(b.model, input_negated(val).x, val.y).rms;
    EXPECT_NEAR(vb, va, 1e-6 * va) << fit_model_name(kind) << ": validation RMS " << va << " plain, " << vb
                                   << " negated";
  }
}

TEST(Equivariance, InputNegatedFestoEveryKind) {
  SKIP_WITHOUT_FESTO();
  const auto dir = festo_dir();
  // every 2nd row; trained on test8's rows 3000..15000 of the full record, validated on test9
  const Record train = shared_record(dir / "festo10mm_20cm_test8.csv", 1, 0, 2);
  const Record val = shared_record(dir / "festo10mm_20cm_test9.csv", 1, 0, 2);
  const IndexRange range{1500, train.x.size()};
  for (FitModel kind : kKinds) {
    const double ref = validation_error(kind, train, val, range);
    const double e = validation_error(kind, input_negated(train), input_negated(val), range);
    EXPECT_NEAR(e, ref, 0.01 * ref) << fit_model_name(kind) << ": " << ref << " % plain, " << e << " % negated";
  }
}

// mpi-asym's minimum-slope bound on q (the slope right after a reversal, q (gamma_a' + gamma_d') / 2)
// is relative to both envelopes' mean span, not to the ascending one's: a negated input swaps the
// branches, and the bound then moved with it (q on the bound: 0.020180 plain vs 0.020008 negated on
// test8 rows 3000..15000). The fit tries both orientations of the input (FitOptions::mpi_asym_mirror),
// so the negated record's fit is the plain one's mirror image: the same q, weights and envelopes, the
// input's origin and scale negated (input_scale < 0 on one of them), the same predictions. (Before the
// fit tried both, its envelopes were the plain fit's swapped and mirrored, which held only where the
// envelopes do not cross by more than 2 r.)
TEST(Equivariance, MpiAsymInputNegatedFestoIsTheMirroredModel) {
  SKIP_WITHOUT_FESTO();
  const auto dir = festo_dir();
  const Record plain = shared_record(dir / "festo10mm_20cm_test8.csv", 1, 0, 1);
  const Record neg = input_negated(plain);
  const Record val = shared_record(dir / "festo10mm_20cm_test9.csv", 1, 0, 1);
  FitOptions o = options_for(FitModel::mpi_asym);
  o.train = IndexRange{3000, 15000};
  const FitReport a = fit(plain.x, plain.y, o), b = fit(neg.x, neg.y, o);
  ASSERT_TRUE(has_model(a.status) && has_model(b.status)) << a.message << " / " << b.message;
  expect_mirror_images(a, b, val);
}

// The same on the whole of test8 (where the mirrored orientation validated better, 0.93 / 0.92 % of
// span on test9 / test10 against 0.98 / 0.94 %): whichever orientation the fit keeps, the fit of
// the negated record is its mirror image, and it is never worse in training than the plain
// orientation alone (FitOptions::mpi_asym_mirror = false).
TEST(Equivariance, MpiAsymInputNegatedFestoWholeRecord) {
  SKIP_WITHOUT_FESTO();
  const auto dir = festo_dir();
  const Record plain = shared_record(dir / "festo10mm_20cm_test8.csv", 1, 0, 1);
  const Record val = shared_record(dir / "festo10mm_20cm_test10.csv", 1, 0, 1);
  FitOptions o = options_for(FitModel::mpi_asym);
  const FitReport a = fit(plain.x, plain.y, o);
  const Record neg = input_negated(plain);
  const FitReport b = fit(neg.x, neg.y, o);
  ASSERT_TRUE(has_model(a.status) && has_model(b.status)) << a.message << " / " << b.message;
  expect_mirror_images(a, b, val);
  o.mpi_asym_mirror = false;
  const FitReport p = fit(plain.x, plain.y, o);
  ASSERT_TRUE(has_model(p.status)) << p.message;
  EXPECT_GT(units_map(p.model).input_scale, 0.0) << "the plain orientation only";
  EXPECT_LE(a.final_cost, p.final_cost);
  EXPECT_LE(a.train.rms, p.train.rms * (1 + 1e-12));
}

// A record of a known mirrored mpi-asym (input_scale -1: the descending bound takes priority
// where the envelopes cross), which no plain mpi-asym can express: the fit keeps the mirrored
// orientation, says so, trains better than the plain orientation alone, and the fit of the
// negated record (a plain mpi-asym's record) is its mirror image.
TEST(Equivariance, MpiAsymInputNegatedSyntheticMirroredTruth) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  truth.units = UnitsMap{0.0, -1.0, 0.0, -1.0};  // y = -M(-x): increasing in x
  Record train, val;
  train.x = reversal_curves(0.7, 6.2, {3.0, 1.0, 0.0, 2.5, 1.2, 4.0, 0.6, 3.2, 1.8, 5.0, 0.3}, 150);
  val.x = wandering_sine(2400, 6.0);
  train.y = noisy(simulate_record(truth, train.x), 0.01, 8);
  val.y = noisy(simulate_record(truth, val.x), 0.01, 9);
  FitOptions o = options_for(FitModel::mpi_asym);
  o.train = IndexRange{450, train.x.size()};
  const FitReport a = fit(train.x, train.y, o);
  ASSERT_TRUE(has_model(a.status)) << a.message;
  EXPECT_LT(units_map(a.model).input_scale, 0.0) << a.message;
  EXPECT_TRUE(a.inverse.increasing);
  EXPECT_NE(a.message.find("mirrored"), std::string::npos) << a.message;
  const Record neg = input_negated(train);
  const FitReport b = fit(neg.x, neg.y, o);
  ASSERT_TRUE(has_model(b.status)) << b.message;
  EXPECT_GT(units_map(b.model).input_scale, 0.0) << "the negated record is a plain mpi-asym's";
  EXPECT_FALSE(b.inverse.increasing);
  expect_mirror_images(a, b, val);
  o.mpi_asym_mirror = false;
  const FitReport p = fit(train.x, train.y, o);
  ASSERT_TRUE(has_model(p.status)) << p.message;
  EXPECT_GT(units_map(p.model).input_scale, 0.0);
  // in training (what the choice is made on) the mirrored orientation is strictly better
  EXPECT_LT(a.train.rms, p.train.rms) << "mirrored " << a.train.rms << ", plain only " << p.train.rms;
  EXPECT_LT(a.final_cost, p.final_cost);
  std::cerr << "train RMS mirrored " << a.train.rms << ", plain only " << p.train.rms << "; validation "
            << evaluate(a.model, val.x, val.y).rms << " / " << evaluate(p.model, val.x, val.y).rms << "\n";
}

// ---- no kind worse than the reference PI ---------------------------------------

TEST(ReferencePi, IsTheNnlsPiOfAPlainScript) {
  // Data from a PI with the reference's own structure, an offset and a relaxed start
  // away from 0: the reference recovers it exactly.
  const std::vector<double> x = triangle({6, 3, 5, 1.5}, 150, 20.0);
  PiParams truth;
  const double span = 26.0 - 20.0;
  for (int i = 1; i <= 10; ++i) truth.r.push_back(i * span / 20.0);
  truth.q = -0.1;  // free sign
  truth.p = {0.5, 0.0, 0.3, 0.0, 0.2, 0.1, 0.0, 0.05, 0.0, 0.02};
  truth.units.input_origin = 20.0;
  truth.units.output_offset = 42.0;
  const auto y = simulate_record(truth, x);
  const PiParams ref = reference_pi(x, y);
  EXPECT_LT(evaluate(ref, x, y).rms, 1e-9);
  EXPECT_NEAR(ref.q, truth.q, 1e-9);
  for (std::size_t i = 0; i < truth.p.size(); ++i) EXPECT_NEAR(ref.p[i], truth.p[i], 1e-9) << i;
  // sign-equivariant: a negated record gives the negated model
  std::vector<double> yn(y.size());
  for (std::size_t k = 0; k < y.size(); ++k) yn[k] = -y[k];
  EXPECT_LT(evaluate(reference_pi(x, yn), x, yn).rms, 1e-9);
  EXPECT_THROW(reference_pi(std::vector<double>(10, 1.0), std::span<const double>(y).subspan(0, 10)), Error);
}

// Every kind validates within 1.05x the reference PI on the shared records (fit on an
// identification run, validate on another), except the 8-parameter gpi on the piezo
// record, whose monotone weight law cannot take the U-shaped weights this record needs:
// there its fit must say so (poor_fit), never plain `converged`.
TEST(ReferencePi, NoKindWorseThanTheReferenceOnSharedRecords) {
  const auto festo = shared_data() / "pam-force-pressure";
  const auto piezo = shared_data() / "piezo-sine" / "piezo_150V_1Hz.csv";
  if (!std::filesystem::exists(festo / "festo10mm_20cm_test8.csv") || !std::filesystem::exists(piezo))
    GTEST_SKIP() << "measured data not found at " << shared_data() << " (../shared/data is absent in this checkout)";
  struct Case {
    const char* name;
    Record train, val;
    IndexRange range, val_range;
  };
  std::vector<Case> cases;
  cases.push_back({"festo", shared_record(festo / "festo10mm_20cm_test8.csv", 1, 0, 2),
                   shared_record(festo / "festo10mm_20cm_test9.csv", 1, 0, 2), {}, {}});
  {
    // piezo: every 2nd sample, fit on the sine's 2nd-4th periods, validate on the rest
    // (the record simulated from its start, so that the validation range has its memory)
    const Record all = shared_record(piezo, 3, 2, 2);
    cases.push_back({"piezo", all, all, {21286 / 2, 33143 / 2}, {33143 / 2, all.x.size()}});
  }
  for (const Case& c : cases) {
    // the reference validated the same way: simulated from the start of its own record
    const PiParams ref = reference_pi(c.train.x, c.train.y, c.range);
    const double ref_val = evaluate(ref, c.val.x, c.val.y, c.val_range).rms_percent_span;
    for (FitModel kind : kPiFamily) {
      FitStatus status = FitStatus::not_run;
      const double e = validation_error(kind, c.train, c.val, c.range, &status, c.val_range);
      if (std::string(c.name) == "piezo" && kind == FitModel::gpi) {
        EXPECT_EQ(status, FitStatus::poor_fit) << "gpi on the piezo: " << e << " % vs reference " << ref_val << " %";
        continue;
      }
      EXPECT_LE(e, 1.05 * ref_val) << c.name << " " << fit_model_name(kind) << ": " << e << " % vs reference "
                                   << ref_val << " %";
    }
  }
}

// ---- inverse slope, honest status ------------------------------------------------

// No fitted model's inverse is steeper than a stated bound: 1000 x span(x) / span(y)
// (min_slope = 0.02 caps the identity-envelope kinds at 50x); the reported jump is that
// slope times the output's steps at most.
TEST(FitChecks, InverseSlopeIsBoundedOnEveryKind) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record r;
  r.x = triangle({6, 4, 5, 2, 3.5, 1}, 200);
  r.y = noisy(simulate_record(truth, r.x), 0.01, 3);
  const double sx = 6.0;
  const double sy = *std::max_element(r.y.begin(), r.y.end()) - *std::min_element(r.y.begin(), r.y.end());
  double dy = 0;
  for (std::size_t k = 1; k < r.y.size(); ++k) dy = std::max(dy, std::abs(r.y[k] - r.y[k - 1]));
  for (FitModel kind : kKinds) {
    const FitReport rep = fit(r.x, r.y, options_for(kind));
    if (kind == FitModel::maxwell_slip) {
      // elasto-slide elements make clockwise loops only (y = k0 x + sum k_i (x - F[x]),
      // k_i >= 0): on these counterclockwise loops the fit is honestly poor
      EXPECT_EQ(rep.status, FitStatus::poor_fit) << rep.full_report();
      continue;
    }
    ASSERT_TRUE(rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence) << rep.full_report();
    EXPECT_TRUE(rep.inverse.increasing);
    EXPECT_GT(rep.inverse.max_slope, 0);
    EXPECT_LT(rep.inverse.max_slope, 1000 * sx / sy) << fit_model_name(kind);
    if (kind == FitModel::pi) {
      EXPECT_LE(rep.inverse.max_slope, sx / (0.02 * sy) * (1 + 1e-6));
    }
    // preisach: a relay that switches changes the output at once by its weight, so that
    // the inverse moves the input by up to max w / q for a small output step (kp, its
    // continuous form, has no such jump)
    if (kind != FitModel::preisach) {
      EXPECT_LE(rep.inverse.max_jump, rep.inverse.max_slope * dy * (1 + 1e-9) + 1e-12) << fit_model_name(kind);
    }
    EXPECT_GT(rep.inverse.max_input_step, 0);
  }
  // a flipped output gives a decreasing model with the same bound
  std::vector<double> yn(r.y.size());
  for (std::size_t k = 0; k < yn.size(); ++k) yn[k] = -r.y[k];
  const FitReport neg = fit(r.x, yn, options_for(FitModel::pi));
  EXPECT_FALSE(neg.inverse.increasing);
  EXPECT_LT(units_map(neg.model).output_gain, 0);
  EXPECT_LE(neg.inverse.max_slope, sx / (0.02 * sy) * (1 + 1e-6));
}

// The inverse-jump warning is the same for the same sensor at 1x and 10x the sample rate: the
// output's noise, and so the inverse's jitter, is the same per sample at any rate, while the
// input's steps shrink with the rate (before 2026-12-02, 10x the rate warned where 1x did not).
// (At 150 samples per leg 10 input steps are 6.7 % of the span, above the rule's 5 %: a noise
// whose jump falls between the two, 0.05 here, still warns at 1500 and not at 150.)
TEST(FitChecks, InverseJumpWarningDoesNotDependOnTheSampleRate) {
  const ModelParams truth = sample_models()[0];
  const auto warns = [](const FitReport& rep) {
    return std::any_of(rep.warnings.begin(), rep.warnings.end(), [](const std::string& w) {
      return w.find("the inverse driven by the measured output jumps") != std::string::npos;
    });
  };
  int warned = 0, quiet = 0;
  for (double sigma : {0.03, 0.15}) {
    bool verdict[2] = {false, false};
    for (int r = 0; r < 2; ++r) {
      const int per_leg = r == 0 ? 150 : 1500;
      const std::vector<double> x = triangle({6, 4, 5, 2, 3.5, 1}, per_leg);
      const std::vector<double> y = noisy(simulate_record(truth, x), sigma, 11);
      const FitReport rep = fit(x, y, options_for(FitModel::pi));
      ASSERT_TRUE(rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence) << rep.full_report();
      verdict[r] = warns(rep);
      std::printf("sigma %g per_leg %d: max_jump %.4g, max_input_step %.4g, max_slope %.4g, warns %d\n", sigma,
                  per_leg, rep.inverse.max_jump, rep.inverse.max_input_step, rep.inverse.max_slope, verdict[r]);
    }
    EXPECT_EQ(verdict[0], verdict[1]) << "sigma " << sigma;
    (verdict[0] ? warned : quiet) += 1;
  }
  // the test sees both verdicts
  EXPECT_EQ(warned, 1);
  EXPECT_EQ(quiet, 1);
}

TEST(FitChecks, UselessOrWorseThanReferenceIsPoorFit) {
  PiParams truth;  // wide loops: thresholds up to half the input span
  truth.q = 0.2;
  truth.r = {0.5, 1.0, 1.5, 2.0, 2.5, 3.0};
  truth.p = {0.3, 0.2, 0.2, 0.1, 0.1, 0.1};
  Record r;
  r.x = triangle({6, 4, 5, 2, 3.5, 1}, 200);
  r.y = noisy(simulate_record(truth, r.x), 0.01, 4);
  // a PI with 3 weights cannot follow these loops: worse than the 10-operator reference
  FitOptions o = options_for(FitModel::pi);
  o.num_operators = 3;
  const FitReport coarse = fit(r.x, r.y, o);
  EXPECT_EQ(coarse.status, FitStatus::poor_fit) << coarse.full_report();
  EXPECT_NE(coarse.message.find("reference PI"), std::string::npos) << coarse.full_report();
  EXPECT_FALSE(coarse.ok());
  o.poor_fit_ratio = 0;  // the check can be turned off
  EXPECT_NE(fit(r.x, r.y, o).status, FitStatus::poor_fit);
  // an output that is noise: no better than a straight line
  Record noise;
  noise.x = r.x;
  noise.y = noisy(std::vector<double>(r.x.size(), 0.0), 1.0, 5);
  for (FitModel kind : {FitModel::pi, FitModel::gpi}) {
    const FitReport rep = fit(noise.x, noise.y, options_for(kind));
    EXPECT_TRUE(rep.status == FitStatus::poor_fit || rep.status == FitStatus::failed)
        << fit_model_name(kind) << ": " << rep.full_report();
  }
}

// A record without hysteresis (a straight line, exact or with a little noise) is fitted as well by
// the line as by any kind: converged with a warning, not poor_fit; noise alone stays poor_fit above.
TEST(FitChecks, NoHysteresisIsConvergedWithAWarning) {
  const std::vector<double> x = triangle({6, 4, 5, 2, 3.5, 1}, 200);
  std::vector<double> line;
  for (double v : x) line.push_back(0.3 * v + 2.0);
  for (const double sigma : {0.0, 1e-3}) {
    const std::vector<double> y = sigma > 0 ? noisy(line, sigma, 6) : line;
    for (FitModel kind : {FitModel::pi, FitModel::kp}) {
      const FitReport rep = fit(x, y, options_for(kind));
      EXPECT_EQ(rep.status, FitStatus::converged) << fit_model_name(kind) << " sigma " << sigma << ": " << rep.full_report();
      EXPECT_TRUE(std::any_of(rep.warnings.begin(), rep.warnings.end(),
                              [](const std::string& w) { return w.find("no hysteresis") != std::string::npos; }))
          << fit_model_name(kind) << " sigma " << sigma << ": " << rep.full_report();
    }
  }
  // a narrow but real loop (a line leaves less than 1 % of the span, the model far less) is not
  // called hysteresis-free: a play of radius 0.05 on a 5-unit span
  PiParams narrow;
  narrow.r = {0.0, 0.05};
  narrow.p = {0.3, 1.0};
  const std::vector<double> yn = simulate_record(ModelParams{narrow}, x, InitialState::virgin);
  const FitReport rn = fit(x, yn, options_for(FitModel::pi));
  EXPECT_EQ(rn.status, FitStatus::converged) << rn.full_report();
  EXPECT_FALSE(std::any_of(rn.warnings.begin(), rn.warnings.end(),
                           [](const std::string& w) { return w.find("no hysteresis") != std::string::npos; }))
      << rn.full_report();
}

// auto refuses a constant output as every kind does; a candidate that could not run has no metrics.
TEST(FitAuto, ConstantOutputIsRefusedAndUnrunCandidatesHaveNoMetrics) {
  const std::vector<double> x = triangle({6, 4, 5, 2}, 100);
  FitOptions o = options_for(FitModel::automatic);
  const FitReport c = fit(x, std::vector<double>(x.size(), 5.0), o);
  EXPECT_EQ(c.status, FitStatus::invalid_input) << c.full_report();
  EXPECT_NE(c.message.find(fmt::format("the output is constant (5) over the training range, samples 0..{} ({} samples)",
                                       x.size(), x.size())),
            std::string::npos)
      << c.message;
  // refused: no sensor-fault warnings on what was not fitted (a review of 2026-12-03: "the output sensor clips
  // there ... the model is fitted to the limit there", and its rows in fault_runs)
  for (const FitModel kind : {FitModel::automatic, FitModel::gpi}) {
    const FitReport k = fit(x, std::vector<double>(x.size(), 5.0), options_for(kind));
    EXPECT_EQ(k.status, FitStatus::invalid_input);
    EXPECT_TRUE(k.fault_runs.empty()) << k.full_report();
    EXPECT_FALSE(std::any_of(k.warnings.begin(), k.warnings.end(),
                             [](const std::string& w) { return w.find("clips") != std::string::npos; }))
        << k.full_report();
  }
  o.sample_time = 0;  // rate-pi cannot run
  std::vector<double> y;
  for (double v : x) y.push_back(std::tanh(0.3 * v) + 0.05 * v);
  const FitReport rep = fit(x, y, o);
  bool seen = false;
  for (const auto& cand : rep.candidates)
    if (cand.kind == FitModel::rate_pi) {
      seen = true;
      EXPECT_FALSE(has_model(cand.status));
      EXPECT_TRUE(std::isnan(cand.train.rms) && std::isnan(cand.train.r2)) << cand.train.rms;
      EXPECT_TRUE(std::isnan(cand.holdout.rms) && std::isnan(cand.holdout.r2)) << cand.holdout.rms;
    }
  EXPECT_TRUE(seen);
}

// ---- auto ---------------------------------------------------------------------------

// auto reports each candidate fit as it ends (the CLI shows them on a terminal): one call per kind
// and fold, counting 1..total in order, total twice the candidates the report lists.
TEST(FitAuto, ReportsEachCandidateFitAsItEnds) {
  const std::vector<double> x = triangle({6, 4, 5, 2}, 100);
  std::vector<double> y;
  for (double v : x) y.push_back(std::tanh(0.3 * v) + 0.05 * v);
  FitOptions o = options_for(FitModel::automatic);
  o.num_threads = 0;
  std::vector<std::size_t> done, totals;
  std::map<FitModel, int> kinds;
  o.candidate_done = [&](std::size_t d, std::size_t total, FitModel kind) {
    done.push_back(d);
    totals.push_back(total);
    ++kinds[kind];
  };
  const FitReport rep = fit(x, y, o);
  ASSERT_FALSE(rep.candidates.empty()) << rep.full_report();
  const std::size_t total = 2 * rep.candidates.size();
  ASSERT_EQ(done.size(), total);
  for (std::size_t i = 0; i < total; ++i) {
    EXPECT_EQ(done[i], i + 1);
    EXPECT_EQ(totals[i], total);
  }
  EXPECT_EQ(kinds.size(), rep.candidates.size());
  for (const auto& c : rep.candidates) EXPECT_EQ(kinds[c.kind], 2) << fit_model_name(c.kind);
}


TEST(FitAuto, ChoosesOnTheHoldOutAndValidatesNearTheBestKind) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record train, val;
  train.x = triangle({6, 4, 5, 2, 3.5, 1, 5.5, 3}, 150);
  val.x = wandering_sine(2400, 6.0);
  train.y = noisy(simulate_record(truth, train.x), 0.01, 6);
  val.y = noisy(simulate_record(truth, val.x), 0.01, 7);
  FitOptions o = options_for(FitModel::automatic);
  o.num_threads = 0;
  const FitReport rep = fit(train.x, train.y, o);
  ASSERT_TRUE(rep.status == FitStatus::converged || rep.status == FitStatus::no_convergence) << rep.full_report();
  ASSERT_EQ(rep.candidates.size(), std::size(fit_model_kinds));
  int chosen = 0;
  const FitCandidate* best = nullptr;
  for (const auto& c : rep.candidates) {
    chosen += c.chosen;
    if (c.chosen) best = &c;
    EXPECT_GT(c.holdout.n, 0u) << fit_model_name(c.kind);
  }
  ASSERT_EQ(chosen, 1);
  EXPECT_EQ(rep.model_kind, best->kind);
  // the least score, or within 2 % of it with fewer parameters than every kind scored there
  double least = INFINITY;
  for (const auto& c : rep.candidates)
    if (std::isfinite(c.holdout_score)) least = std::min(least, c.holdout_score);
  EXPECT_LE(best->holdout_score, 1.02 * least);
  for (const auto& c : rep.candidates) {
    EXPECT_GT(c.num_parameters, 0u) << fit_model_name(c.kind);
    if (std::isfinite(c.holdout_score) && c.holdout_score <= 1.02 * least) {
      EXPECT_LE(best->num_parameters, c.num_parameters) << fit_model_name(c.kind);
    }
  }
  EXPECT_GE(best->holdout_score, 1.0);
  const double e_auto = evaluate(rep.model, val.x, val.y).rms_percent_span;
  double e_best = std::numeric_limits<double>::infinity();
  for (FitModel kind : kKinds) e_best = std::min(e_best, validation_error(kind, train, val));
  EXPECT_LE(e_auto, 1.05 * e_best) << "auto chose " << fit_model_name(rep.model_kind);
}

// Two folds cannot tell apart kinds whose scores differ by a few per cent (gpi and kp on the
// Festo record, 0.3 % apart, swapped their order when kp's least squares used other rows):
// within 2 % of the least score the kind with the fewest parameters is chosen.
TEST(FitAuto, ATieOnTheHoldOutGoesToTheFewestParameters) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto choose = [](std::vector<double> s, std::vector<std::size_t> p) {
    return detail::auto_choice(s, p, 0.02);
  };
  auto c = choose({1.808, 1.802, 1.87}, {12, 60, 56});
  EXPECT_EQ(c.by_score, 1u);
  EXPECT_EQ(c.chosen, 0u);
  c = choose({1.85, 1.802, 1.81}, {12, 60, 30});  // 2.7 % is no tie; 0.4 % is
  EXPECT_EQ(c.by_score, 1u);
  EXPECT_EQ(c.chosen, 2u);
  c = choose({1.0, 1.01, 1.005}, {10, 10, 10});  // equal counts: the least score
  EXPECT_EQ(c.chosen, 0u);
  c = choose({1.015, 1.0, 1.002}, {10, 20, 10});  // of the fewest, the least score
  EXPECT_EQ(c.chosen, 2u);
  c = choose({nan, 1.3, 1.0, nan}, {1, 20, 20, 2});  // no score, no choice
  EXPECT_EQ(c.by_score, 2u);
  EXPECT_EQ(c.chosen, 2u);
  c = choose({nan, nan}, {1, 2});
  EXPECT_EQ(c.by_score, 2u);
  EXPECT_EQ(c.chosen, 2u);
}

// With --huber the candidates are scored on the hold-outs under the Huber loss (sqrt of twice
// the mean loss), as the fits and the poor-fit rule judge them; plain RMS let outliers in a
// hold-out, which no kind predicts, flatten that fold's ratios. Each candidate's score is
// recomputed here from its definition, with the two folds fitted by the public fit().
TEST(FitAuto, HuberScoresTheHoldOutsUnderTheLoss) {
  MpiAsymParams truth = std::get<MpiAsymParams>(sample_models()[3]);
  Record r;
  r.x = triangle({6, 4, 5, 2, 3.5, 1, 5.5, 3}, 100);
  r.y = noisy(simulate_record(truth, r.x), 0.01, 6);
  const auto [lo, hi] = std::minmax_element(r.y.begin(), r.y.end());
  const double span = *hi - *lo;
  for (std::size_t k = 5; k < r.y.size(); k += 37) r.y[k] += (k % 2 ? 0.3 : -0.3) * span;  // outliers
  FitOptions o = options_for(FitModel::automatic);
  o.huber_delta = 0.02 * span;
  o.num_threads = 0;
  const FitReport rep = fit(r.x, r.y, o);
  ASSERT_TRUE(has_model(rep.status)) << rep.full_report();
  EXPECT_NE(rep.message.find("Huber RMS (delta"), std::string::npos) << rep.message;
  const std::size_t m = r.x.size(), h = static_cast<std::size_t>(std::llround(o.holdout_fraction * m));
  const IndexRange fit_range[2] = {{0, m - h}, {h, m}}, hold_range[2] = {{m - h, m}, {0, h}};
  const auto huber_rms = [&](const ModelParams& model, IndexRange range) {
    const std::vector<double> yp = simulate_record(model, std::span<const double>(r.x).subspan(0, range.end));
    double sum = 0;
    for (std::size_t i = range.begin; i < range.end; ++i) {
      const double a = std::abs(r.y[i] - yp[i]);
      sum += a <= o.huber_delta ? a * a : 2 * o.huber_delta * a - o.huber_delta * o.huber_delta;
    }
    return std::sqrt(sum / static_cast<double>(range.end - range.begin));
  };
  ASSERT_EQ(rep.candidates.size(), std::size(fit_model_kinds));
  std::vector<std::array<double, 2>> e(rep.candidates.size());
  double best[2] = {INFINITY, INFINITY};
  for (std::size_t c = 0; c < rep.candidates.size(); ++c)
    for (int f = 0; f < 2; ++f) {
      FitOptions oc = o;
      oc.model = rep.candidates[c].kind;
      oc.train = fit_range[f];
      oc.num_threads = 1;
      const FitReport fr = fit(r.x, r.y, oc);
      e[c][f] = has_model(fr.status) ? huber_rms(fr.model, hold_range[f]) : NAN;
      if (std::isfinite(e[c][f])) best[f] = std::min(best[f], e[c][f]);
    }
  const double eps = 1e-12 * span;
  int compared = 0;
  for (std::size_t c = 0; c < rep.candidates.size(); ++c) {
    if (!std::isfinite(e[c][0]) || !std::isfinite(e[c][1])) continue;
    const double expected = std::sqrt((e[c][0] + eps) / (best[0] + eps) * (e[c][1] + eps) / (best[1] + eps));
    EXPECT_NEAR(rep.candidates[c].holdout_score, expected, 1e-9 * expected) << fit_model_name(rep.candidates[c].kind);
    ++compared;
  }
  EXPECT_GE(compared, 5);
}
