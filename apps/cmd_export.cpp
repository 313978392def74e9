// hysteron export: a model file as one self-contained C99 file (docs/export.md).
//
//   hysteron export --model M.json --out compensator.c [--header compensator.h] [--prefix NAME] [--limits=LO,HI]
//                   [--loop result.json --run RUN]
// --model - reads the model JSON from stdin; --out - (or a path naming stdout) writes the C file to stdout (not with
// --header). --header names a regular file (or a new path): never stdout, a descriptor, a device or a FIFO.
#include <fmt/format.h>

#include <sys/stat.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/export_c.hpp"
#include "hysteron/io/table.hpp"

namespace hysteron::cli {

namespace {

struct Options {
  std::string model, out, header, prefix, limits, loop, run;
  bool prefix_given = false;  // --prefix on the command line (even "")
};

// Default prefix: the output file's stem with every other character as '_'
// ("my-comp.c" -> "my_comp"), or "compensator" if that is not a usable prefix or the output is stdout.
std::string default_prefix(const std::string& out) {
  if (names_stdout(out)) return "compensator";  // - or /dev/stdout: no file name to take it from
  std::string stem = std::filesystem::path(out).stem().string();
  for (char& c : stem)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_') || static_cast<unsigned char>(c) >= 0x80) c = '_';
  if (io::valid_c_prefix(stem)) return stem;
  // said, so that a user who expected the file's name in the symbols is not left with link errors
  fmt::print(stderr, "warning: --out's name \"{}\" is not a usable prefix ({}): the prefix is \"compensator\" (--prefix "
             "sets it)\n",
             stem, io::c_prefix_problem(stem));
  return "compensator";
}

// Why `path` cannot be the header the C file #includes (empty: it can): it names stdout or a
// descriptor, or is a device, FIFO or socket (a directory is refused by check_output_files).
std::string header_path_problem(const std::string& path) {
  if (names_stdout(path)) return "names stdout";
  if (path == "/dev/stdout" || path == "/dev/stderr" || path.starts_with("/dev/fd/") ||
      path.starts_with("/proc/self/fd/"))
    return "names a file descriptor, not a file";
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
    return "is not a regular file (a device, FIFO or socket)";
  return {};
}

int run_export(const Options& o) {
  // the C file #includes the header by its file name: the C file must be a file too, not stdout (-, /dev/stdout
  // or the file stdout is redirected to: names_stdout), as for every output that names stdout
  if (!o.header.empty() && names_stdout(o.out))
    throw Error(fmt::format("--header needs --out to name a file, not stdout (--out {}): the C file #includes the "
                            "header by its file name",
                            o.out));
  // and the header must be a file of that name: stdout (- or any path names_stdout sees: #include "-" or
  // "stdout"), a device, a FIFO or a descriptor path gives the C file an #include of nothing
  if (!o.header.empty()) {
    if (const std::string why = header_path_problem(o.header); !why.empty())
      throw Error(fmt::format("--header {}: {}; the C file #includes the header by its file name, so --header must "
                              "name a regular file (nothing was written)",
                              o.header, why));
  }
  if (!o.header.empty() && o.header == o.out) throw Error(fmt::format("--header and --out name the same file \"{}\"", o.out));
  if (!o.run.empty() && o.loop.empty()) throw Error("--run names a run of the --loop file: give --loop too");
  io::check_output_files({{"--out", o.out}, {"--header", o.header}}, {{"--model", o.model}, {"--loop", o.loop}});
  const io::ModelDocument doc = io::read_model_document(o.model);
  const ModelParams& params = doc.params;
  io::ExportOptions e;
  e.input_unit = doc.unit("input");  // the units the C file's comments state
  e.output_unit = doc.unit("output");
  e.prefix = o.prefix_given ? o.prefix : default_prefix(o.out);
  if (const std::string why = io::c_prefix_problem(e.prefix); !why.empty())
    throw Error(fmt::format("--prefix: \"{}\" is not usable: {}", e.prefix, why));
  e.source_name = o.model == "-" ? std::string("<stdin>") : std::filesystem::path(o.model).filename().string();
  if (!o.header.empty()) e.header_name = std::filesystem::path(o.header).filename().string();
  if (!o.limits.empty()) {
    e.inverse_limits = parse_limits(o.limits);
    warn_limits_beyond_model(params, e.inverse_limits, "export", e.input_unit);
  }
  if (!o.loop.empty()) {
    e.loop = io::read_loop_design(o.loop, o.run);  // an adaptive run's loop is refused by generate_c
    e.loop_source = fmt::format("\"{}\"{}", std::filesystem::path(o.loop).filename().string(),
                                o.run.empty() ? std::string() : fmt::format(", run \"{}\"", o.run));
  }
  e.command_line = command_line();
  io::GeneratedC c;
  try {
    c = io::generate_c(params, e);  // every error before any file is written
  } catch (const Error& err) {
    throw Error(fmt::format("{}: cannot export: {}", o.model == "-" ? std::string("<stdin>") : o.model, err.what()));
  }
  io::FileBatch batch;  // the header and the source replaced together
  if (!o.header.empty()) io::write_text_file(o.header, c.header);
  io::write_text_file(o.out, c.source);
  batch.commit();
  if (o.out != "-")
    fmt::print(stderr, "export: {} model{} -> {}{} (prefix {})\n", model_name(params),
               e.loop ? fmt::format(" and the loop of {}", e.loop_source) : std::string(), o.out,
               o.header.empty() ? std::string() : fmt::format(" + {}", o.header), e.prefix);
  return exit_ok;
}

}  // namespace

void add_export(CLI::App& app, Action& action) {
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "export", "write a model and its exact inverse as one self-contained C99 file (docs/export.md)");
  sub->add_option("--model,-m", o->model, "model file (JSON, see docs/model-files.md); - reads it from stdin")->required();
  sub->add_option("--out,-o", o->out, "C file to write (- for stdout)")->required();
  sub->add_option("--header", o->header,
                  "also write the declarations to this header (the C file #includes it by its file name)");
  CLI::Option* prefix = sub->add_option("--prefix", o->prefix,
                  "prefix of the C names (default: the --out file's stem, e.g. compensator -> compensator_model_step)");
  sub->add_option("--limits", o->limits,
                  "input limits LO,HI the inverse saturates at (default: the model's input_limits; write "
                  "--limits=LO,HI if LO < 0)");
  sub->add_option("--loop", o->loop,
                  "also write the compensating loop around the inverse: an experiment's result.json (or a "
                  "controller JSON); the model must be the one the run inverts (docs/export.md, \"The loop\")");
  sub->add_option("--run", o->run,
                  "the run of the --loop file, e.g. compensated.sine, or learning.sine for the loop with its iterative "
                  "learning (not adaptive runs)");
  sub->callback([o, prefix, &action] {
    o->prefix_given = prefix->count() > 0;
    action = [o] { return run_export(*o); };
  });
}

}  // namespace hysteron::cli
