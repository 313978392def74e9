// Model files (JSON), CSV/.mat tables and atomic writes.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>
#include <matio.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "temp_dir.hpp"
#include "test_util.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/numbers.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/io/units.hpp"
#include "hysteron/models.hpp"

namespace fs = std::filesystem;
using hysteron::Error;
using nlohmann::json;
namespace io = hysteron::io;

namespace {

using hysteron::test::TempDir;
using hysteron::test::slurp;

// Expects `f` to throw hysteron::Error whose message contains every one of `parts`.
template <class F>
void expect_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "message: " << msg << "\nmissing: " << p;
    return;
  }
  ADD_FAILURE() << "no hysteron::Error thrown";
}

std::vector<double> test_signal() {
  std::vector<double> x;
  for (int k = 0; k < 400; ++k) x.push_back(0.9 * std::sin(0.037 * k) * std::exp(-k / 300.0) + 0.1 * std::sin(0.31 * k));
  return x;
}

void expect_same_envelope(const hysteron::Envelope& a, const hysteron::Envelope& b) {
  EXPECT_EQ(a.kind, b.kind);
  for (std::size_t i = 0; i < hysteron::envelope_num_coefficients(a.kind); ++i) EXPECT_EQ(a.c[i], b.c[i]) << i;
}

void expect_same(const hysteron::ModelParams& a, const hysteron::ModelParams& b) {
  ASSERT_EQ(a.index(), b.index());
  EXPECT_EQ(hysteron::input_limits(a), hysteron::input_limits(b));
  if (auto* m = std::get_if<hysteron::PiParams>(&a)) {
    const auto& n = std::get<hysteron::PiParams>(b);
    EXPECT_EQ(m->q, n.q);
    EXPECT_EQ(m->r, n.r);
    EXPECT_EQ(m->p, n.p);
  } else if (auto* g = std::get_if<hysteron::GpiParams>(&a)) {
    const auto& h = std::get<hysteron::GpiParams>(b);
    expect_same_envelope(g->envelope, h.envelope);
    EXPECT_EQ(g->q, h.q);
    EXPECT_EQ(g->r, h.r);
    EXPECT_EQ(g->p, h.p);
    if (g->r.empty()) {
      EXPECT_EQ(g->n, h.n);
      EXPECT_EQ(g->rho, h.rho);
      EXPECT_EQ(g->tau, h.tau);
      EXPECT_EQ(g->alpha, h.alpha);
    }
  } else if (auto* d = std::get_if<hysteron::MpiDeadzoneParams>(&a)) {
    const auto& e = std::get<hysteron::MpiDeadzoneParams>(b);
    EXPECT_EQ(d->q, e.q);
    EXPECT_EQ(d->r, e.r);
    EXPECT_EQ(d->p, e.p);
    EXPECT_EQ(d->g0, e.g0);
    EXPECT_EQ(d->z, e.z);
    EXPECT_EQ(d->g, e.g);
  } else {
    const auto& s = std::get<hysteron::MpiAsymParams>(a);
    const auto& t = std::get<hysteron::MpiAsymParams>(b);
    expect_same_envelope(s.ascending, t.ascending);
    expect_same_envelope(s.descending, t.descending);
    EXPECT_EQ(s.q, t.q);
    EXPECT_EQ(s.r, t.r);
    EXPECT_EQ(s.p, t.p);
  }
  // identical simulated outputs, bit for bit
  hysteron::Model ma(a), mb(b);
  const auto x = test_signal();
  EXPECT_EQ(ma.simulate(x), mb.simulate(x));
}

std::vector<hysteron::ModelParams> all_model_kinds() {
  std::vector<hysteron::ModelParams> out;
  hysteron::PiParams pi;
  pi.q = 0.1 + 0.2;
  pi.r = {0.0, 1.0 / 3.0, 2.0 / 3.0, 0.9};
  pi.p = {0.7, 0.2 / 3.0, -0.01, 0.125};
  pi.input_limits = {-1.0 / 7.0, 1.0 / 7.0};
  out.push_back(pi);

  hysteron::GpiParams gpi;
  gpi.envelope = hysteron::Envelope::tanh(1.2, 0.8, 0.1 / 3.0, std::exp(-1.0));
  gpi.q = std::sqrt(2.0) / 3.0;
  gpi.n = 12;
  gpi.rho = 0.3 / 7.0;
  gpi.tau = 1.5;
  gpi.alpha = 0.05 / 3.0;
  gpi.input_limits.hi = 0.6;  // one-sided: lo stays -inf
  out.push_back(gpi);

  hysteron::GpiParams free_w;
  free_w.envelope = hysteron::Envelope::atan(0.9, 1.1, -0.2, 1e-17);
  free_w.q = 0.4;
  free_w.r = {0.05, 0.1, 0.3};
  free_w.p = {0.2, 0.1 / 3.0, 0.05};
  out.push_back(free_w);

  hysteron::GpiParams affine = free_w;
  affine.envelope = hysteron::Envelope::affine(2.0 / 3.0, -0.25);
  out.push_back(affine);

  hysteron::GpiParams ident = free_w;
  ident.envelope = hysteron::Envelope::identity();
  out.push_back(ident);

  hysteron::MpiDeadzoneParams dz;
  dz.q = 0.8;
  dz.r = {0.1, 0.2};
  dz.p = {0.3, 0.1 / 9.0};
  dz.g0 = 1.0 / 3.0;
  dz.z = {-0.5, 0.25};
  dz.g = {0.2, 0.7 / 3.0};
  out.push_back(dz);

  hysteron::MpiAsymParams as;
  as.ascending = hysteron::Envelope::tanh(1.0, 1.3, 0.05, 0.01);
  as.descending = hysteron::Envelope::affine(0.9, 1.0 / 3.0);
  as.q = 0.6;
  as.r = {0.05, 0.15};
  as.p = {0.2, 0.1 / 3.0};
  out.push_back(as);
  return out;
}

}  // namespace

// ---- model files -------------------------------------------------------------------

TEST(ModelFile, JsonRoundTripEveryModelKindIsExact) {
  for (const auto& params : all_model_kinds()) {
    SCOPED_TRACE(std::string(hysteron::model_name(params)));
    const json j = io::model_to_json(params);
    EXPECT_EQ(j.at("schema"), 1);
    EXPECT_EQ(j.at("model"), std::string(hysteron::model_name(params)));
    // through text, as on disk
    const json back = json::parse(j.dump(2));
    expect_same(params, io::model_from_json(back, "mem"));
  }
}

TEST(ModelFile, WriteAndReadFileRoundTripKeepsUnitsAndNote) {
  TempDir dir;
  for (const auto& params : all_model_kinds()) {
    const std::string path = dir.file("m.json");
    io::write_model_file(path, params, {{"units", {{"input", "MPa"}, {"output", "mm"}}}, {"note", "fitted"}});
    expect_same(params, io::read_model_file(path));
    const json extra = io::model_extra(json::parse(slurp(path)));
    EXPECT_EQ(extra.at("units").at("input"), "MPa");
    EXPECT_EQ(extra.at("note"), "fitted");
  }
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"m.json"});  // no temporary files left
}

// io::read_model_document: one reader of a model file that returns the parameters with the
// free-form keys ("units", "note", "metadata"), and write_model_file(path, doc) the writer.
TEST(ModelDocument, ReadReturnsParamsAndFreeFormKeys) {
  TempDir dir;
  const std::string text = R"({"schema": 1, "model": "pi", "r": [0, 0.1], "p": [1, 0.5],
    "units": {"input": "kPa", "output": "N"}, "note": "bench 3",
    "metadata": {"rig": {"id": 7, "tags": ["a", null]}}})";
  const std::string path = dir.write("m.json", text);
  const io::ModelDocument doc = io::read_model_document(path);
  const json j = json::parse(text);
  expect_same(io::model_from_json(j, "mem"), doc.params);
  const json expected = {{"units", j.at("units")}, {"note", j.at("note")}, {"metadata", j.at("metadata")}};
  EXPECT_EQ(doc.extra, expected);
  EXPECT_EQ(doc.unit("input"), "kPa");
  EXPECT_EQ(doc.unit("output"), "N");
  EXPECT_EQ(doc.unit("time"), "");
  // a file without them: an empty object, no units
  const io::ModelDocument bare = io::read_model_document(dir.write("b.json", R"({"model":"pi","r":[0],"p":[1]})"));
  EXPECT_TRUE(bare.extra.is_object());
  EXPECT_TRUE(bare.extra.empty());
  EXPECT_EQ(bare.unit("input"), "");
  // read_model_file is the same reader, parameters only
  expect_same(doc.params, io::read_model_file(path));
}

TEST(ModelDocument, WriteThenReadKeepsEveryFreeFormKeyForEveryKind) {
  TempDir dir;
  const json extra = {{"units", {{"input", "bar"}, {"output", "mm"}, {"time", "s"}}},
                      {"note", "fitted on r.csv"},
                      {"metadata", {{"score", 0.25}, {"list", {1, 2, 3}}}}};
  for (const auto& params : all_model_kinds()) {
    SCOPED_TRACE(std::string(hysteron::model_name(params)));
    const std::string path = dir.file("m.json");
    io::write_model_file(path, io::ModelDocument{params, extra});
    const io::ModelDocument back = io::read_model_document(path);
    expect_same(params, back.params);
    EXPECT_EQ(back.extra, extra);
    // and the JSON of a document is its parameters' JSON plus the keys
    json want = io::model_to_json(params);
    for (const auto& [k, v] : extra.items()) want[k] = v;
    EXPECT_EQ(io::model_to_json(io::ModelDocument{params, extra}), want);
  }
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"m.json"});
}

