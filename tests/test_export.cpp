// Generated C (hysteron export, include/hysteron/io/export_c.hpp) against the library:
// for every model kind, generate the C file, compile it with gcc -std=c99 -pedantic
// -Wall -Wextra -Werror -O2 together with tests/export/driver.c, run forward and
// inverse over 10^5 random samples from random resets and states, and compare with
// hysteron::Model / hysteron::Inverse fed the same inputs.
//
// Error measure ("relative"): |c - lib| / max(|lib|, S), S = the largest |lib| of the same
// quantity (forward outputs, resp. inverse inputs) over the whole run, so that values
// crossing zero are measured against the signal's scale. Must be <= 1e-12; the
// saturation flags and fault counts must be equal. The generated code transcribes
// the library's arithmetic, so on x86-64 every result must also be bit-identical.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "export_loop_util.hpp"
#include "hysteron/error.hpp"
#include "hysteron/inverse.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/results.hpp"
#include "hysteron/models.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hysteron;

bool have(const char* compiler) { return std::system(fmt::format("{} --version > /dev/null 2>&1", compiler).c_str()) == 0; }
using test::have_gcc;

struct Case {
  std::string name;
  std::string json;
  double x_lo, x_hi;      // raw input range of the random signals
  Limits inverse_limits;  // ExportOptions / InverseOptions override
  bool single = false;    // one .c #included by the driver (else .c + .h)
};

std::vector<Case> all_cases() {
  const Limits none;
  return {
      {"pi", R"({"model": "pi", "q": 0.4, "r": [0, 0.1, 0.25, 0.5, 0.7], "p": [0.3, 0.2, 0.15, 0.1, 0.05],
                 "input_limits": [-1, 1.5]})", -1.5, 2.0, none},
      {"pi_no_operators", R"({"model": "pi", "q": 0.7, "r": [], "p": []})", -3.0, 3.0, none},
      {"pi_units_unbounded", R"({"model": "pi", "q": 0.09, "r": [28.8, 57.6, 80, 130], "p": [0.72, -0.04, 0.1, 0.2],
                 "input_origin": 8.18, "output_offset": -40.0, "output_gain": -1})", -200.0, 650.0, none},
      {"gpi_tanh", R"({"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10,
                 "rho": 0.3, "tau": 1.5, "alpha": 0.05})", -4.0, 4.0, none},
      {"gpi_atan_free", R"({"model": "gpi", "envelope": "atan", "c": [0.9, 1.1, -0.2, 0], "q": 0.4,
                 "r": [0.05, 0.1, 0.3], "p": [0.2, 0.03, 0.05], "input_limits": [-2, 2]})", -3.0, 3.0, none},
      {"gpi_affine_limits_override", R"({"model": "gpi", "envelope": "affine", "c": [0.13, 0.02], "q": 0.8, "n": 7,
                 "rho": 0.05, "tau": 0.02, "alpha": 10})", -150.0, 150.0, Limits{-120.0, 110.0}},
      {"gpi_tanh_units_negative_gain", R"({"model": "gpi", "envelope": "tanh", "c": [1.3, 1.7, -0.4, 0.1], "q": 0.6,
                 "n": 9, "rho": 0.4, "tau": 2.0, "alpha": 0.06, "input_origin": 8.18, "input_scale": 616.12,
                 "output_offset": -40.0, "output_gain": -25.5, "input_limits": [8.18, 624.3]})", -50.0, 700.0, none},
      {"mpi_deadzone", R"({"model": "mpi-deadzone", "q": 0.8, "r": [0.1, 0.2, 0.3], "p": [0.3, 0.1, 0.05], "g0": 1,
                 "z": [-0.5, 0.25, 0.6], "g": [0.2, 0.3, 0.1], "input_limits": [-1.5, 1.5]})", -2.0, 2.0, none},
      {"mpi_deadzone_units", R"({"model": "mpi-deadzone", "q": 1.1, "r": [0.3, 0.6, 0.9, 1.2, 1.5, 1.8], "p": [0.3, 0.2, 0.1, 0.1, 0.05, 0.05],
                 "g0": 0.9, "z": [], "g": [], "input_origin": -3, "input_scale": 2.5, "output_offset": 7,
                 "output_gain": -0.25})", -10.0, 4.0, none},
      {"mpi_asym", R"({"model": "mpi-asym", "q": 0.6, "r": [0.05, 0.15, 0.3, 0.45, 0.6, 0.8], "p": [0.2, 0.1, 0.1, 0.05, 0.05, 0.02],
                 "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]},
                 "descending": {"envelope": "affine", "c": [0.9, 0.1]}, "input_limits": [-2, 2]})", -2.5, 2.5, none},
      {"mpi_asym_atan_units", R"({"model": "mpi-asym", "q": 0.5, "r": [0.1, 0.2, 0.35], "p": [0.3, 0.2, 0.1],
                 "ascending": {"envelope": "atan", "c": [0.8, 1.2, 0.1, 0]},
                 "descending": {"envelope": "tanh", "c": [1.1, 0.9, -0.1, 0.05]},
                 "input_origin": 0.2, "input_scale": 0.3, "output_offset": 5, "output_gain": -2,
                 "input_limits": [-0.3, 0.8]})", -0.5, 1.0, none},
      // mirrored inputs (input_scale < 0): the descending bound takes priority where the envelopes
      // cross; the limits swap in model coordinates
      {"mpi_asym_mirrored", R"({"model": "mpi-asym", "q": 0.5, "r": [0.1, 0.2, 0.35], "p": [0.3, 0.2, 0.1],
                 "ascending": {"envelope": "tanh", "c": [2, 0.5, -0.5, 1]},
                 "descending": {"envelope": "tanh", "c": [1.8, 0.45, -0.3, 1]},
                 "input_origin": 0.2, "input_scale": -0.3, "output_offset": 5, "output_gain": -2,
                 "input_limits": [-0.3, 0.8]})", -0.5, 1.0, none},
      {"gpi_tanh_mirrored_decreasing", R"({"model": "gpi", "envelope": "tanh", "c": [1.3, 1.7, -0.4, 0.1], "q": 0.6,
                 "n": 9, "rho": 0.4, "tau": 2.0, "alpha": 0.06, "input_origin": 8.18, "input_scale": -616.12,
                 "output_offset": -40.0, "output_gain": 25.5, "input_limits": [-600, 8.18]})", -700.0, 50.0, none},
      {"pi_mirrored_unbounded", R"({"model": "pi", "q": 0.09, "r": [28.8, 57.6, 80, 130], "p": [0.72, -0.04, 0.1, 0.2],
                 "input_origin": 8.18, "input_scale": -1, "output_offset": -40.0, "output_gain": -1})", -200.0, 650.0,
                 Limits{-150.0, std::numeric_limits<double>::infinity()}},
      {"mpi_asym_equal_envelopes", R"({"model": "mpi-asym", "q": 0.6, "r": [0.05, 0.15], "p": [0.2, 0.1],
                 "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]},
                 "descending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]}, "input_limits": [-2, 2]})", -2.5, 2.5, none},
  };
}

