// Regressions from fuzzing the readers (fuzz/, `make fuzz`) and from issue 13's "every
// documented constraint enforced at load": each input here once crashed, hung, allocated without
// bound or was accepted wrongly; now each is a hysteron::Error naming what and where.
#include <gtest/gtest.h>

#include <string>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/io/table.hpp"
#include "hysteron/plant.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using hysteron::Error;
namespace io = hysteron::io;
using hysteron::test::TempDir;
using hysteron::test::error_of;
using hysteron::test::has;
using hysteron::test::slurp;

namespace {

hysteron::PamRigParams rig_from(const std::string& text) {
  return hysteron::rig_params_from_json(io::parse_json(text, "rig.json"), "rig.json");
}

hysteron::ModelParams model_from(const std::string& text) {
  return io::model_from_json(io::parse_json(text, "m.json"), "m.json");
}

}  // namespace

// An integer field beyond int wrapped: 2^32 + 12 read as 12 bits and was accepted.
TEST(FuzzRegression, RigIntegerFieldsOutsideIntAreRefusedNotWrapped) {
  const std::string m1 = error_of([] { rig_from(R"({"sensors": {"pressure_bits": 4294967308}})"); });
  EXPECT_TRUE(has(m1, "rig.json.sensors.pressure_bits = 4294967308: must be an integer in [1, 31]")) << m1;
  const std::string m2 = error_of([] { rig_from(R"({"simulation": {"max_substeps": -4294967295}})"); });
  EXPECT_TRUE(has(m2, "simulation.max_substeps")) << m2;
  const std::string m3 = error_of([] { rig_from(R"({"simulation": {"max_substeps": 18446744073709551615}})"); });
  EXPECT_TRUE(has(m3, "simulation.max_substeps = 18446744073709551615")) << m3;
  EXPECT_EQ(rig_from(R"({"sensors": {"pressure_bits": 12}})").sensors.pressure_bits, 12);
}

// docs/model-files.md: dead-zone thresholds z_k != 0; z = 0 was folded into g0 silently.
TEST(FuzzRegression, ZeroDeadZoneThresholdRefusedAtLoadAndWrite) {
  const std::string base = R"({"model": "mpi-deadzone", "q": 0.8, "r": [0.1], "p": [0.3], "g0": 1, )";
  const std::string m1 = error_of([&] { model_from(base + R"("z": [-0.5, 0], "g": [0.2, 0.3]})"); });
  EXPECT_TRUE(has(m1, "m.json: mpi-deadzone: key \"z[1]\"")) << m1;
  EXPECT_TRUE(has(m1, "non-zero")) << m1;
  EXPECT_TRUE(has(error_of([&] { model_from(base + R"("z": [-0.0], "g": [0.2]})"); }), "z[0]"));
  EXPECT_NO_THROW(model_from(base + R"("z": [-0.5, 0.25], "g": [0.2, 0.3]})"));
  TempDir dir;
  hysteron::MpiDeadzoneParams dz;
  dz.r = {0.1};
  dz.p = {0.3};
  dz.z = {0.0};
  dz.g = {0.2};
  const std::string m2 = error_of([&] { io::write_model_file(dir.file("dz.json"), dz); });
  EXPECT_TRUE(has(m2, "refusing to write an invalid model")) << m2;
  EXPECT_TRUE(dir.entries().empty());
}

// ---- .mat (fuzz_mat): the inputs libFuzzer found are in fuzz/regressions/mat/ -----------------

namespace {
std::string regression(const std::string& name) { return std::string(HYSTERON_SOURCE_DIR) + "/fuzz/regressions/" + name; }
}  // namespace

// A char variable whose data tag was mutated: matio allocated the 1.95 GB the tag's bytes
// ("text") declared. Every class matio reads is now size-checked, char included.
TEST(FuzzRegression, MatCharVariableWithCorruptDataSizeIsRefusedBeforeMatioAllocates) {
  const std::string path = regression("mat/char-data-declares-2GB.mat");
  const std::string msg = error_of([&] { io::read_table(path); });
  EXPECT_TRUE(has(msg, path + ": variable #3")) << msg;
  EXPECT_TRUE(has(msg, "inconsistent")) << msg;
  EXPECT_TRUE(has(error_of([&] { io::read_column(path, "x"); }), "variable #3"));
}