TEST(ModelDocument, DashReadsStandardInput) {
  // fd 0 replaced by a pipe holding `text` for one read_model_document("-")
  const auto read_stdin = [](const std::string& text) {
    int fds[2];
    EXPECT_EQ(::pipe(fds), 0);
    EXPECT_EQ(::write(fds[1], text.data(), text.size()), static_cast<ssize_t>(text.size()));
    ::close(fds[1]);
    const int saved = ::dup(0);
    ::dup2(fds[0], 0);
    ::close(fds[0]);
    std::clearerr(stdin);
    struct Restore {
      int fd;
      ~Restore() {
        ::dup2(fd, 0);
        ::close(fd);
        std::clearerr(stdin);
      }
    } restore{saved};
    return io::read_model_document("-");
  };
  const io::ModelDocument doc =
      read_stdin(R"({"model": "pi", "r": [0, 0.2], "p": [1, 0.25], "units": {"input": "kPa"}})");
  EXPECT_EQ(std::get<hysteron::PiParams>(doc.params).p, (std::vector<double>{1, 0.25}));
  EXPECT_EQ(doc.unit("input"), "kPa");
  EXPECT_EQ(doc.unit("output"), "");
  expect_error([&] { read_stdin(" \n"); }, {"<stdin>", "standard input is empty"});
  expect_error([&] { read_stdin(R"({"model": "pi", "r": [0], "p": [1], "units": "kPa"})"); },
               {"<stdin>", "\"units\"", "expected an object"});
}

TEST(ModelDocument, BadFreeFormKeysAreRefusedReadingAndWriting) {
  const auto doc_error = [](const std::string& extra_keys, std::initializer_list<std::string> parts) {
    const std::string text = R"({"model": "pi", "r": [0], "p": [1], )" + extra_keys + "}";
    expect_error([&] { io::model_document_from_json(json::parse(text), "m.json"); }, parts);
  };
  doc_error(R"("units": "kPa")", {"m.json", "\"units\"", "expected an object"});
  doc_error(R"("units": {"input": 100})", {"m.json", "\"units.input\"", "expected a string, got number"});
  doc_error(R"("note": ["a"])", {"m.json", "\"note\"", "expected a string, got array"});
  // the writer checks the values too: nothing is written
  TempDir dir;
  const std::string path = dir.write("m.json", "old");
  hysteron::PiParams good;
  good.r = {0.1};
  good.p = {1.0};
  expect_error([&] { io::write_model_file(path, good, {{"units", {{"input", 100}}}}); },
               {path, "\"units.input\"", "expected a string"});
  expect_error([&] { io::write_model_file(path, good, {{"units", "kPa"}}); }, {path, "\"units\""});
  expect_error([&] { io::write_model_file(path, good, {{"note", 3}}); }, {path, "\"note\""});
  expect_error([&] { io::write_model_file(path, io::ModelDocument{good, {{"fit", 1}}}); }, {path, "\"fit\""});
  EXPECT_EQ(slurp(path), "old");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"m.json"});
}

TEST(ModelFile, ExampleFromDocsReads) {
  const json j = json::parse(R"({"schema": 1, "model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0, 0],
    "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05, "input_limits": [0, 0.6],
    "units": {"input": "MPa", "output": "mm"}})");
  const auto p = io::model_from_json(j, "doc");
  const auto& g = std::get<hysteron::GpiParams>(p);
  EXPECT_EQ(g.n, 10);
  EXPECT_EQ(g.tau, 1.5);
  EXPECT_EQ(g.input_limits.lo, 0.0);
  EXPECT_EQ(g.input_limits.hi, 0.6);
  // pi: q optional (default 0)
  const auto pi = io::model_from_json(json::parse(R"({"model":"pi","r":[0,0.1],"p":[1,0.5]})"), "doc");
  EXPECT_EQ(std::get<hysteron::PiParams>(pi).q, 0.0);
}

TEST(ModelFile, NotJsonNamesFileLineAndColumn) {
  TempDir dir;
  const std::string path = dir.write("bad.json", "{\"model\": \"pi\",\n  \"r\": [0.1, ],\n}");
  expect_error([&] { io::read_model_file(path); }, {path, "line 2", "column"});
  expect_error([&] { io::read_model_file(dir.file("missing.json")); }, {"missing.json", "cannot open"});
  const std::string huge = dir.write("huge.json", R"({"model":"pi","r":[1e400],"p":[1]})");
  expect_error([&] { io::read_model_file(huge); }, {huge, "1e400"});
}

// Issue 13: duplicate keys (last one won: this loaded a PI) and bytes after a NUL
// were accepted silently.
// A model file is small (max_model_file_bytes, from the largest model the format allows): a
// device or a huge file is refused by name without reading it all, a FIFO without a writer
// does not block.
TEST(ModelFile, ReadIsBoundedAndNeverHangs) {
  try {
    io::read_model_file("/dev/zero");
    FAIL() << "/dev/zero was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("more than the"), std::string::npos) << e.what();
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("hysteron_read_bound_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {  // a sparse regular file just beyond the bound: refused from its size
    const std::string big = (dir / "big.json").string();
    std::ofstream(big).put(' ');
    std::filesystem::resize_file(big, io::max_model_file_bytes + 1);
    EXPECT_THROW(io::read_model_file(big), Error);
  }
  const std::string fifo = (dir / "fifo.json").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THROW(io::read_model_file(fifo), Error);  // empty, not a hang
  std::filesystem::remove_all(dir);
}

TEST(ModelFile, DuplicateKeysAndNulBytesRefused) {
  auto expect_error = [](const std::string& text, const std::string& needle) {
    try {
      io::parse_json(text, "m.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("m.json"), std::string::npos) << what;
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  };
  expect_error(R"({"model": "gpi", "model": "pi", "r": [0], "p": [1]})", R"(key "model" appears twice in the object at the top level)");
  expect_error(R"({"a": {"b": 1, "c": {"d": 1, "d": 2}}})", "at /a/c");
  expect_error(R"({"a": [{"x": 1}, {"x": 1, "x": 2}]})", R"("x" appears twice)");
  const std::string good = R"({"model": "pi", "r": [0], "p": [1]})";
  expect_error(good + std::string(1, '\0') + "garbage", "NUL byte at offset " + std::to_string(good.size()));
  // The same key in sibling and nested objects is fine.
  const auto ok = io::parse_json(R"({"a": {"x": 1}, "b": {"x": 2, "a": {"x": 3}}, "x": [ {"x": 1}, {"x": 2} ]})", "m.json");
  EXPECT_EQ(ok["b"]["a"]["x"], 3);
  // Through the file reader, too.
  TempDir dir;
  EXPECT_THROW(io::read_model_file(dir.write("dup.json", R"({"model": "gpi", "model": "pi", "r": [0], "p": [1]})")), Error);
}

TEST(ModelFile, EachClassOfInvalidFileNamesTheKey) {
  auto bad = [](const char* text, std::initializer_list<std::string> parts) {
    SCOPED_TRACE(text);
    expect_error([&] { io::model_from_json(json::parse(text), "m.json"); }, parts);
  };
  const char* gpi_tail = R"("c":[1,1,0,0],"q":1,"n":5,"rho":0.5,"tau":1,"alpha":0.1)";
  // missing key
  bad(R"({"r":[1],"p":[1]})", {"m.json", "\"model\"", "missing"});
  bad(R"({"model":"pi","r":[0.1]})", {"m.json", "pi", "\"p\"", "missing"});
  bad(R"({"model":"gpi","c":[1,1,0,0],"q":1,"n":5,"rho":0.5,"alpha":0.1})", {"gpi", "\"tau\"", "missing"});
  // wrong type
  bad(R"({"model":"gpi","c":[1,1,0,0],"q":1,"n":5,"rho":0.5,"tau":"1","alpha":0.1})",
      {"m.json: gpi: key \"tau\": expected a number, got string"});
  bad(R"({"model":"gpi","c":[1,1,0,0],"q":1,"n":5.5,"rho":0.5,"tau":1,"alpha":0.1})", {"\"n\"", "integer"});
  bad(R"({"model":"pi","r":[0.1,"a"],"p":[1,1]})", {"\"r[1]\"", "expected a number, got string"});
  bad(R"({"model":"pi","r":0.1,"p":[1]})", {"\"r\"", "expected an array"});
  bad(R"({"model":3})", {"\"model\"", "expected a string"});
  bad(R"([1,2])", {"m.json", "expected a JSON object"});
  // unknown key: says which are allowed
  bad((std::string(R"({"model":"gpi","beta":1,)") + gpi_tail + "}").c_str(),
      {"\"beta\"", "unknown key", "\"alpha\"", "\"rho\""});
  bad(R"({"model":"pi","r":[0.1],"p":[1],"n":3})", {"\"n\"", "unknown key"});
  bad(R"({"model":"mpi-asym","r":[0.1],"p":[1],"ascending":{"envelope":"tanh","c":[1,1,0,0],"x":1},
        "descending":{"envelope":"identity"}})", {"ascending", "\"x\"", "unknown key"});
  // mixing the parametric and free-weight gpi
  bad((std::string(R"({"model":"gpi","r":[0.1],"p":[1],)") + gpi_tail + "}").c_str(), {"unknown key"});
  // wrong array length
  bad(R"({"model":"gpi","c":[1,1,0],"q":1,"n":5,"rho":0.5,"tau":1,"alpha":0.1})", {"\"c\"", "4 numbers", "got 3"});
  bad(R"({"model":"gpi","envelope":"affine","c":[1,1,0,0],"q":1,"r":[0.1],"p":[1]})", {"\"c\"", "2 numbers"});
  bad(R"({"model":"pi","r":[0.1,0.2],"p":[1]})", {"\"p\"", "2 numbers", "got 1"});
  bad(R"({"model":"pi","r":[0.1],"p":[1],"input_limits":[0]})", {"\"input_limits\"", "[lo, hi]"});
  // unknown names
  bad(R"({"model":"prandtl","r":[0.1],"p":[1]})", {"\"model\"", "\"prandtl\"", "\"gpi\""});
  bad(R"({"model":"gpi","envelope":"sigmoid","c":[1,1,0,0],"q":1,"r":[0.1],"p":[1]})", {"\"envelope\"", "sigmoid"});
  // schema version
  bad(R"({"schema":2,"model":"pi","r":[0.1],"p":[1]})", {"\"schema\"", "version 2"});
  // the model's own validation, prefixed with the file
  bad(R"({"model":"gpi","c":[1,1,0,0],"q":1,"n":5,"rho":0.5,"tau":1,"alpha":-0.1})", {"m.json", "alpha"});
  bad(R"({"model":"pi","r":[-0.1],"p":[1]})", {"m.json", "r[0]"});
  bad(R"({"model":"pi","r":[0.1],"p":[1],"input_limits":[1,0]})", {"m.json", "input_limits"});
  bad(R"({"model":"pi","r":[0.1],"p":[1],"units":"mm"})", {"\"units\"", "object"});
  // non-finite numbers (not expressible in JSON text, but in a json value)
  json j = json::parse(R"({"model":"pi","r":[0.1],"p":[1]})");
  j["q"] = std::numeric_limits<double>::quiet_NaN();
  expect_error([&] { io::model_from_json(j, "mem"); }, {"\"q\"", "finite"});
  j["q"] = 1.0;
  j["p"][0] = std::numeric_limits<double>::infinity();
  expect_error([&] { io::model_from_json(j, "mem"); }, {"\"p[0]\"", "finite"});
}