std::vector<Case> cases() {
  std::vector<Case> v = all_cases();
  for (std::size_t i = 0; i < v.size(); ++i) v[i].single = i % 2 == 1;
  return v;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

ModelParams params_of(const Case& c) { return io::model_from_json(io::parse_json(c.json, c.name), c.name); }

// Exact text of a double for the driver (C99 hex float; nan, inf, -inf).
std::string hex(double v) { return test::hexf(v); }

struct Expected {
  char op;
  double value = 0.0;
  int flag = 0;           // saturated (I), rc (R, S: model rc)
  int flag2 = 0;          // S: inverse rc
  std::size_t faults = 0;
};

struct Script {
  std::string script;
  std::vector<Expected> expected;
  std::size_t forward = 0, inverse = 0;
  bool bounded = false;  // the inverse has finite limits (it can saturate)
  std::size_t saturated = 0, nonfinite = 0, virgin = 0, relaxed = 0, states = 0, unreachable = 0;
  std::size_t huge = 0, refused_relaxed = 0;  // finite inputs beyond any output (+-1e300.. +-DBL_MAX)
};

// Random resets and signals, with the library's results.
Script make_run(const Case& c, std::size_t samples, unsigned seed) {
  const ModelParams params = params_of(c);
  Model model(params);
  Inverse inv(params, InverseOptions{c.inverse_limits});
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double span = c.x_hi - c.x_lo;
  auto random_x = [&] { return c.x_lo + span * unit(rng); };
  Script run;
  std::string& s = run.script;
  s.reserve(samples * 60);
  const std::size_t n = model.num_operators();
  double out_span = 1.0;
  while (run.forward < samples) {
    // a reset
    const double pick = unit(rng);
    if (pick < 0.03) {
      // a refused relaxed start over garbage (the struct never initialised): the virgin state
      // (-DBL_MAX: refused where the output could overflow, taken by a bounded envelope)
      const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::max()};
      const double x0 = bad[static_cast<int>(unit(rng) * 4) % 4];
      const bool accepted = model.reset_relaxed(x0);
      if (!std::isfinite(x0)) {
        EXPECT_FALSE(accepted) << c.name << ": reset_relaxed accepted " << x0;
      }
      s += "n " + hex(x0) + "\n";
      if (accepted) {
        inv.reset(model.state());
        run.expected.push_back({'N', 0.0, 0, 0, 0});
      } else {
        ++run.refused_relaxed;
        model.reset();
        inv.reset();
        run.expected.push_back({'N', 0.0, -1, -1, 0});
      }
    } else if (pick < 0.25) {
      s += "v\n";
      ++run.virgin;
      model.reset();
      inv.reset();
    } else if (pick < 0.5) {
      const double x0 = random_x();
      s += "r " + hex(x0) + "\n";
      ++run.relaxed;
      model.reset_relaxed(x0);
      inv.reset(model.state());
      run.expected.push_back({'R', 0.0, 0, 0, 0});
    } else if (pick < 0.95 || n == 0) {
      // a reachable state: a model driven from rest by a random walk
      Model helper(params);
      helper.reset_relaxed(random_x());
      double x = random_x();
      const int len = 1 + static_cast<int>(unit(rng) * 300);
      for (int k = 0; k < len; ++k) {
        x = std::clamp(x + 0.2 * span * (unit(rng) - 0.5), c.x_lo, c.x_hi);
        helper.step(x);
      }
      const ModelState st = helper.state();
      ++run.states;
      s += "s " + hex(st.u);
      for (double v : st.y) s += " " + hex(v);
      s += "\n";
      model.reset(st);
      inv.reset(st);
      run.expected.push_back({'S', 0.0, 0, 0, 0});
    } else {
      // an unreachable state: the inverse refuses it (the model takes any finite state);
      // then both restart from a reachable one
      ++run.unreachable;
      ModelState st = model.state();
      st.u = 0.1;
      st.y.assign(n, 0.1);
      st.y[0] = 0.1 + 3.0 * model.structure().r[0] + 1.0;
      s += "s " + hex(st.u);
      for (double v : st.y) s += " " + hex(v);
      s += "\n";
      model.reset(st);
      EXPECT_THROW(inv.reset(st), hysteron::Error);
      run.expected.push_back({'S', 0.0, 0, -1, 0});
      st.y.assign(n, 0.1);
      s += "s " + hex(st.u);
      for (double v : st.y) s += " " + hex(v);
      s += "\n";
      model.reset(st);
      inv.reset(st);
      run.expected.push_back({'S', 0.0, 0, 0, 0});
    }
    // a segment: random walk with jumps, now and then a non-finite sample; the inverse
    // follows the model's output, sometimes pushed far beyond the reachable range
    const std::size_t len = std::min<std::size_t>(samples - run.forward, 200 + static_cast<std::size_t>(unit(rng) * 3000));
    double x = random_x();
    const double step = span * (0.002 + 0.1 * unit(rng));
    for (std::size_t k = 0; k < len; ++k) {
      const double a = unit(rng);
      if (a < 0.01) x = random_x();
      else x = std::clamp(x + step * (unit(rng) - 0.5), c.x_lo, c.x_hi);
      double xin = x;
      const double huge[] = {1e300, 1e307, 1e308, std::numeric_limits<double>::max()};
      auto pick_huge = [&] { return (unit(rng) < 0.5 ? -1.0 : 1.0) * huge[static_cast<int>(unit(rng) * 4) % 4]; };
      if (a > 0.9995) xin = std::numeric_limits<double>::quiet_NaN();
      else if (a > 0.999) xin = -std::numeric_limits<double>::infinity();
      else if (a > 0.998) xin = pick_huge(), ++run.huge;
      s += "f " + hex(xin) + "\n";
      const double y = model.step(xin);
      out_span = std::max(out_span, std::abs(y));
      run.expected.push_back({'F', y, 0, 0, model.faults()});
      ++run.forward;
      double yd = y;
      const double b = unit(rng);
      if (b < 0.05) yd = y + 3.0 * out_span * (unit(rng) - 0.5);
      else if (b < 0.06) yd = (unit(rng) < 0.5 ? -1.0 : 1.0) * 10.0 * out_span;
      else if (b < 0.065) yd = pick_huge(), ++run.huge;
      else if (b > 0.9995) yd = std::numeric_limits<double>::quiet_NaN();
      s += "i " + hex(yd) + "\n";
      const double xi = inv.step(yd);
      EXPECT_TRUE(std::isfinite(y) && std::isfinite(xi)) << c.name << ": x = " << xin << " -> " << y << ", y = " << yd
                                                         << " -> " << xi;
      // a desired output of 1e300 or more is beyond any output of these models: the limit in its direction
      const Limits& lim = inv.limits();
      if (std::abs(yd) >= 1e300 && std::isfinite(lim.lo) && std::isfinite(lim.hi)) {
        const bool up = (yd > 0) == model.structure().units.increasing();
        EXPECT_EQ(xi, up ? lim.hi : lim.lo) << c.name << ": y = " << yd;
        EXPECT_TRUE(inv.saturated()) << c.name << ": y = " << yd;
      }
      run.expected.push_back({'I', xi, inv.saturated() ? 1 : 0, 0, inv.faults()});
      run.saturated += inv.saturated();
      run.nonfinite += !std::isfinite(xin) + !std::isfinite(yd);
      ++run.inverse;
    }
  }
  s += "l\n";
  run.bounded = std::isfinite(inv.limits().lo) || std::isfinite(inv.limits().hi);
  run.expected.push_back({'L', inv.limits().lo, 0, 0, 0});
  run.expected.push_back({'l', inv.limits().hi, 0, 0, 0});
  return run;
}