// A function-handle variable (class 16) of size 67108865 x 4 in 48 bytes: matio allocated 32 bytes
// per element (2 GB) while listing the variables (found by the CI's 25 s fuzz_mat run).
TEST(FuzzRegression, MatFunctionClassSizedBeyondTheFileIsRefused) {
  const std::string path = regression("mat/function-class-declares-67M-elements.mat");
  const std::string msg = error_of([&] { io::read_table(path); });
  EXPECT_TRUE(has(msg, "variable \"c\": truncated or inconsistent: a variable of class 16 and size 67108865x4")) << msg;
  EXPECT_TRUE(has(msg, "truncated or inconsistent")) << msg;
}

// A MAT v5 sparse matrix whose values element declares 4,176,674,816 bytes in an 80-byte
// variable, its column starts a small element of type 17 (UTF-16): matio allocated the 4 GB
// (found by the third long fuzz_mat run at 8,966,069 executions). Index arrays must now be of a
// numeric type (not miUTF8/miUTF16; matio converts any numeric type), and the values (and imaginary values) are checked like the index arrays: the
// second file is the first with the column starts made int32, so only the values are wrong.
TEST(FuzzRegression, MatV5SparseValuesDeclaringMoreThanTheVariableAreRefused) {
  const std::string found = regression("mat/v5-sparse-utf16-column-starts.mat");
  const std::string msg = error_of([&] { io::read_table(found); });
  EXPECT_TRUE(has(msg, "variable \"data\": inconsistent: sparse index arrays of 8 and 1 bytes")) << msg;
  const std::string path = regression("mat/v5-sparse-values-declare-4GB.mat");
  const std::string msg2 = error_of([&] { io::read_table(path); });
  EXPECT_TRUE(has(msg2, "variable \"data\": truncated or inconsistent: its sparse values declares 4176674816 bytes"))
      << msg2;
  EXPECT_TRUE(has(error_of([&] { io::read_column(path, "data"); }), "sparse values")) << msg2;
}

// A MAT v4 sparse matrix stored as 855638017 x 0: matio sized it by the rows (3.4 GB).
TEST(FuzzRegression, MatV4SparseWithoutItsThreeColumnsIsRefused) {
  const std::string path = regression("mat/v4-sparse-0-columns.mat");
  const std::string msg = error_of([&] { io::read_table(path); });
  EXPECT_TRUE(has(msg, "a sparse MAT v4 matrix stored as 855638017x0")) << msg;
}

// 128 bytes with the v5 endian mark "IM" but version 0x0900: the structure check took it for a v5
// file without variables, matio (v5 / v7.3 only for versions 0x0100 / 0x0200) read it as MAT v4
// and allocated 1 GB for its second variable's name (found by fuzz_mat while measuring its
// exec/s). A file is now checked as the format matio will read it as.
TEST(FuzzRegression, MatV5MarkWithUnknownVersionIsCheckedAsMatioReadsItAsV4) {
  const std::string path = regression("mat/v5-mark-unknown-version-read-as-v4.mat");
  const std::string msg = error_of([&] { io::read_table(path); });
  EXPECT_TRUE(has(msg, path + ": variable #2: inconsistent MAT v4 header")) << msg;
  EXPECT_TRUE(has(msg, "name length 1072693248")) << msg;
  EXPECT_TRUE(has(error_of([&] { io::read_column(path, "x"); }), "variable #2"));
}