TEST(ModelFile, WriteRefusesInvalidModelAndBadExtraLeavingFileIntact) {
  TempDir dir;
  const std::string path = dir.write("m.json", "old");
  hysteron::PiParams bad;
  bad.r = {0.1};
  bad.p = {1.0, 2.0};
  EXPECT_THROW(io::write_model_file(path, bad), Error);
  hysteron::PiParams good;
  good.r = {0.1};
  good.p = {1.0};
  EXPECT_THROW(io::write_model_file(path, good, {{"fit", 1}}), Error);
  EXPECT_EQ(slurp(path), "old");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"m.json"});
}

// ---- CSV reading --------------------------------------------------------------------

// One number rule for files, overrides, references and options (io/numbers.hpp): a decimal
// literal, the whole text, an optional '+'; C's strtod would take "0x10" (16), " 5" and "1e-999".
TEST(Numbers, DecimalLiteralsOnlyTheWholeText) {
  using io::NumberParse;
  const auto parsed = [](std::string_view t) {
    double v = -7.0;
    const NumberParse p = io::parse_number(t, v);
    return std::pair{p, v};
  };
  EXPECT_EQ(parsed("13.5"), std::pair(NumberParse::ok, 13.5));
  EXPECT_EQ(parsed("+2e3"), std::pair(NumberParse::ok, 2000.0));
  EXPECT_EQ(parsed("-0.25"), std::pair(NumberParse::ok, -0.25));
  EXPECT_EQ(parsed(".5"), std::pair(NumberParse::ok, 0.5));
  for (const char* bad : {"0x10", "0x1p3", " 5", "5 ", "5,0", "++5", "+-5", "1e", "e5", "5mm", "-"})
    EXPECT_EQ(parsed(bad), std::pair(NumberParse::malformed, -7.0)) << bad;  // not written
  EXPECT_EQ(parsed(""), std::pair(NumberParse::empty, -7.0));
  for (const char* nf : {"nan", "NaN", "inf", "-Infinity", "+inf"})
    EXPECT_EQ(parsed(nf).first, NumberParse::non_finite) << nf;
  EXPECT_EQ(parsed("1e999").first, NumberParse::out_of_range);
  EXPECT_EQ(parsed("-1e400").first, NumberParse::out_of_range);
  // an underflow is a number: 0 or a subnormal, as the literal says
  EXPECT_EQ(parsed("1e-999"), std::pair(NumberParse::ok, 0.0));
  EXPECT_EQ(parsed("4.9406564584124654e-324"), std::pair(NumberParse::ok, std::numeric_limits<double>::denorm_min()));
  EXPECT_EQ(io::finite_number("0.6"), 0.6);
  EXPECT_FALSE(io::finite_number("0x1").has_value());
  EXPECT_FALSE(io::finite_number("inf").has_value());
}

TEST(Csv, HeaderAndNoHeader) {
  TempDir dir;
  const auto h = dir.write("h.csv", "time,x\n0,1.5\n1,-2.5e-3\n");
  EXPECT_EQ(io::read_column(h, "x"), (std::vector<double>{1.5, -2.5e-3}));
  EXPECT_EQ(io::read_column(h, "1"), (std::vector<double>{1.5, -2.5e-3}));
  EXPECT_EQ(io::read_column(h, "time"), (std::vector<double>{0, 1}));
  const auto n = dir.write("n.csv", "0,1.5\n1,-2.5e-3\n");
  EXPECT_EQ(io::read_column(n, "1"), (std::vector<double>{1.5, -2.5e-3}));
  const auto t = io::read_table(h);
  EXPECT_EQ(t.names, (std::vector<std::string>{"time", "x"}));
  EXPECT_EQ(t.num_rows(), 2u);
  const auto t2 = io::read_table(n);
  EXPECT_EQ(t2.names, (std::vector<std::string>{"", ""}));
  // one column, no spec needed
  const auto one = dir.write("one.csv", "3\n+4\n5e0\n");
  EXPECT_EQ(io::read_column(one, ""), (std::vector<double>{3, 4, 5}));
  // forced header mode
  io::ReadOptions o;
  o.header = io::HeaderMode::present;
  o.column_spec = "7";
  EXPECT_EQ(io::read_column(dir.write("num_header.csv", "7\n1\n2\n"), o), (std::vector<double>{1, 2}));
}

TEST(Csv, EverySeparatorCrlfBomBlankLinesAndComments) {
  TempDir dir;
  const std::vector<double> expect{1.25, -3, 4e-5};
  const std::vector<std::pair<std::string, std::string>> files = {
      {"comma.csv", "a,b\n0,1.25\n1,-3\n2,4e-5\n"},
      {"tab.tsv", "a\tb\n0\t1.25\n1\t-3\n2\t4e-5\n"},
      {"semi.csv", "a;b\n0;1.25\n1;-3\n2;4e-5\n"},
      {"space.txt", "  a   b\n0  1.25\n 1\t-3  \n2 4e-5"},
      {"crlf.csv", "a,b\r\n0,1.25\r\n1,-3\r\n2,4e-5\r\n"},
      {"bom.csv", "\xEF\xBB\xBF" "a,b\n0,1.25\n1,-3\n2,4e-5\n"},
      {"blank.csv", "\n\n# comment\na, b\n\n0, 1.25\n   \n1 ,-3\r\n\n2,4e-5\n\n"},
      {"quoted.csv", "\"a\",\"b\"\n0,1.25\n1,-3\n2,4e-5\n"},
      // what spreadsheets write: Excel's "sep=" line, a decimal comma (European locales)
      {"sep.csv", "sep=;\na;b\n0;1.25\n1;-3\n2;4e-5\n"},
      {"sep_comma.csv", "sep=,\r\na,b\r\n0,1.25\r\n1,-3\r\n2,4e-5\r\n"},
      {"decimal_comma.csv", "a;b\n0;1,25\n1;-3\n2;0,00004\n"},
      {"decimal_comma_tab.tsv", "a\tb\n0,0\t1,25\n1\t-3\n2\t4e-5\n"},
      {"sep_decimal_comma.csv", "sep=;\na;b\n0;1,25\n1;-3\n2;4e-5\n"},
  };
  for (const auto& [name, text] : files) {
    SCOPED_TRACE(name);
    const auto path = dir.write(name, text);
    EXPECT_EQ(io::read_column(path, "b"), expect);
    EXPECT_EQ(io::read_column(path, "1"), expect);
    EXPECT_EQ(io::read_column(path, "a"), (std::vector<double>{0, 1, 2}));
    EXPECT_EQ(io::read_table(path).names, (std::vector<std::string>{"a", "b"}));
  }
}