struct Compared {
  double forward_err = 0.0, inverse_err = 0.0;  // largest relative error (see the top)
  std::size_t forward_exact = 0, inverse_exact = 0, forward = 0, inverse = 0;
  std::size_t mismatches = 0;  // flags, fault counts, return codes, limits
  std::string first_mismatch;
};

Compared compare(const Script& run, const std::string& output) {
  Compared r;
  std::istringstream in(output);
  double f_scale = 0.0, i_scale = 0.0;
  for (const Expected& e : run.expected) {
    if (e.op == 'F' && std::isfinite(e.value)) f_scale = std::max(f_scale, std::abs(e.value));
    if (e.op == 'I' && std::isfinite(e.value)) i_scale = std::max(i_scale, std::abs(e.value));
  }
  auto mismatch = [&](const std::string& what) {
    if (r.mismatches++ == 0) r.first_mismatch = what;
  };
  std::string line;
  std::size_t k = 0;
  while (k < run.expected.size()) {
    const Expected& e = run.expected[k];
    if (!std::getline(in, line)) {
      mismatch(fmt::format("output ends at result {} of {}", k, run.expected.size()));
      break;
    }
    std::istringstream ls(line);
    std::string op;
    ls >> op;
    auto read_double = [&] {
      std::string t;
      ls >> t;
      return std::strtod(t.c_str(), nullptr);
    };
    auto rel = [](double c, double lib, double scale) {
      if (c == lib) return 0.0;
      if (!std::isfinite(c) || !std::isfinite(lib)) return std::numeric_limits<double>::infinity();
      return std::abs(c - lib) / std::max(std::abs(lib), scale);
    };
    if (e.op == 'F') {
      const double c = read_double();
      std::size_t faults = 0;
      ls >> faults;
      if (op != "F") mismatch(fmt::format("result {}: expected F, got \"{}\"", k, line));
      const double err = rel(c, e.value, f_scale);
      r.forward_err = std::max(r.forward_err, err);
      r.forward_exact += c == e.value;
      ++r.forward;
      if (faults != e.faults) mismatch(fmt::format("result {}: forward faults {} vs {}", k, faults, e.faults));
    } else if (e.op == 'I') {
      const double c = read_double();
      int sat = 0;
      std::size_t faults = 0;
      ls >> sat >> faults;
      if (op != "I") mismatch(fmt::format("result {}: expected I, got \"{}\"", k, line));
      const double err = rel(c, e.value, i_scale);
      r.inverse_err = std::max(r.inverse_err, err);
      r.inverse_exact += c == e.value;
      ++r.inverse;
      if (sat != e.flag) mismatch(fmt::format("result {}: saturated {} vs {} (x = {} vs {})", k, sat, e.flag, c, e.value));
      if (faults != e.faults) mismatch(fmt::format("result {}: inverse faults {} vs {}", k, faults, e.faults));
    } else if (e.op == 'N') {
      int rm = 0, ri = 0;
      ls >> rm >> ri;
      if (op != "N" || rm != e.flag || ri != e.flag2)
        mismatch(fmt::format("result {}: \"{}\", expected N {} {}", k, line, e.flag, e.flag2));
    } else if (e.op == 'R') {
      int rc = 1;
      ls >> rc;
      if (op != "R" || rc != 0) mismatch(fmt::format("result {}: \"{}\", expected R 0", k, line));
    } else if (e.op == 'S') {
      int rm = 1, ri = 1;
      ls >> rm >> ri;
      if (op != "S" || rm != e.flag || ri != e.flag2)
        mismatch(fmt::format("result {}: \"{}\", expected S {} {}", k, line, e.flag, e.flag2));
    } else if (e.op == 'L') {
      const double lo = read_double(), hi = read_double();
      if (op != "L" || lo != e.value || hi != run.expected[k + 1].value)
        mismatch(fmt::format("limits [{}, {}] vs [{}, {}]", lo, hi, e.value, run.expected[k + 1].value));
      ++k;
    }
    ++k;
  }
  return r;
}

