#pragma once
// A generated loop (hysteron export --loop) compiled with tests/export/loop_driver.c and run
// on recorded inputs (tests/test_export_loop.cpp, tests/test_c_api_loops.cpp); have_gcc and
// hexf also serve tests/test_export.cpp.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hysteron/io/export_c.hpp"
#include "hysteron/loop_design.hpp"

namespace hysteron::test {

inline bool have_gcc() { return std::system("gcc --version > /dev/null 2>&1") == 0; }

// Exact text of a double for the drivers (C99 hex float; nan, inf, -inf).
inline std::string hexf(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:a}", v);
}

struct LoopRun {
  std::string error;                 // "" or what failed (generation, compiler, driver)
  std::vector<double> preview;       // lp_loop_preview of the reference
  std::vector<double> command, duty; // lp_loop_step (lp_loop_learning_step) of every sample
  // after every lp_loop_step: the position PID's faults, guard_cuts, gain_scale, the inverse's faults and, in a
  // cascade_pwm loop, the pressure PID's faults, guard_cuts, gain_scale and pwm_faults (loop_driver.c)
  std::vector<std::vector<double>> counts;
  std::vector<double> correction;    // with learning: lp_learning_correction(0) before every step
  int warm_status = 0;               // lp_learning_warm_start's return value, if called
};

// Generates `d` on `model` (prefix lp; one .c, or .c + .h), compiles it with
// gcc -std=c99 -pedantic -Wall -Wextra -Werror -O2 in `dir`, computes the preview of
// `reference` and steps every sample with the given inputs; a reset before each sample listed
// in `resets`, and a restart of the position PID's limit-cycle guard (lp_loop_restart_guard) before each
// sample listed in `guard_restarts` (after a reset there). With d.learning, the steps are lp_loop_learning_step's, after a warm start from
// `warm_start` if it is not empty (a reset restarts the learning cold).
inline LoopRun run_generated_loop(const LoopDesign& d, const ModelParams& model, const std::filesystem::path& dir,
                                  bool single, const std::vector<double>& reference, const std::vector<double>& preview,
                                  const std::vector<double>& measured, const std::vector<double>& pressure,
                                  const std::vector<std::size_t>& resets = {},
                                  const std::vector<double>& warm_start = {},
                                  const std::vector<std::size_t>& guard_restarts = {}) {
  namespace fs = std::filesystem;
  LoopRun out;
  io::ExportOptions o;
  o.prefix = "lp";
  o.loop = d;
  if (!single) o.header_name = "loop.h";
  io::GeneratedC g;
  try {
    g = io::generate_c(model, o);
  } catch (const std::exception& e) {
    out.error = std::string("generate_c: ") + e.what();
    return out;
  }
  std::ofstream(dir / "loop.c", std::ios::binary) << g.source;
  if (!single) std::ofstream(dir / "loop.h", std::ios::binary) << g.header;
  const std::string driver = std::string(HYSTERON_SOURCE_DIR) + "/tests/export/loop_driver.c";
  const std::string cc = fmt::format(
      "gcc -std=c99 -pedantic -Wall -Wextra -Werror -O2 {} {} -I'{}' '{}' {} -o '{}' -lm > '{}' 2>&1",
      std::string(single ? "-DLP_SINGLE" : "") + (d.kind == LoopDesign::Kind::cascade_pwm ? " -DLP_CASCADE" : ""),
      d.learning ? "-DLP_LEARNING" : "", dir.string(), driver, single ? "" : "'" + (dir / "loop.c").string() + "'",
      (dir / "loop_driver").string(), (dir / "gcc.log").string());
  if (std::system(cc.c_str()) != 0) {
    std::ifstream log(dir / "gcc.log");
    out.error = cc + "\n" + std::string(std::istreambuf_iterator<char>(log), {});
    return out;
  }
  {
    std::ofstream s(dir / "script.txt", std::ios::binary);
    s << "p " << reference.size();
    for (double v : reference) s << ' ' << hexf(v);
    s << '\n';
    if (!warm_start.empty()) {
      s << "w " << warm_start.size();
      for (double v : warm_start) s << ' ' << hexf(v);
      s << '\n';
    }
    const char* op = d.learning ? "l " : "s ";
    std::size_t next = 0, next_restart = 0;
    for (std::size_t k = 0; k < reference.size(); ++k) {
      while (next < resets.size() && resets[next] <= k) {
        if (resets[next] == k) s << "r\n";
        ++next;
      }
      while (next_restart < guard_restarts.size() && guard_restarts[next_restart] <= k) {
        if (guard_restarts[next_restart] == k) s << "g\n";
        ++next_restart;
      }
      s << op << hexf(reference[k]) << ' ' << hexf(preview[k]) << ' ' << hexf(measured[k]) << ' '
        << hexf(pressure[k]) << '\n';
    }
  }
  const std::string run = fmt::format("'{}' < '{}' > '{}'", (dir / "loop_driver").string(),
                                      (dir / "script.txt").string(), (dir / "out.txt").string());
  if (std::system(run.c_str()) != 0) {
    out.error = "driver failed: " + run;
    return out;
  }
  std::ifstream in(dir / "out.txt");
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag, a, b;
    ls >> tag;
    if (tag == "P") {
      while (ls >> a) out.preview.push_back(std::strtod(a.c_str(), nullptr));
    } else if (tag == "S" && (ls >> a >> b)) {
      out.command.push_back(std::strtod(a.c_str(), nullptr));
      out.duty.push_back(std::strtod(b.c_str(), nullptr));
      std::vector<double>& n = out.counts.emplace_back();
      while (ls >> a) n.push_back(std::strtod(a.c_str(), nullptr));
    } else if (std::string c; tag == "L" && (ls >> a >> b >> c)) {
      out.command.push_back(std::strtod(a.c_str(), nullptr));
      out.duty.push_back(std::strtod(b.c_str(), nullptr));
      out.correction.push_back(std::strtod(c.c_str(), nullptr));
    } else if (tag == "W" && (ls >> a)) {
      out.warm_status = std::atoi(a.c_str());
    } else {
      out.error = "unexpected driver output: " + line;
      return out;
    }
  }
  return out;
}

}  // namespace hysteron::test