TEST(Csv, AllEmptyLeadingColumnLikeThePiezoFile) {
  TempDir dir;
  const auto path = dir.write("piezo.csv", ",0,-1.6174316,0\n,0.000200010001,-1.7242432,0\n");
  const auto t = io::read_table(path);
  ASSERT_EQ(t.num_columns(), 4u);
  EXPECT_TRUE(t.columns[0].empty());
  EXPECT_EQ(t.num_rows(), 2u);
  EXPECT_EQ(io::read_column(path, "2"), (std::vector<double>{-1.6174316, -1.7242432}));
  expect_error([&] { io::read_column(path, "0"); }, {path, "column 0", "empty in every row"});
  // partly empty column: an error naming the line and column
  const auto partly = dir.write("partly.csv", "1,2\n3,\n5,6\n");
  expect_error([&] { io::read_column(partly, "0"); }, {partly + ":2:2", "empty field"});
  const auto partly2 = dir.write("partly2.csv", ",2\n3,4\n");
  expect_error([&] { io::read_column(partly2, "1"); }, {partly2 + ":1:1", "empty field"});
}

TEST(Csv, RealPiezoFileIfPresent) {
  const std::string path = std::string(HYSTERON_SOURCE_DIR) + "/../shared/data/piezo-sine/piezo_150V_1Hz.csv";
  if (!fs::exists(path)) GTEST_SKIP() << "shared data not present: " << path;
  const auto v = io::read_column(path, "3");
  EXPECT_EQ(v.size(), 50001u);
  EXPECT_THROW(io::read_column(path, "0"), Error);
}

TEST(Csv, BadNumberNamesFileLineColumnAndHeader) {
  TempDir dir;
  const auto path = dir.write("bad.csv", "time,disp\n0,1\n\n1,1.2.3\n");
  expect_error([&] { io::read_column(path, "disp"); }, {path + ":4:2", "\"disp\"", "\"1.2.3\"", "not a number"});
  const auto noh = dir.write("noh.csv", "0,1\n1,abc\n");
  // the second line is data, so "abc" is a bad number, not a header
  expect_error([&] { io::read_column(noh, "1"); }, {noh + ":2:2", "\"abc\""});
  // a decimal comma that the first data row does not announce (Csv.ExcelExports reads one that it does)
  const auto comma = dir.write("decimal_comma.csv", "a;b\n1;2\n1;2,5\n");
  expect_error([&] { io::read_column(comma, "b"); }, {comma + ":3:2", "2,5", "decimal comma"});
  const auto big = dir.write("big.csv", "1\n1e999\n");
  expect_error([&] { io::read_column(big, ""); }, {big + ":2:1", "range"});
}

// What spreadsheets write beyond Csv.EverySeparatorCrlfBomBlankLinesAndComments's files: a
// decimal comma without a header, a declared separator we do not read, UTF-16 text ("Unicode
// text"), which is named, not "not a number".
TEST(Csv, ExcelExports) {
  TempDir dir;
  // without a header the first row is data, not a header, with a decimal comma
  const auto noh = dir.write("noh.csv", "0;1,25\n1;-3\n");
  EXPECT_EQ(io::read_column(noh, "1"), (std::vector<double>{1.25, -3}));
  const auto declared = dir.write("declared.csv", "sep=|\na|b\n");
  expect_error([&] { io::read_column(declared, "b"); }, {declared + ":1", "unsupported separator"});
  const std::string u16 = std::string("\xFF\xFE", 2) + std::string("a\0,\0b\0\n\0" "1\0,\0" "2\0\n\0", 16);
  const auto utf16 = dir.write("utf16.csv", u16);
  expect_error([&] { io::read_column(utf16, "b"); }, {utf16, "UTF-16", "FF FE"});
  // the in-memory reader says the same (the fuzzer found them disagreeing)
  expect_error([&] { io::parse_text_table(u16, "mem.csv", {}); }, {"mem.csv", "UTF-16", "FF FE"});
  const auto nobom = dir.write("utf16_nobom.csv", u16.substr(2));
  expect_error([&] { io::read_column(nobom, "b"); }, {nobom + ":1", "NUL byte"});
}

TEST(Csv, NanAndInfinityRefused) {
  TempDir dir;
  for (const char* bad : {"nan", "NaN", "-inf", "Infinity", "+inf"}) {
    SCOPED_TRACE(bad);
    const auto path = dir.write("nan.csv", std::string("x,y\n0,1\n1,") + bad + "\n");
    expect_error([&] { io::read_column(path, "y"); }, {path + ":3:2", "\"y\"", "finite"});
    // even on the first line (which must not be taken for a header)
    const auto first = dir.write("nan1.csv", std::string(bad) + "\n1\n");
    expect_error([&] { io::read_column(first, ""); }, {first + ":1:1", "finite"});
  }
}

TEST(Csv, ColumnSelectionErrorsAndRaggedRows) {
  TempDir dir;
  const auto path = dir.write("t.csv", "a,b\n1,2\n3,4\n");
  expect_error([&] { io::read_column(path, "5"); }, {path, "index 5", "out of range", "\"a\"", "\"b\""});
  expect_error([&] { io::read_column(path, "c"); }, {path, "no column named \"c\"", "\"a\"", "\"b\""});
  expect_error([&] { io::read_column(path, ""); }, {path, "2 non-empty columns"});
  const auto ragged = dir.write("r.csv", "a,b\n1,2\n3,4,5\n");
  expect_error([&] { io::read_column(ragged, "a"); }, {ragged + ":3", "3 fields", "expected 2"});
  expect_error([&] { io::read_column(dir.write("empty.csv", "\n\n"), ""); }, {"empty"});
  expect_error([&] { io::read_column(dir.file("nope.csv"), "a"); }, {"nope.csv", "cannot open"});
}

// Issue 13: a header naming two columns alike selected the first one silently. Such a name is
// refused where it selects a column (columns counted from 0, as everywhere else); a file whose
// repeated names are not used reads (an audit of 2026-12-01: two "spare" columns refused the file).
TEST(Csv, DuplicateHeaderNamesRefused) {
  TempDir dir;
  const auto path = dir.write("d.csv", "# comment\nt,x,y,x\n0,1,2,3\n");
  expect_error([&] { io::read_column(path, "x"); }, {path, "column name \"x\" appears twice", "columns 1 and 3"});
  EXPECT_EQ(io::read_column(path, "y"), std::vector<double>{2.0});
  EXPECT_EQ(io::read_column(path, "3"), std::vector<double>{3.0});  // by its index
  const auto spare = dir.write("s.csv", "t,p,force,spare,spare\n0,1,2,0,0\n1,2,3,0,0\n");
  EXPECT_EQ(io::read_column(spare, "force"), (std::vector<double>{2.0, 3.0}));
  expect_error([&] { io::read_column(spare, "spare"); }, {"column name \"spare\" appears twice", "columns 3 and 4"});
  // Empty names (a leading index column without a header) may repeat.
  const auto ok = dir.write("e.csv", ",,x\n1,2,3\n");
  EXPECT_EQ(io::read_column(ok, "x"), std::vector<double>{3.0});
}

// Issue 13: a model with 10^7 operators was accepted with no cap.
TEST(ModelFile, OperatorCountIsCapped) {
  hysteron::PiParams pi;
  pi.r.assign(hysteron::max_operators + 1, 0.5);
  pi.p.assign(hysteron::max_operators + 1, 1.0);
  expect_error([&] { hysteron::Model m(pi); }, {"r has 100001 entries", "at most 100000"});
  pi.r.resize(hysteron::max_operators);
  pi.p.resize(hysteron::max_operators);
  EXPECT_NO_THROW(hysteron::Model m(pi));
  hysteron::MpiDeadzoneParams dz;
  dz.z.assign(hysteron::max_operators + 1, 0.5);
  dz.g.assign(hysteron::max_operators + 1, 0.1);
  dz.q = 1.0;
  expect_error([&] { hysteron::Model m(dz); }, {"z has 100001 entries"});
}

// ---- writing ------------------------------------------------------------------------

TEST(Write, CsvRoundTripIsExact) {
  TempDir dir;
  const std::vector<double> a{0.1, 1.0 / 3.0, -2.5e-310, 1e300, -0.0, 123456789.123456789};
  const std::vector<double> b{1, 2, 3, 4, 5, 6};
  const auto path = dir.file("out.csv");
  io::write_columns(path, {"input", "output"}, {a, b});
  EXPECT_EQ(slurp(path).substr(0, 13), "input,output\n");
  EXPECT_EQ(io::read_column(path, "input"), a);
  EXPECT_EQ(io::read_column(path, "output"), b);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.csv"});
}