// A scratch directory for one case, removed at the end.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / fmt::format("hysteron_export_{}_{}", name, static_cast<unsigned>(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void write(const fs::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary);
  f << text;
}

std::string read(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

const std::string kFlags = "-std=c99 -pedantic -Wall -Wextra -Werror -O2";

// Compiles driver.c with the generated files in `dir`; returns "" or the compiler's messages.
std::string compile(const fs::path& dir, bool single, const std::string& flags = kFlags, const std::string& cc = "gcc") {
  const std::string driver = std::string(HYSTERON_SOURCE_DIR) + "/tests/export/driver.c";
  const std::string cmd =
      fmt::format("{} {} {} -I'{}' '{}' {} -o '{}' -lm > '{}' 2>&1", cc, flags, single ? "-DHM_SINGLE" : "", dir.string(),
                  driver, single ? "" : "'" + (dir / "model.c").string() + "'", (dir / "driver").string(),
                  (dir / "gcc.log").string());
  if (std::system(cmd.c_str()) != 0) return cmd + "\n" + read(dir / "gcc.log");
  return "";
}

std::string run_driver(const fs::path& dir, const std::string& script) {
  write(dir / "script.txt", script);
  const std::string cmd = fmt::format("'{}' < '{}' > '{}'", (dir / "driver").string(), (dir / "script.txt").string(),
                                      (dir / "out.txt").string());
  if (std::system(cmd.c_str()) != 0) return "driver failed: " + cmd;
  return read(dir / "out.txt");
}

io::GeneratedC generate(const Case& c, bool single) {
  io::ExportOptions o;
  o.prefix = "hm";
  o.source_name = c.name + ".json";
  if (!single) o.header_name = "model.h";
  o.inverse_limits = c.inverse_limits;
  return io::generate_c(params_of(c), o);
}

class ExportC : public ::testing::TestWithParam<Case> {};

TEST_P(ExportC, MatchesTheLibrary) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found: generated C not compiled";
  const Case& c = GetParam();
  TempDir dir(c.name);
  const bool single = c.single;
  const io::GeneratedC g = generate(c, single);
  write(dir.path / "model.c", g.source);
  if (!single) write(dir.path / "model.h", g.header);
  const std::string err = compile(dir.path, single);
  ASSERT_EQ(err, "") << "the generated C does not compile cleanly";
  const Script run = make_run(c, 100000, 12345u + static_cast<unsigned>(c.name.size()));
  const Compared r = compare(run, run_driver(dir.path, run.script));
  EXPECT_EQ(r.mismatches, 0u) << r.first_mismatch;
  EXPECT_EQ(r.forward, run.forward);
  EXPECT_EQ(r.inverse, run.inverse);
  EXPECT_LE(r.forward_err, 1e-12);
  EXPECT_LE(r.inverse_err, 1e-12);
#if defined(__x86_64__) && defined(__SSE2__)
  // Stronger than the 1e-12 required: with IEEE doubles, no FMA contraction (gcc -std=c99 on
  // x86-64) the generated code performs the library's operations in its order: equal bits.
  EXPECT_EQ(r.forward_exact, r.forward) << "forward results are not bit-identical to the library's";
  EXPECT_EQ(r.inverse_exact, r.inverse) << "inverse results are not bit-identical to the library's";
#endif
  if (run.bounded) {
    EXPECT_GT(run.saturated, 0u) << "the test never drove the inverse into its limits";
  }
  std::printf("  %s (%s): %zu forward, %zu inverse samples (%zu saturated, %zu non-finite; resets: %zu virgin, %zu "
              "relaxed, %zu states, %zu unreachable); max relative error %.3g / %.3g; bit-identical %zu / %zu\n",
              c.name.c_str(), single ? "single .c" : ".c + .h", r.forward, r.inverse, run.saturated, run.nonfinite,
              run.virgin, run.relaxed, run.states, run.unreachable, r.forward_err, r.inverse_err, r.forward_exact,
              r.inverse_exact);
}