// MAT v4 variables whose type word is stored byte-swapped with M = 0: the check swapped every
// header field with it, matio swaps the others only for M = 1 and read the name length as
// stored. Found by the long fuzz_mat run: 165 bytes made matio allocate 1.29 GB while listing
// the variables; 56 bytes allocated and zero-filled 64 MB per open (the run's slowdown).
TEST(FuzzRegression, MatV4ByteOrderTakenFromTheMachineDigitAsMatioDoes) {
  const std::string big = regression("mat/v4-type-swapped-name-length-1.2GB.mat");
  const std::string m1 = error_of([&] { io::read_table(big); });
  EXPECT_TRUE(has(m1, big + ": variable #2: inconsistent MAT v4 header (type 1, 909258802x0, name length 1291845632)"))
      << m1;
  EXPECT_TRUE(has(error_of([&] { io::read_column(big, "data:1"); }), "name length 1291845632"));
  const std::string small = regression("mat/v4-type-swapped-name-length-64MB.mat");
  const std::string m2 = error_of([&] { io::read_table(small); });
  EXPECT_TRUE(has(m2, small + ": variable #1: inconsistent MAT v4 header (type 2")) << m2;
  EXPECT_TRUE(has(m2, "name length 67108864")) << m2;
}

// The same classes built by hand: a char matrix declaring 10^8 characters with 8 bytes of data,
// a cell declaring 10^8 elements, a struct declaring 10^8 fields, sparse with a huge nzmax; each
// in a 200-byte file.
TEST(FuzzRegression, MatNonNumericClassesSizesCheckedAgainstTheFile) {
  TempDir dir;
  auto u32 = [](std::string& s, std::uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); };
  auto header = [] {
    std::string h(116, ' ');
    h.replace(0, 10, "MATLAB 5.0");
    h += std::string(8, '\0');
    h += std::string("\x00\x01IM", 4);
    return h;
  };
  // miMATRIX of class `cls`, dims rows x cols, name "v", then `tail` (already-tagged elements)
  auto matrix = [&](std::uint32_t cls, std::uint32_t rows, std::uint32_t cols, const std::string& tail,
                    std::uint32_t nzmax = 0) {
    std::string body;
    u32(body, 6), u32(body, 8), u32(body, cls), u32(body, nzmax);         // array flags
    u32(body, 5), u32(body, 8), u32(body, rows), u32(body, cols);         // dimensions
    u32(body, (1u << 16) | 1u), body += "v", body += std::string(3, '\0');  // name (small element)
    body += tail;
    std::string m;
    u32(m, 14), u32(m, static_cast<std::uint32_t>(body.size()));
    return header() + m + body;
  };
  std::string chars;
  u32(chars, 4), u32(chars, 8), chars += "abcdabcd";  // miUINT16, 8 bytes = 4 characters
  const auto c = dir.write("char.mat", matrix(4, 10000, 10000, chars));
  EXPECT_TRUE(has(error_of([&] { io::read_table(c); }), "size 10000x10000 (100000000 elements) needs 200000000 bytes"));
  const auto cell = dir.write("cell.mat", matrix(1, 10000, 10000, ""));
  EXPECT_TRUE(has(error_of([&] { io::read_table(cell); }), "needs 100000000 elements"));
  std::string fields;
  u32(fields, (4u << 16) | 5u), u32(fields, 8);  // field name length 8 (small element)
  u32(fields, 1), u32(fields, 16), fields += std::string("aaaaaaa\0bbbbbbb\0", 16);  // 2 names
  const auto st = dir.write("struct.mat", matrix(2, 10000, 10000, fields));
  EXPECT_TRUE(has(error_of([&] { io::read_table(st); }), "needs 200000000 elements"));
  const auto sp = dir.write("sparse.mat", matrix(5, 3, 3, "", 0x40000000u));
  EXPECT_TRUE(has(error_of([&] { io::read_table(sp); }), "nzmax 1073741824"));
  // a well-formed char variable next to a vector is still skipped by read_table, not an error
  std::string ok_chars;
  u32(ok_chars, 4), u32(ok_chars, 8), ok_chars += std::string("a\0b\0c\0d\0", 8);
  const auto good = dir.write("good.mat", matrix(4, 1, 4, ok_chars));
  const io::Table t = io::read_table(good);
  EXPECT_EQ(t.num_columns(), 0u);
}