TEST(Write, FailuresLeaveExistingFileIntactAndNoTempFiles) {
  TempDir dir;
  const auto path = dir.write("keep.csv", "precious\n");
  const auto mat = dir.write("keep.mat", "precious\n");
  EXPECT_THROW(io::write_columns(path, {"a", "b"}, {{1, 2}, {1}}), Error);            // unequal length
  EXPECT_THROW(io::write_columns(path, {"a"}, {{1, NAN}}), Error);                     // non-finite
  EXPECT_THROW(io::write_columns(path, {"a", "b"}, {{1}}), Error);                     // names vs columns
  EXPECT_THROW(io::write_columns(path, {"a,b"}, {{1}}), Error);                        // bad CSV name
  EXPECT_THROW(io::write_columns(mat, {"2x"}, {{1}}), Error);                          // bad MATLAB name
  expect_error([&] { io::write_columns(dir.file("no/such/dir/x.csv"), {"a"}, {{1}}); }, {"no/such/dir", "does not exist"});
  expect_error([&] { io::write_columns(dir.path().string(), {"a"}, {{1}}); }, {"directory"});
  // a writer that fails half way: the temporary file is removed, the target untouched
  expect_error(
      [&] {
        io::write_file_atomically(path, [](const std::string& tmp) {
          std::ofstream(tmp) << "half-written";
          throw Error("disk full (simulated)");
        });
      },
      {path, "disk full"});
  EXPECT_THROW(io::write_file_atomically(path, [](const std::string&) { throw std::runtime_error("boom"); }),
               std::runtime_error);
  EXPECT_EQ(slurp(path), "precious\n");
  EXPECT_EQ(slurp(mat), "precious\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"keep.csv", "keep.mat"}));
  // a successful write replaces the file
  io::write_columns(path, {"a"}, {{1, 2}});
  EXPECT_EQ(slurp(path), "a\n1\n2\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"keep.csv", "keep.mat"}));
}

// ---- .mat ---------------------------------------------------------------------------

TEST(Mat, RoundTripAndMissingVariable) {
  TempDir dir;
  const std::vector<double> x{0.1, 1.0 / 3.0, -2.0, 1e-300};
  const std::vector<double> y{1, 2, 3, 4};
  const auto path = dir.file("data.mat");
  io::write_columns(path, {"input", "output"}, {x, y});
  EXPECT_EQ(io::read_column(path, "input"), x);
  EXPECT_EQ(io::read_column(path, "output"), y);
  const auto t = io::read_table(path);
  EXPECT_EQ(t.names, (std::vector<std::string>{"input", "output"}));
  EXPECT_EQ(t.column("output"), y);
  expect_error([&] { io::read_column(path, "u"); }, {path, "no variable \"u\"", "\"input\"", "\"output\""});
  expect_error([&] { io::read_column(path, ""); }, {path, "2 variables"});
  // extension is case-insensitive
  const auto upper = dir.file("DATA.MAT");
  io::write_columns(upper, {"v"}, {x});
  EXPECT_EQ(io::read_column(upper, ""), x);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"DATA.MAT", "data.mat"}));
  // not a .mat file
  expect_error([&] { io::read_column(dir.write("fake.mat", "hello"), "x"); }, {"fake.mat", ".mat"});
}

TEST(Mat, ReadsSingleIntegerRowVectorsAndMatrixNeedsAColumn) {
  TempDir dir;
  const auto path = dir.file("classes.mat");
  mat_t* m = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(m, nullptr);
  float f[3] = {0.5f, -1.25f, 2.0f};
  std::int16_t s[3] = {-3, 0, 7};
  double mat2x2[4] = {1, 2, 3, 4};
  double nan_v[2] = {1, NAN};
  size_t row[2] = {1, 3}, sq[2] = {2, 2}, two[2] = {2, 1};
  auto write = [&](const char* name, matio_classes c, matio_types t, size_t* dims, void* data) {
    matvar_t* v = Mat_VarCreate(name, c, t, 2, dims, data, MAT_F_DONT_COPY_DATA);
    ASSERT_NE(v, nullptr);
    ASSERT_EQ(Mat_VarWrite(m, v, MAT_COMPRESSION_NONE), 0);
    Mat_VarFree(v);
  };
  write("f", MAT_C_SINGLE, MAT_T_SINGLE, row, f);
  write("s", MAT_C_INT16, MAT_T_INT16, row, s);
  write("M", MAT_C_DOUBLE, MAT_T_DOUBLE, sq, mat2x2);
  write("bad", MAT_C_DOUBLE, MAT_T_DOUBLE, two, nan_v);
  Mat_Close(m);
  EXPECT_EQ(io::read_column(path, "f"), (std::vector<double>{0.5, -1.25, 2.0}));
  EXPECT_EQ(io::read_column(path, "s"), (std::vector<double>{-3, 0, 7}));
  // a matrix named without a column index: the size and how to choose a column
  expect_error([&] { io::read_column(path, "M"); }, {"\"M\"", "2x2", "\"M:0\" .. \"M:1\"", "0-based"});
  expect_error([&] { io::read_column(path, "bad"); }, {"\"bad\"", "element 2", "finite"});
}