INSTANTIATE_TEST_SUITE_P(Export, ExportC, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& p) { return p.param.name; });

// The comparison can fail: a constant perturbed by 1e-9 (relative) is detected.
TEST(ExportCheck, PerturbedConstantIsDetected) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found";
  for (const char* which : {"gpi_tanh", "mpi_asym"}) {
    Case c;
    for (const Case& k : cases())
      if (k.name == which) c = k;
    TempDir dir(std::string("perturbed_") + which);
    io::GeneratedC g = generate(c, true);
    const std::string key = "static const double hm_q = ";
    const auto pos = g.source.find(key);
    ASSERT_NE(pos, std::string::npos);
    const auto end = g.source.find(';', pos);
    const double q = std::strtod(g.source.substr(pos + key.size(), end - pos - key.size()).c_str(), nullptr);
    g.source.replace(pos + key.size(), end - pos - key.size(), fmt::format("{}", q * (1 + 1e-9)));
    write(dir.path / "model.c", g.source);
    ASSERT_EQ(compile(dir.path, true), "");
    const Script run = make_run(c, 20000, 7u);
    const Compared r = compare(run, run_driver(dir.path, run.script));
    EXPECT_GT(std::max(r.forward_err, r.inverse_err), 1e-12) << which << ": a perturbed q went unnoticed";
    std::printf("  %s with q * (1 + 1e-9): max relative error %.3g / %.3g (detected)\n", which, r.forward_err,
                r.inverse_err);
  }
}