// ---- CSV (fuzz_csv) ------------------------------------------------------------------------

// A 415-byte line of ~400 mostly empty columns: choosing a column (no --column, several
// non-empty ones) listed every column in the message (unbounded: 3.4 MB for 200,000 columns).
TEST(FuzzRegression, ColumnChoiceErrorListsAtMost20Columns) {
  io::ReadOptions o;
  o.preferred_column = "input";  // as the fuzz input's mode byte 0x8c chose
  const std::string path = regression("csv/wide-row-error-lists-every-column.csv");
  std::string text = hysteron::test::slurp(path).substr(1);  // without the fuzzer's mode byte
  TempDir dir;
  const std::string file = dir.write("wide.csv", text);
  const std::string msg = error_of([&] { io::for_each_value(file, o, [](double) {}); });
  EXPECT_TRUE(has(msg, "non-empty columns")) << msg.substr(0, 300);
  EXPECT_TRUE(has(msg, "more)")) << msg.substr(0, 300);
  EXPECT_LT(msg.size(), 1000u);
  // the same for a 5000-column header naming each column
  std::string header, row;
  for (int i = 0; i < 5000; ++i) {
    header += (i ? ",column_" : "column_") + std::to_string(i);
    row += i ? ",1" : "1";
  }
  const std::string m2 = error_of([&] { io::parse_text_table(header + "\n" + row + "\n", "w.csv").column("nope"); });
  EXPECT_TRUE(has(m2, "no column named \"nope\"")) << m2.substr(0, 300);
  EXPECT_TRUE(has(m2, "19 \"column_19\", ... (4980 more)")) << m2.substr(0, 600);
  EXPECT_LT(m2.size(), 1000u);
}

// The duplicate-header check sorted every non-empty name (a third of fuzz_csv's time on its grown
// corpus of wide headers); then one hash pass over the header. Since 2026-12-01 a repeated name is
// refused only where it selects a column (one scan of the names per selection): a wide header with
// repeated names reads, and selecting one of them names its first two columns, counted from 0.
TEST(FuzzRegression, DuplicateHeaderNamesAreRefusedOnlyWhereSelected) {
  const auto msg = [](const std::string& text, const char* col) {
    return error_of([&] { io::parse_text_table(text, "h.csv").column(col); });
  };
  EXPECT_NO_THROW(io::parse_text_table("b,a,b,a,a\n1,2,3,4,5\n", "h.csv"));
  EXPECT_TRUE(has(msg("b,a,b,a,a\n1,2,3,4,5\n", "a"), "h.csv: column name \"a\" appears twice (columns 1 and 3"))
      << msg("b,a,b,a,a\n1,2,3,4,5\n", "a");
  const std::string m2 = msg("z,,y,,\"z\",x,y\n1,2,3,4,5,6,7\n", "y");
  EXPECT_TRUE(has(m2, "column name \"y\" appears twice (columns 2 and 6")) << m2;
  EXPECT_EQ(io::parse_text_table("z,,y,,\"z\",x,y\n1,2,3,4,5,6,7\n", "h.csv").column("x"), std::vector<double>{6});
  EXPECT_NO_THROW(io::parse_text_table(",,x,,y\n1,2,3,4,5\n", "h.csv"));
  // 9,000 distinct names (the limit is max_text_columns = 10,000), then two of them again
  std::string header, row;
  for (int i = 0; i < 9000; ++i) {
    header += (i ? ",c" : "c") + std::to_string(i);
    row += i ? ",1" : "1";
  }
  const std::string text = header + ",c8999,c1000\n" + row + ",1,1\n";
  EXPECT_NO_THROW(io::parse_text_table(text, "w.csv").column("c5"));
  const std::string m4 = msg(text, "c1000");
  EXPECT_TRUE(has(m4, "column name \"c1000\" appears twice (columns 1000 and 9001")) << m4.substr(0, 300);
}