// A matrix variable's columns: NAME:INDEX (0-based); vectors (N x 1, 1 x N) with or without
// ":0"; errors naming the file, the variable and what is wrong with it.
TEST(Mat, MatrixColumnsByIndex) {
  TempDir dir;
  const auto path = dir.file("matrix.mat");
  mat_t* m = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(m, nullptr);
  // data: 4 samples x 3 columns, column-major as MATLAB stores it: data(:,j+1) = 10*j + (1..4)
  double data[12] = {1, 2, 3, 4, 11, 12, 13, 14, 21, 22, 23, 24};
  std::int32_t ints[8] = {-1, -2, -3, -4, 5, 6, 7, 8};                  // 4x2 int32
  double col[4] = {0.5, 1.5, 2.5, 3.5}, row[4] = {9, 8, 7, 6};          // 4x1 and 1x4
  double nanm[6] = {1, 2, 3, 4, NAN, 6};                                // 3x2, NaN in column 1
  double re[4] = {1, 2, 3, 4}, im[4] = {0, 0, 1, 0};
  mat_complex_split_t cplx{re, im};
  double cube[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  char text[5] = {'h', 'e', 'l', 'l', 'o'};
  // sparse 3x2 [1 0; 0 0; 0 2]
  mat_uint32_t ir[2] = {0, 2}, jc[3] = {0, 1, 2};
  double sdata[2] = {1, 2};
  mat_sparse_t sparse{};
  sparse.nzmax = 2;
  sparse.ir = ir;
  sparse.nir = 2;
  sparse.jc = jc;
  sparse.njc = 3;
  sparse.ndata = 2;
  sparse.data = sdata;
  size_t d43[2] = {4, 3}, d42[2] = {4, 2}, d41[2] = {4, 1}, d14[2] = {1, 4}, d32[2] = {3, 2}, d22[2] = {2, 2},
         d222[3] = {2, 2, 2}, d15[2] = {1, 5};
  auto write = [&](const char* name, matio_classes c, matio_types t, int rank, size_t* dims, void* values, int opt) {
    matvar_t* v = Mat_VarCreate(name, c, t, rank, dims, values, MAT_F_DONT_COPY_DATA | opt);
    ASSERT_NE(v, nullptr) << name;
    ASSERT_EQ(Mat_VarWrite(m, v, MAT_COMPRESSION_NONE), 0) << name;
    Mat_VarFree(v);
  };
  write("data", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d43, data, 0);
  write("ints", MAT_C_INT32, MAT_T_INT32, 2, d42, ints, 0);
  write("col", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d41, col, 0);
  write("row", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d14, row, 0);
  write("nanm", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d32, nanm, 0);
  write("cplx", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d22, &cplx, MAT_F_COMPLEX);
  write("cube", MAT_C_DOUBLE, MAT_T_DOUBLE, 3, d222, cube, 0);
  write("text", MAT_C_CHAR, MAT_T_UINT8, 2, d15, text, 0);
  write("sp", MAT_C_SPARSE, MAT_T_DOUBLE, 2, d32, &sparse, 0);
  Mat_Close(m);

  // columns of a matrix, 0-based
  EXPECT_EQ(io::read_column(path, "data:0"), (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(io::read_column(path, "data:1"), (std::vector<double>{11, 12, 13, 14}));
  EXPECT_EQ(io::read_column(path, "data:2"), (std::vector<double>{21, 22, 23, 24}));
  EXPECT_EQ(io::read_column(path, "ints:1"), (std::vector<double>{5, 6, 7, 8}));
  // N x 1 and 1 x N are vectors: by name, or as their only column 0
  EXPECT_EQ(io::read_column(path, "col"), (std::vector<double>{0.5, 1.5, 2.5, 3.5}));
  EXPECT_EQ(io::read_column(path, "col:0"), (std::vector<double>{0.5, 1.5, 2.5, 3.5}));
  EXPECT_EQ(io::read_column(path, "row"), (std::vector<double>{9, 8, 7, 6}));
  EXPECT_EQ(io::read_column(path, "row:0"), (std::vector<double>{9, 8, 7, 6}));
  // a NaN in another column does not matter; in the column read it is refused with its place
  EXPECT_EQ(io::read_column(path, "nanm:0"), (std::vector<double>{1, 2, 3}));
  expect_error([&] { io::read_column(path, "nanm:1"); }, {path, "\"nanm\"", "row 2, column 1", "finite"});

  // index out of range: the matrix size
  expect_error([&] { io::read_column(path, "data:3"); },
               {path, "variable \"data\"", "column index 3 is out of range", "4x3", "3 columns", "0..2"});
  expect_error([&] { io::read_column(path, "row:1"); }, {path, "\"row\"", "column index 1", "vector", "1x4"});
  // a matrix without an index
  expect_error([&] { io::read_column(path, "data"); }, {path, "\"data\"", "4x3", "\"data:0\" .. \"data:2\""});
  // missing variable, with or without an index: the file's variables
  expect_error([&] { io::read_column(path, "nope:1"); }, {path, "no variable \"nope\"", "\"data\"", "\"ints\"", "\"sp\""});
  expect_error([&] { io::read_column(path, "nope"); }, {path, "no variable \"nope\"", "\"data\"", "\"cube\""});
  // malformed index
  for (const char* bad : {"data:x", "data:-1", "data:", ":1", "data:1.5", "data: 1"})
    expect_error([&] { io::read_column(path, bad); }, {path, std::string("\"") + bad + "\"", "NAME:INDEX", "\"data\""});
  // complex, N-D, non-numeric, sparse
  expect_error([&] { io::read_column(path, "cplx:0"); }, {path, "\"cplx\"", "complex", "2x2"});
  expect_error([&] { io::read_column(path, "cube:0"); }, {path, "\"cube\"", "3-D array", "2x2x2"});
  expect_error([&] { io::read_column(path, "cube"); }, {path, "\"cube\"", "3-D array"});
  expect_error([&] { io::read_column(path, "text:0"); }, {path, "\"text\"", "not numeric", "char"});
  expect_error([&] { io::read_column(path, "sp:1"); }, {path, "\"sp\"", "sparse", "3x2", "full()"});

  // the whole table: vectors first, then the columns of the matrices with as many rows
  const auto t = io::read_table(path);
  EXPECT_EQ(t.names, (std::vector<std::string>{"col", "row", "data:0", "data:1", "data:2", "ints:0", "ints:1"}));
  EXPECT_EQ(t.column("data:2"), (std::vector<double>{21, 22, 23, 24}));
  EXPECT_EQ(t.column("ints:0"), (std::vector<double>{-1, -2, -3, -4}));
}

// A variable named exactly like the spec wins over NAME:INDEX (matio reads names MATLAB
// cannot write); a matrix that is the file's only variable still needs a column.
TEST(Mat, ExactNameWinsAndOnlyMatrixNeedsAColumn) {
  TempDir dir;
  const auto path = dir.file("odd.mat");
  mat_t* m = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(m, nullptr);
  double v[3] = {7, 8, 9}, w[4] = {1, 2, 3, 4};
  size_t d31[2] = {3, 1}, d22[2] = {2, 2};
  matvar_t* a = Mat_VarCreate("a:1", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d31, v, MAT_F_DONT_COPY_DATA);
  ASSERT_NE(a, nullptr);
  ASSERT_EQ(Mat_VarWrite(m, a, MAT_COMPRESSION_NONE), 0);
  Mat_VarFree(a);
  Mat_Close(m);
  EXPECT_EQ(io::read_column(path, "a:1"), (std::vector<double>{7, 8, 9}));
  expect_error([&] { io::read_column(path, "a:0"); }, {path, "no variable \"a\"", "\"a:1\""});

  const auto only = dir.file("only.mat");
  m = Mat_CreateVer(only.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(m, nullptr);
  matvar_t* mm = Mat_VarCreate("M", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d22, w, MAT_F_DONT_COPY_DATA);
  ASSERT_NE(mm, nullptr);
  ASSERT_EQ(Mat_VarWrite(m, mm, MAT_COMPRESSION_ZLIB), 0);
  Mat_VarFree(mm);
  Mat_Close(m);
  expect_error([&] { io::read_column(only, ""); }, {only, "\"M\"", "2x2", "\"M:0\" .. \"M:1\""});
  EXPECT_EQ(io::read_column(only, "M:1"), (std::vector<double>{3, 4}));
  EXPECT_EQ(io::read_table(only).names, (std::vector<std::string>{"M:0", "M:1"}));
}

// ReadOptions::preferred_column picks a .mat variable as it picks a CSV column (simulate takes
// "input", invert "output"): the same columns written both ways read the same way.
TEST(Mat, PreferredVariableAsForACsvColumn) {
  TempDir dir;
  const std::vector<double> t{0, 0.5, 1}, x{0.1, -0.2, 0.3}, y{4, 5, 6};
  const auto mat = dir.file("rec.mat"), csv = dir.file("rec.csv");
  io::write_columns(mat, {"time", "input", "output"}, {t, x, y});
  io::write_columns(csv, {"time", "input", "output"}, {t, x, y});
  auto opts = [](std::string spec, std::string preferred) {
    io::ReadOptions o;
    o.column_spec = std::move(spec);
    o.preferred_column = std::move(preferred);
    return o;
  };
  for (const auto& path : {mat, csv}) {
    SCOPED_TRACE(path);
    EXPECT_EQ(io::read_column(path, opts("", "input")), x);
    EXPECT_EQ(io::read_column(path, opts("", "output")), y);
    EXPECT_EQ(io::read_column(path, opts("time", "input")), t);  // a named column wins
    std::vector<double> streamed;
    io::for_each_value(path, opts("", "output"), [&](double v) { streamed.push_back(v); });
    EXPECT_EQ(streamed, y);
    expect_error([&] { io::read_column(path, opts("", "")); }, {path, "3 "});
  }
  // several variables, none of the preferred name: the error of no choice, saying so
  expect_error([&] { io::read_column(mat, opts("", "u")); },
               {mat, "3 variables", "\"time\"", "none named \"u\"", "choose one by name"});
  // one variable: it is read whatever its name, as a CSV file's only column is
  const auto one = dir.file("one.mat");
  io::write_columns(one, {"v"}, {y});
  EXPECT_EQ(io::read_column(one, opts("", "input")), y);
}

// In a CSV file a colon is part of a header name: a header match wins, and NAME:INDEX is not
// a column selector there (the error says so).
TEST(Table, ColonInCsvHeaderIsAName) {
  TempDir dir;
  const auto path = dir.write("colon.csv", "a:b,c,data\n1,2,3\n4,5,6\n");
  EXPECT_EQ(io::read_column(path, "a:b"), (std::vector<double>{1, 4}));
  EXPECT_EQ(io::read_column(path, "0"), (std::vector<double>{1, 4}));
  EXPECT_EQ(io::read_column(path, "data"), (std::vector<double>{3, 6}));
  expect_error([&] { io::read_column(path, "data:0"); },
               {path, "no column named \"data:0\"", ".mat file only", "\"a:b\""});
  expect_error([&] { io::read_column(path, "x"); }, {path, "no column named \"x\""});
}

// A units row below the header ("s,kPa,N", a DAQ export's second header line) gives the columns'
// units and is not data; so does a header name ending in [unit] or (unit). A row of numbers and
// empty fields is data, and a non-number in a later data row is still an error.
TEST(Table, UnitsRowAndUnitsInTheHeader) {
  TempDir dir;
  const auto spec = [](const char* column) {
    io::ReadOptions o;
    o.column_spec = column;
    return o;
  };
  for (const char* text : {"time,pressure,force\ns,kPa,N\n0,1,2\n0.1,3,4\n",
                           "time;pressure;force\n[s];[kPa];(N)\n0,0;1;2\n0,1;3;4\n",
                           "# rig 3\ntime,pressure,force\n\n# units\n\"s\",\"kPa\",\"N\"\n0,1,2\n0.1,3,4\n"}) {
    SCOPED_TRACE(text);
    const auto path = dir.write("units.csv", text);
    const io::Table t = io::read_table(path);
    ASSERT_EQ(t.num_rows(), 2u);
    EXPECT_EQ(t.columns[1], (std::vector<double>{1, 3}));
    EXPECT_EQ(io::column_unit(t, 0), "s");
    EXPECT_EQ(io::column_unit(t, 1), "kPa");
    EXPECT_EQ(io::column_unit(t, 2), "N");
    EXPECT_EQ(io::column_quantity(t, 1), "pressure");
    const io::NamedColumn c = io::read_named_column(path, spec("force"));
    EXPECT_EQ(c.values, (std::vector<double>{2, 4}));
    EXPECT_EQ(c.name, "force");
    EXPECT_EQ(c.unit, "N");
    // streamed: the column's name and unit once, before its first value
    std::vector<double> streamed;
    std::vector<std::string> seen;
    io::for_each_value(
        path, spec("pressure"), [&](double v) { streamed.push_back(v); },
        [&](const io::NamedColumn& h) {
          EXPECT_TRUE(streamed.empty());
          seen.push_back(h.name + "/" + h.unit);
        });
    EXPECT_EQ(streamed, (std::vector<double>{1, 3}));
    EXPECT_EQ(seen, (std::vector<std::string>{"pressure/kPa"}));
  }
  // units in the header names; a units row, where given, wins; a bracket that is no unit stays
  const auto named = dir.write("named.csv", "t [ms],pressure (kPa),force,x()\n0,1,2,3\n");
  const io::Table n = io::read_table(named);
  EXPECT_EQ(io::column_unit(n, 0), "ms");
  EXPECT_EQ(io::column_quantity(n, 0), "t");
  EXPECT_EQ(io::column_unit(n, 1), "kPa");
  EXPECT_EQ(io::column_quantity(n, 1), "pressure");
  EXPECT_EQ(io::column_unit(n, 2), "");
  EXPECT_EQ(io::column_quantity(n, 2), "force");
  EXPECT_EQ(io::column_unit(n, 3), "");
  // a column is selected by its name without the unit, an exact name and an index first
  EXPECT_EQ(io::read_column(named, "pressure"), (std::vector<double>{1}));
  EXPECT_EQ(io::read_column(named, "pressure (kPa)"), (std::vector<double>{1}));
  EXPECT_EQ(io::read_column(named, "t"), (std::vector<double>{0}));
  const auto two = dir.write("two.csv", "p [kPa],p [bar],1 [s]\n1,0.01,5\n");
  expect_error([&] { io::read_column(two, "p"); }, {two, "2 columns are named \"p\" with a unit"});
  EXPECT_EQ(io::read_column(two, "1"), (std::vector<double>{0.01}));  // an index, not "1 [s]"
  const io::Table w = io::read_table(dir.write("wins.csv", "t [ms],p\ns,bar\n0,1\n"));
  EXPECT_EQ(io::column_unit(w, 0), "s");
  EXPECT_EQ(io::column_unit(w, 1), "bar");
  // brackets that are no unit: no blank before them ("x[0]", "sin(t)"), or digits only
  const io::Table b = io::read_table(dir.write("brackets.csv", "x[0],sin(t),p [3],q (raw)\n1,2,3,4\n"));
  EXPECT_EQ(io::column_unit(b, 0), "");
  EXPECT_EQ(io::column_unit(b, 1), "");
  EXPECT_EQ(io::column_unit(b, 2), "");
  EXPECT_EQ(io::column_quantity(b, 0), "x[0]");
  EXPECT_EQ(io::column_unit(b, 3), "raw");  // a unit by its form; canonical_unit does not know it
  // the units compared: symbols of known units, spellings of one unit alike; free text is none
  EXPECT_EQ(io::canonical_unit("KPa"), "kPa");
  EXPECT_EQ(io::canonical_unit("Pressure [kPa]"), "kPa");
  EXPECT_EQ(io::canonical_unit("(bar)"), "bar");
  EXPECT_EQ(io::canonical_unit("\xC2\xB5m"), "um");
  EXPECT_EQ(io::canonical_unit("MPa"), "MPa");
  EXPECT_EQ(io::canonical_unit("mPa"), "");  // not MPa
  EXPECT_EQ(io::canonical_unit("raw"), "");
  EXPECT_EQ(io::canonical_unit("kPa (gauge)"), "");
  // a placeholder row ("-", "NA") or the header repeated is no units row: left to the data rows
  for (const char* text : {"a,b\n-,-\n1,2\n", "a,b\nNA,NA\n1,2\n", "a,b\na,b\n1,2\n"}) {
    const auto path = dir.write("placeholder.csv", text);
    expect_error([&] { io::read_table(path); }, {path, ":2:1", "is not a number"});
  }
  // a placeholder for a column without a unit beside units: a units row, the column's unit empty
  for (const char* text : {"t,p,f\ns,kPa,-\n0,1,2\n", "t;p;f\n[s];NA;[N]\n0;1;2\n", "t,p,f\ns,,N\n0,1,2\n"}) {
    SCOPED_TRACE(text);
    const io::Table t = io::read_table(dir.write("some.csv", text));
    ASSERT_EQ(t.num_rows(), 1u);
    EXPECT_EQ(io::column_unit(t, 0), "s");
    EXPECT_EQ(io::column_unit(t, 1), std::string(text).find("kPa") != std::string::npos ? "kPa" : "");
    EXPECT_EQ(io::column_unit(t, 2), std::string(text).find("-") != std::string::npos ? "" : "N");
  }
  // a line of units that is no units row says why (a number, a field count); a data row does not
  const auto one = dir.write("one.csv", "t,p,f\ns,kPa,1\n0,1,2\n");
  expect_error([&] { io::read_table(one); },
               {one, ":2:1", "\"s\" is not a number", "line 2 is not read as a units row", "field 3 \"1\" is a number",
                "write \"-\""});
  const auto count = dir.write("count.csv", "t,p,f\ns,kPa\n0,1,2\n");
  expect_error([&] { io::read_table(count); }, {count, ":2:", "row has 2 fields", "it has 2 fields, the header 3"});
  const auto typo = dir.write("typo.csv", "t,p,f\n0,x1,2\n");
  try {
    io::read_table(typo);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("\"x1\" is not a number"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("units row"), std::string::npos) << e.what();
  }
  // a blank-separated header keeps a name's unit with it ("input [kPa]": one column, not two),
  // unless the data rows have a field for each part as written
  const io::Table one_column = io::read_table(dir.write("one.txt", "input [kPa]\n0.1\n0.2\n"));
  ASSERT_EQ(one_column.columns.size(), 1u);
  EXPECT_EQ(one_column.columns[0], (std::vector<double>{0.1, 0.2}));
  EXPECT_EQ(io::column_unit(one_column, 0), "kPa");
  EXPECT_EQ(io::column_quantity(one_column, 0), "input");
  const auto blanks = dir.write("blanks.txt", "t (s)   p [kPa] force\n0 1 2\n0.1 3 4\n");
  const io::Table tp = io::read_table(blanks);
  ASSERT_EQ(tp.columns.size(), 3u);
  EXPECT_EQ(io::column_unit(tp, 0), "s");
  EXPECT_EQ(io::column_unit(tp, 1), "kPa");
  EXPECT_EQ(io::column_quantity(tp, 2), "force");
  EXPECT_EQ(io::read_column(blanks, "p"), (std::vector<double>{1, 3}));
  std::vector<double> streamed;
  io::for_each_value(blanks, spec("p"), [&](double v) { streamed.push_back(v); });
  EXPECT_EQ(streamed, (std::vector<double>{1, 3}));
  // ... or the units row has (the header as written, its units row below it)
  const io::Table units_as_written = io::read_table(dir.write("uw.txt", "t [s] p [kPa]\nx s y kPa\n0 1 2 3\n"));
  ASSERT_EQ(units_as_written.columns.size(), 4u);
  EXPECT_EQ(units_as_written.names[1], "[s]");
  EXPECT_EQ(io::column_unit(units_as_written, 3), "kPa");
  EXPECT_EQ(units_as_written.columns[3], (std::vector<double>{3}));
  const io::Table as_written = io::read_table(dir.write("written.txt", "a (b) c\n1 2 3\n"));
  ASSERT_EQ(as_written.columns.size(), 3u);
  EXPECT_EQ(as_written.names[1], "(b)");
  EXPECT_EQ(io::read_column(dir.write("written2.txt", "a (b) c\n1 2 3\n"), "c"), (std::vector<double>{3}));
  // a row of numbers and empty fields is data, not units
  const io::Table d = io::read_table(dir.write("data.csv", "a,b,c\n1,,3\n4,,6\n"));
  EXPECT_TRUE(d.units.empty());
  EXPECT_EQ(d.num_rows(), 2u);
  // only the line right after the header can be a units row
  const auto late = dir.write("late.csv", "a,b\n1,2\ns,kPa\n");
  expect_error([&] { io::read_table(late); }, {late, ":3:1", "\"s\" is not a number"});
  // a units row with a field missing is a short row, named as such
  const auto short_row = dir.write("short.csv", "a,b,c\ns,kPa\n1,2,3\n");
  expect_error([&] { io::read_table(short_row); }, {short_row, ":2", "2 fields, expected 3"});
  // no header: no units row (a file of text lines is no table)
  io::ReadOptions none;
  none.header = io::HeaderMode::absent;
  const auto bare = dir.write("bare.csv", "s,kPa\n1,2\n");
  expect_error([&] { io::read_table(bare, none); }, {bare, ":1:1"});
}

// ---- corrupt and hostile .mat input (issue 13, item 2) ---------------------------------------

namespace {

std::string read_bytes(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
void write_bytes(const std::string& p, const std::string& b) { std::ofstream(p, std::ios::binary) << b; }

std::uint32_t u32(const std::string& b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
void set_u32(std::string& b, std::size_t at, std::uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

// One N x 1 double variable written by matio, uncompressed, in MAT v5 or v4.
std::string matio_file(const TempDir& dir, const std::string& name, mat_ft version, const std::string& var,
                       std::size_t n) {
  const auto path = dir.file(name);
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = 0.5 + static_cast<double>(i);
  mat_t* m = Mat_CreateVer(path.c_str(), nullptr, version);
  if (!m) throw std::runtime_error("Mat_CreateVer failed");
  size_t dims[2] = {n, 1};
  matvar_t* mv = Mat_VarCreate(var.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, v.data(), MAT_F_DONT_COPY_DATA);
  Mat_VarWrite(m, mv, MAT_COMPRESSION_NONE);
  Mat_VarFree(mv);
  Mat_Close(m);
  return path;
}

}  // namespace

// The issue's cases: a library-written (compressed v5) .mat cut by one byte was read with its
// last value as 2.19e-304, cut in half as 13 values then zeros, both without an error.
TEST(MatCorrupt, TruncatedCompressedFilesAreRefused) {
  TempDir dir;
  std::vector<double> x(26);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 1.0 + 0.25 * static_cast<double>(i);
  const auto good = dir.file("good.mat");
  io::write_columns(good, {"input", "output"}, {x, x});
  ASSERT_EQ(io::read_column(good, "input"), x);
  const std::string bytes = read_bytes(good);
  const auto cut1 = dir.file("cut1.mat"), half = dir.file("half.mat");
  write_bytes(cut1, bytes.substr(0, bytes.size() - 1));
  write_bytes(half, bytes.substr(0, bytes.size() / 2));
  for (const auto& p : {cut1, half}) {
    expect_error([&] { io::read_column(p, "input"); }, {p, "variable #", "truncated"});
    expect_error([&] { io::read_column(p, "output"); }, {p, "truncated"});
    expect_error([&] { io::read_table(p); }, {p, "truncated"});
  }
}

// Uncompressed v5: a cut file, and a 607-byte file whose dimensions claim 1.7e9 elements (matio
// allocated 11 GB for it): refused from the sizes, before any allocation.
TEST(MatCorrupt, UncompressedV5SizesAreCheckedAgainstTheFile) {
  TempDir dir;
  const auto path = matio_file(dir, "v5.mat", MAT_FT_MAT5, "input", 58);
  ASSERT_EQ(io::read_column(path, "input").size(), 58u);
  std::string b = read_bytes(path);
  const auto cut = dir.file("cut.mat");
  write_bytes(cut, b.substr(0, b.size() - 1));
  expect_error([&] { io::read_column(cut, "input"); }, {cut, "truncated"});
  // dims: after the 8-byte tag, the 16-byte array flags and the 8-byte dims tag
  ASSERT_EQ(u32(b, 128), 14u);   // miMATRIX
  ASSERT_EQ(u32(b, 152), 5u);    // miINT32 dims
  ASSERT_EQ(u32(b, 160), 58u);   // rows
  set_u32(b, 160, 1700000000u);  // 1.7e9 elements claimed
  const auto huge = dir.file("huge.mat");
  write_bytes(huge, b);
  EXPECT_LT(b.size(), 700u);
  expect_error([&] { io::read_column(huge, "input"); },
               {huge, "variable \"input\"", "1700000000x1", "13600000000 bytes of data", "464"});
  expect_error([&] { io::read_table(huge); }, {huge, "\"input\"", "inconsistent"});

  // the same claim inside a compressed variable (what the library writes)
  std::string element = b.substr(128);
  uLongf zlen = compressBound(static_cast<uLong>(element.size()));
  std::string z(zlen, '\0');
  ASSERT_EQ(compress(reinterpret_cast<Bytef*>(z.data()), &zlen, reinterpret_cast<const Bytef*>(element.data()),
                     static_cast<uLong>(element.size())),
            Z_OK);
  z.resize(zlen);
  std::string c = b.substr(0, 128) + std::string(8, '\0') + z;
  set_u32(c, 128, 15u);  // miCOMPRESSED
  set_u32(c, 132, static_cast<std::uint32_t>(z.size()));
  const auto hugez = dir.file("hugez.mat");
  write_bytes(hugez, c);
  expect_error([&] { io::read_column(hugez, "input"); }, {hugez, "\"input\"", "1700000000x1", "inconsistent"});
  // a compressed variable whose stream is corrupt
  std::string bad = c;
  for (std::size_t i = 140; i < bad.size(); ++i) bad[i] = static_cast<char>(bad[i] ^ 0x5a);
  const auto badz = dir.file("badz.mat");
  write_bytes(badz, bad);
  expect_error([&] { io::read_column(badz, "input"); }, {badz, "variable #1", "compressed"});
}

// MAT v4 (written by matio): truncated, and a header that claims more than the file holds. The
// old message for a truncated v4 file was `no variable "input"; the file has "input"`.
TEST(MatCorrupt, V4SizesAreCheckedAgainstTheFile) {
  TempDir dir;
  const auto path = matio_file(dir, "v4.mat", MAT_FT_MAT4, "input", 40);
  ASSERT_EQ(io::read_column(path, "input").size(), 40u);
  const std::string b = read_bytes(path);
  ASSERT_EQ(b.size(), 20u + 6u + 40u * 8u);
  const auto cut = dir.file("cut4.mat");
  write_bytes(cut, b.substr(0, b.size() - 1));
  expect_error([&] { io::read_column(cut, "input"); },
               {cut, "variable \"input\"", "truncated", "40x1 needs 320 bytes of data, the file has 319"});
  try {
    io::read_column(cut, "input");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("the file has \"input\""), std::string::npos) << e.what();
  }
  std::string h = b;
  set_u32(h, 4, 1700000000u);  // mrows
  const auto huge = dir.file("huge4.mat");
  write_bytes(huge, h);
  expect_error([&] { io::read_column(huge, "input"); }, {huge, "\"input\"", "1700000000x1", "13600000000 bytes"});
  std::string name = b;
  set_u32(name, 16, 100000u);  // name length beyond the file
  const auto badname = dir.file("name4.mat");
  write_bytes(badname, name);
  expect_error([&] { io::read_column(badname, "input"); }, {badname, "variable #1"});
}

// Mutation testing (2026-12-01): the error of a column empty on some lines names the FIRST empty
// line (not the last before a value), and a ragged row names the header's line as the reference
// (a comment line before the header counts: the header is line 2).
TEST(Csv, ErrorsNameTheFirstEmptyLineAndTheHeadersLine) {
  TempDir dir;
  const auto gaps = dir.write("gaps.csv", ",2\n,3\n,4\n5,6\n");
  expect_error([&] { io::read_column(gaps, "1"); }, {gaps + ":1:1", "empty field"});
  const auto ragged = dir.write("ragged.csv", "# a note\na,b\n1,2\n3\n");
  expect_error([&] { io::read_column(ragged, "a"); }, {ragged + ":4:", "1 fields, expected 2 (as on line 2)"});
}

// The conversion factors of the units a model or record names, from their definitions (not read
// back from the table): 1 psi = 0.45359237 kg x 9.80665 m/s^2 / (0.0254 m)^2, 1 bar = 1e5 Pa,
// 1 mbar = 1 hPa = 100 Pa, 1 atm = 101325 Pa; 1 in = 0.0254 m. A model file in psi or inches must
// be converted by the factor the message prints.
TEST(Units, ConversionFactorsFromTheirDefinitions) {
  const double psi_pa = 0.45359237 * 9.80665 / (0.0254 * 0.0254);
  const std::pair<const char*, double> mpa[] = {{"Pa", 1e-6},        {"hPa", 100e-6}, {"kPa", 1e-3},
                                                {"MPa", 1.0},        {"bar", 0.1},    {"mbar", 100e-6},
                                                {"psi", psi_pa * 1e-6}, {"atm", 0.101325}, {"barg", 0.1},
                                                {"Pressure [psi]", psi_pa * 1e-6}};
  for (const auto& [unit, factor] : mpa) EXPECT_NEAR(io::mpa_per_pressure_unit(unit), factor, 1e-12 * factor) << unit;
  EXPECT_EQ(io::mpa_per_pressure_unit("mm"), 0.0);
  const std::pair<const char*, double> per_m[] = {{"m", 1.0},   {"cm", 100.0},        {"mm", 1000.0},
                                                  {"um", 1e6},  {"\xC2\xB5m", 1e6}, {"nm", 1e9},
                                                  {"in", 1.0 / 0.0254}};
  for (const auto& [unit, count] : per_m) EXPECT_NEAR(io::length_units_per_metre(unit), count, 1e-12 * count) << unit;
  EXPECT_EQ(io::length_units_per_metre("kPa"), 0.0);
  // a model_scale within 1e-4 of the unit's count per metre is the unit's; 1 % off is a mismatch
  EXPECT_TRUE(io::model_scale_mismatch(1000.0 * (1 + 5e-5), "mm").empty());
  EXPECT_FALSE(io::model_scale_mismatch(1000.0 * 1.01, "mm").empty());
  EXPECT_FALSE(io::model_scale_mismatch(1000.0, "um").empty());
  // the controller's pressures are in MPa: a model in psi is 1 / (psi in MPa) = 145.04 x off
  ASSERT_NEAR(1e6 / psi_pa, 145.04, 0.01);
  EXPECT_NE(io::input_unit_mismatch("psi").find("145x off"), std::string::npos)
      << io::input_unit_mismatch("psi");
  EXPECT_TRUE(io::input_unit_mismatch("MPa").empty());
  // every other pressure unit is a mismatch; a unit that is no pressure is not this check's
  for (const char* unit : {"Pa", "hPa", "kPa", "bar", "mbar", "psi", "atm", "barg", "kPa (gauge) [kPa]"})
    EXPECT_FALSE(io::input_unit_mismatch(unit).empty()) << unit;
  EXPECT_TRUE(io::input_unit_mismatch("mm").empty());
}

// A units map with input_scale 0 (it divides the input) or output_gain 0 (a constant output) is
// refused at load, naming the key (model_file.cpp's units_of, and the model's own validation
// behind it: either alone refuses it).
TEST(ModelFile, ZeroInputScaleOrOutputGainIsRefusedNamingTheKey) {
  for (const char* key : {"input_scale", "output_gain"}) {
    json j = json::parse(R"({"model": "pi", "q": 1, "r": [0, 0.5], "p": [1, 0.5]})");
    EXPECT_NO_THROW(hysteron::io::model_from_json(j, "m.json"));
    j[key] = 0.0;
    expect_error([&] { hysteron::io::model_from_json(j, "m.json"); }, {"m.json", key});
  }
}