// The generated mpi-asym inverse refuses a start state exactly where Inverse::reset(ModelState) does (two necessary
// conditions of reachability, docs/models.md): states of runs (accepted), the same perturbed, random ones, virgin
// operators with any u (accepted), and states 0.5 and 2 tolerances (1e-9 max(1, |values|)) past y_1 = u - r_1.
TEST(ExportCheck, MpiAsymInverseRefusesTheStatesTheLibraryRefuses) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found";
  for (const Case& c : cases()) {
    if (c.name.rfind("mpi_asym", 0) != 0) continue;
    TempDir dir("asym_states_" + c.name);
    const io::GeneratedC g = generate(c, true);
    write(dir.path / "model.c", g.source);
    ASSERT_EQ(compile(dir.path, true), "") << c.name;
    const ModelParams params = params_of(c);
    const Inverse proto(params, InverseOptions{c.inverse_limits});
    const std::vector<double>& r = proto.structure().r;
    const std::size_t n = r.size();
    ASSERT_GE(n, 2u) << c.name;
    std::mt19937_64 rng(99u + static_cast<unsigned>(c.name.size()));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    auto random_x = [&] { return c.x_lo + (c.x_hi - c.x_lo) * unit(rng); };
    auto run_state = [&] {  // a state of the model driven from rest by a random walk
      Model m(params);
      if (unit(rng) < 0.8) m.reset_relaxed(random_x());
      const int len = 1 + static_cast<int>(unit(rng) * 50);
      for (int k = 0; k < len; ++k) m.step(random_x());
      return m.state();
    };
    std::string script;
    std::vector<int> expected;  // the library's inverse: 0 accepted, -1 refused
    std::size_t accepted = 0, refused = 0, from_runs = 0;
    for (int t = 0; t < 3000; ++t) {
      ModelState st = run_state();
      const int kind = t % 5;
      if (kind == 1) {  // one operator or u moved by up to twice the largest threshold gap
        const double by = 2.0 * (r[n - 1] - r[0]) * (unit(rng) - 0.5);
        const std::size_t i = static_cast<std::size_t>(unit(rng) * static_cast<double>(n + 1));
        (i < n ? st.y[i] : st.u) += by;
      } else if (kind == 2) {  // random operator outputs around u
        for (double& v : st.y) v = st.u + (r[n - 1] + 0.5) * 2.0 * (unit(rng) - 0.5);
      } else if (kind == 3) {  // virgin operators, any u
        st.y.assign(n, 0.0);
        st.u += 3.0 * (unit(rng) - 0.5);
      } else if (kind == 4) {  // every y_i = u - r_i - delta: the first condition's edge
        double scale = std::abs(st.u);
        for (std::size_t i = 0; i < n; ++i) scale = std::max(scale, std::abs(st.u - r[i]));
        const double delta = (t % 2 == 0 ? 0.5 : 2.0) * 1e-9 * std::max(1.0, scale);
        for (std::size_t i = 0; i < n; ++i) st.y[i] = st.u - r[i] - delta;
      }
      int rc = 0;
      try {
        Inverse(params, InverseOptions{c.inverse_limits}).reset(st);
      } catch (const hysteron::Error&) {
        rc = -1;
      }
      if (kind == 0) {
        EXPECT_EQ(rc, 0) << c.name << ": a state of a run refused by the library";
        ++from_runs;
      }
      (rc == 0 ? accepted : refused) += 1;
      expected.push_back(rc);
      script += "s ";
      script += hex(st.u);
      for (double v : st.y) (script += " ") += hex(v);
      script += "\n";
    }
    std::istringstream out(run_driver(dir.path, script));
    std::size_t mismatches = 0, lines = 0;
    std::string first;
    for (int rc : expected) {
      std::string op;
      int rm = 1, ri = 1;
      if (!(out >> op >> rm >> ri)) break;
      ++lines;
      if (op != "S" || rm != 0 || ri != rc) {
        if (mismatches++ == 0) first = fmt::format("state {}: C \"{} {} {}\", library {}", lines - 1, op, rm, ri, rc);
      }
    }
    EXPECT_EQ(lines, expected.size()) << c.name;
    EXPECT_EQ(mismatches, 0u) << c.name << ": " << first;
    EXPECT_GE(accepted, 1000u) << c.name;
    EXPECT_GE(refused, 500u) << c.name;
    std::printf("  %s: %zu states (%zu of runs), the library accepts %zu, refuses %zu; the C differs on %zu\n",
                c.name.c_str(), expected.size(), from_runs, accepted, refused, mismatches);
  }
}

// Other flags and compilers: -O0, -O3, C11, -Wshadow -Wstrict-prototypes
// -Wmissing-prototypes, and clang where it is installed.
TEST(ExportCheck, CompilesWithOtherFlags) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found";
  for (const Case& c : cases()) {
    TempDir dir("flags_" + c.name);
    const io::GeneratedC g = generate(c, false);
    write(dir.path / "model.c", g.source);
    write(dir.path / "model.h", g.header);
    for (const char* flags : {"-std=c99 -pedantic -Wall -Wextra -Werror -O0", "-std=c11 -pedantic -Wall -Wextra -Werror -O3",
                              "-std=c99 -pedantic -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Werror -O2"})
      EXPECT_EQ(compile(dir.path, false, flags), "") << c.name << " with " << flags;
    if (have("clang")) {
      EXPECT_EQ(compile(dir.path, true, "-std=c99 -pedantic -Wall -Wextra -Werror -O2", "clang"), "") << c.name << " with clang";
    }
  }
}

// -ffast-math regroups floating-point operations: the tanh kernel's round-to-integer trick
// (y/ln2 + 1.5 2^52) - 1.5 2^52 was folded to y/ln2 and a tanh model was off by up to 10 mm
// (gpi-pid's fitted model). Not bit-identical under it, but within 1e-12 of the library, every kind.
TEST(ExportCheck, FastMathStaysWithin1e12OfTheLibrary) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found";
  for (const Case& c : cases()) {
    TempDir dir("fast_math_" + c.name);
    write(dir.path / "model.c", generate(c, true).source);
    ASSERT_EQ(compile(dir.path, true, kFlags + " -ffast-math"), "") << c.name;
    const Script run = make_run(c, 20000, 99u);
    const Compared r = compare(run, run_driver(dir.path, run.script));
    EXPECT_LE(r.forward_err, 1e-12) << c.name;
    EXPECT_LE(r.inverse_err, 1e-12) << c.name;
    std::printf("  %s with -ffast-math: max relative error %.3g / %.3g; bit-identical %zu / %zu of %zu / %zu; "
                "%zu other mismatches%s%s\n",
                c.name.c_str(), r.forward_err, r.inverse_err, r.forward_exact, r.inverse_exact, r.forward, r.inverse,
                r.mismatches, r.mismatches ? ", first: " : "", r.first_mismatch.c_str());
  }
}

// -fsingle-precision-constant makes every floating constant a float (0.6 -> 0.60000002384185791,
// 1e300 -> inf) and defines no macro: the generated file's check stops the compilation.
TEST(ExportCheck, SinglePrecisionConstantsStopTheCompilation) {
  if (!have_gcc()) GTEST_SKIP() << "gcc not found";
  for (const Case& c : cases()) {
    if (c.name != "pi" && c.name != "gpi_tanh") continue;
    TempDir dir("single_constants_" + c.name);
    write(dir.path / "model.c", generate(c, true).source);
    ASSERT_EQ(compile(dir.path, true), "") << c.name;
    const std::string err = compile(dir.path, true, kFlags + " -fsingle-precision-constant");
    EXPECT_NE(err.find("hm_floating_constants_are_double"), std::string::npos) << c.name << ": " << err;
  }
}

TEST(ExportCheck, BadOptionsAndModelsAreRefused) {
  const ModelParams pi = io::model_from_json(io::parse_json(R"({"model": "pi", "q": 0.4, "r": [0.1], "p": [0.3]})", "pi"), "pi");
  io::ExportOptions o;
  for (const char* bad : {"", "1abc", "_x", "a-b", "a b", "a.b", "hysteron", "hysteron_params", "Hysteron_x", "HYSTERON",
                          "pam_", "a__b"}) {
    o.prefix = bad;
    EXPECT_THROW(io::generate_c(pi, o), hysteron::Error) << bad;
  }
  for (const char* good : {"pam", "pam_left", "hysteronx", "my_hysteron", "a1"}) {
    o.prefix = good;
    EXPECT_NO_THROW(io::generate_c(pi, o)) << good;
  }
  o.prefix = "ok";
  o.header_name = "a\"b.h";
  EXPECT_THROW(io::generate_c(pi, o), hysteron::Error);
  o.header_name.clear();
  // not invertible: q + p_1 <= 0
  const ModelParams bad = io::model_from_json(io::parse_json(R"({"model": "pi", "q": 0.4, "r": [0.1], "p": [-0.5]})", "b"), "b");
  try {
    io::generate_c(bad, o);
    FAIL() << "a model without an inverse was exported";
  } catch (const hysteron::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not invertible"), std::string::npos) << e.what();
  }
  // mpi-asym needs finite limits
  const ModelParams asym = io::model_from_json(
      io::parse_json(R"({"model": "mpi-asym", "q": 0.6, "r": [0.05], "p": [0.2],
         "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]}, "descending": {"envelope": "affine", "c": [0.9, 0.1]}})",
                     "a"),
      "a");
  EXPECT_THROW(io::generate_c(asym, o), hysteron::Error);
  o.inverse_limits = Limits{-2.0, 2.0};
  EXPECT_NO_THROW(io::generate_c(asym, o));
  // rate-pi is made of plays: refused as rate-dependent, not as a model without a play structure
  const ModelParams rate = io::model_from_json(
      io::parse_json(R"({"model": "rate-pi", "q": 0.4, "r": [0.1], "p": [0.3], "c": 0.01, "tau": 0.05, "dt": 0.001})",
                     "rp"),
      "rp");
  try {
    io::generate_c(rate, o);
    FAIL() << "rate-pi was exported";
  } catch (const hysteron::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("rate-pi: rate-dependent"), std::string::npos) << m;
    EXPECT_NE(m.find("not supported"), std::string::npos) << m;
    EXPECT_EQ(m.find("no play structure"), std::string::npos) << m;
  }
}

TEST(ExportCheck, ConstantsRoundTripAndCommentsNameTheSource) {
  Case c = cases()[3];  // gpi_tanh
  io::ExportOptions o;
  o.prefix = "comp";
  o.source_name = "my */ model.json";
  o.command_line = "hysteron export --model m.json --out comp.c";
  const io::GeneratedC g = io::generate_c(params_of(c), o);
  EXPECT_EQ(g.header, "");
  EXPECT_NE(g.source.find("my * / model.json"), std::string::npos);  // no comment end inside the comment
  EXPECT_NE(g.source.find("Regenerate with: hysteron export --model m.json --out comp.c"), std::string::npos);
  EXPECT_NE(g.source.find("generated by hysteron "), std::string::npos);
  EXPECT_NE(g.source.find("Eq. 5"), std::string::npos);
  EXPECT_NE(g.source.find("Eqs. 9-10"), std::string::npos);
  EXPECT_NE(g.source.find("comp_model_step"), std::string::npos);
  EXPECT_EQ(g.source.find("#include <stdlib.h>"), std::string::npos);
  // every weight p_i of Eq. 8 appears as its shortest round-trip decimal
  const Structure<double> s = canonical_structure(params_of(c));
  for (double p : s.p) EXPECT_NE(g.source.find(fmt::format("{}", p)), std::string::npos) << p;
}

}  // namespace
