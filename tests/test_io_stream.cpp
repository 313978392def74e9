// Text-table caps, the chunked and streamed readers, CSV numbers in shortest round-trip form,
// streamed CSV output and uncompressed .mat output (issue 13, items 2 and 8).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"
#include "temp_dir.hpp"
#include "test_util.hpp"

using hysteron::Error;
namespace io = hysteron::io;
using hysteron::test::TempDir;
using hysteron::test::error_of;
using hysteron::test::has;
using hysteron::test::slurp;

namespace {

// Bit patterns equal (0.0 vs -0.0 differ; EXPECT_EQ on doubles would not see it).
void expect_bits_equal(const std::vector<double>& a, const std::vector<double>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a[i]), std::bit_cast<std::uint64_t>(b[i])) << "row " << i << ": " << a[i];
}

std::vector<double> streamed(const std::string& path, const io::ReadOptions& o) {
  std::vector<double> v;
  io::for_each_value(path, o, [&](double x) { v.push_back(x); });
  return v;
}

}  // namespace

// ---- caps ---------------------------------------------------------------------------

TEST(CsvCaps, TooManyColumnsIsAnErrorNamingTheLine) {
  std::string header, row;
  for (std::size_t i = 0; i <= io::max_text_columns; ++i) {  // one more than allowed
    header += (i ? ",c" : "c") + std::to_string(i);
    row += i ? ",1" : "1";
  }
  const std::string msg = error_of([&] { io::parse_text_table("# x\n" + header + "\n" + row + "\n", "wide.csv"); });
  EXPECT_TRUE(has(msg, "wide.csv:2:")) << msg;
  EXPECT_TRUE(has(msg, "more than 10000 fields")) << msg;
  EXPECT_LT(msg.size(), 300u);  // not a list of 10001 names
  // at the cap it reads
  std::string h2, r2;
  for (std::size_t i = 0; i < io::max_text_columns; ++i) {
    h2 += (i ? ",c" : "c") + std::to_string(i);
    r2 += i ? ",2" : "3";
  }
  const io::Table t = io::parse_text_table(h2 + "\n" + r2 + "\n", "ok.csv");
  ASSERT_EQ(t.num_columns(), io::max_text_columns);
  EXPECT_EQ(t.column("c9999"), std::vector<double>{2});
  // a data row with too many fields (the first line was fine) names its own line
  const std::string msg2 = error_of([&] { io::parse_text_table("a,b\n1,2\n" + row + "\n", "rows.csv"); });
  EXPECT_TRUE(has(msg2, "rows.csv:3:")) << msg2;
}

TEST(CsvCaps, OverlongLineIsAnErrorInMemoryAndFromAFile) {
  TempDir dir;
  const std::string longline(io::max_text_line_bytes + 1, '7');
  const std::string text = "x\n1\n" + longline + "\n2\n";
  const std::string m1 = error_of([&] { io::parse_text_table(text, "long.csv"); });
  EXPECT_TRUE(has(m1, "long.csv:3: line longer than 1048576 bytes")) << m1;
  const auto path = dir.write("long.csv", text);
  const std::string m2 = error_of([&] { io::read_column(path, "x"); });
  EXPECT_TRUE(has(m2, path + ":3: line longer than 1048576 bytes")) << m2;
  const std::string m3 = error_of([&] { streamed(path, {}); });
  EXPECT_TRUE(has(m3, path + ":3: line longer")) << m3;
  // a binary file without any line end is refused the same way (not read into one huge line)
  const auto bin = dir.write("bin.csv", std::string(3 * io::max_text_line_bytes, '\x01'));
  EXPECT_TRUE(has(error_of([&] { io::read_table(bin); }), ":1: line longer")) ;
}

TEST(CsvCaps, MessagesShowFieldsShortAndWithoutControlBytes) {
  const std::string field(100000, 'z');
  const std::string m1 = error_of([&] { io::parse_text_table("a\n1\n" + field + "\n", "f.csv"); });
  EXPECT_TRUE(has(m1, "f.csv:3:1")) << m1.substr(0, 200);
  EXPECT_LT(m1.size(), 300u);
  EXPECT_TRUE(has(m1, "(100000 bytes)")) << m1.substr(0, 200);
  const std::string m2 = error_of([&] { io::parse_text_table("a\n1\n2\x01x\n", "c.csv"); });
  EXPECT_TRUE(has(m2, "\"2\\x01x\" is not a number")) << m2;
  EXPECT_EQ(m2.find('\x01'), std::string::npos);
}

TEST(Csv, CrOnlyLineEndingsAreLines) {
  const io::Table t = io::parse_text_table("in,out\r1,2\r3,4\r", "mac.csv");
  EXPECT_EQ(t.column("in"), (std::vector<double>{1, 3}));
  EXPECT_EQ(t.column("out"), (std::vector<double>{2, 4}));
  // mixed LF, CRLF and CR: line numbers count each
  const std::string msg = error_of([&] { io::parse_text_table("a\n1\r\n2\rx\n", "mixed.csv"); });
  EXPECT_TRUE(has(msg, "mixed.csv:4:1")) << msg;
}

// ---- the chunked file reader and the streamed column -----------------------------

TEST(CsvStream, ChunkedReadEqualsTheWrittenValuesAcrossChunkBoundaries) {
  TempDir dir;
  // ~5 MB: several 64 KiB..2 MiB chunks, CRLF line ends (a CR may end a chunk)
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  std::vector<double> a, b;
  std::string text = "\xEF\xBB\xBFt,a,b\r\n";
  char num[64];
  for (int k = 0; k < 120000; ++k) {
    a.push_back(u(rng));
    b.push_back(u(rng) * 1e-200);
    std::snprintf(num, sizeof num, "%d,%.17g,%.17g\r\n", k, a.back(), b.back());
    text += num;
  }
  const auto path = dir.write("big.csv", text);
  expect_bits_equal(io::read_column(path, "a"), a);
  expect_bits_equal(io::read_column(path, "b"), b);
  io::ReadOptions o;
  o.column_spec = "b";
  expect_bits_equal(streamed(path, o), b);
  expect_bits_equal(io::parse_text_table(text, "mem").column("a"), a);
}

TEST(CsvStream, ColumnSelectionAndErrorsAsReadColumn) {
  TempDir dir;
  const auto three = dir.write("three.csv", "time,input,output\n0,1,2\n1,3,4\n");
  io::ReadOptions o;
  o.preferred_column = "input";
  EXPECT_EQ(streamed(three, o), (std::vector<double>{1, 3}));
  EXPECT_EQ(io::read_column(three, o), (std::vector<double>{1, 3}));
  o.column_spec = "2";
  EXPECT_EQ(streamed(three, o), (std::vector<double>{2, 4}));
  // preferred only when the file has several non-empty columns
  const auto one = dir.write("one.csv", ",x\n,5\n,6\n");
  io::ReadOptions p;
  p.preferred_column = "input";
  EXPECT_EQ(streamed(one, p), (std::vector<double>{5, 6}));
  // errors: no preferred name among several columns; an empty column; a header without data
  const auto two = dir.write("two.csv", "a,b\n1,2\n");
  EXPECT_TRUE(has(error_of([&] { streamed(two, p); }), "has 2 non-empty columns"));
  io::ReadOptions c0;
  c0.column_spec = "0";
  EXPECT_TRUE(has(error_of([&] { streamed(one, c0); }), "is empty in every row"));
  const auto header_only = dir.write("h.csv", "a\n");
  io::ReadOptions ca;
  ca.column_spec = "a";
  EXPECT_TRUE(has(error_of([&] { streamed(header_only, ca); }), "has no data"));
  EXPECT_TRUE(has(error_of([&] { io::read_column(header_only, "a"); }), "has no data"));
  // a bad later line is reported after the earlier values were delivered
  const auto bad = dir.write("bad.csv", "x\n1\n2\noops\n");
  std::vector<double> got;
  const std::string msg = error_of([&] { io::for_each_value(bad, {}, [&](double v) { got.push_back(v); }); });
  EXPECT_TRUE(has(msg, bad + ":4:1")) << msg;
  EXPECT_EQ(got, (std::vector<double>{1, 2}));
}

// ---- CSV output: std::to_chars, bit-exact round trips ------------------------------

TEST(CsvWrite, ShortestFormReadsBackBitExactly) {
  TempDir dir;
  const double sub_min = std::numeric_limits<double>::denorm_min();
  std::vector<double> v{0.1, 1.0 / 3.0, -0.0, 0.0, sub_min, -sub_min, 2.2250738585072009e-308,
                        std::numeric_limits<double>::min(), std::numeric_limits<double>::max(),
                        -std::numeric_limits<double>::max(), 1e21, 123456789.123456789, -2.5e-310};
  std::mt19937_64 rng(11);
  for (int k = 0; k < 20000; ++k) {  // random bit patterns, finite only
    const double d = std::bit_cast<double>(rng());
    if (std::isfinite(d)) v.push_back(d);
  }
  const std::vector<double> idx = [&] {
    std::vector<double> i(v.size());
    for (std::size_t k = 0; k < i.size(); ++k) i[k] = static_cast<double>(k);
    return i;
  }();
  const auto path = dir.file("rt.csv");
  io::write_columns(path, {"k", "v"}, {idx, v});
  expect_bits_equal(io::read_column(path, "v"), v);
  // the shortest decimal form: 0.1 is "0.1" (printf %.17g wrote 0.10000000000000001)
  const std::string text = slurp(path);
  EXPECT_EQ(text.substr(0, 20), "k,v\n0,0.1\n1,0.333333");
  EXPECT_NE(text.find("\n2,-0\n"), std::string::npos);
  EXPECT_NE(text.find("\n4,5e-324\n"), std::string::npos);
  EXPECT_NE(text.find("\n8,1.7976931348623157e+308\n"), std::string::npos);
}

TEST(CsvWrite, NonFiniteValuesRefusedNothingWritten) {
  TempDir dir;
  const auto path = dir.write("keep.csv", "precious\n");
  for (const double bad : {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_TRUE(has(error_of([&] { io::write_columns(path, {"a"}, {{1.0, bad}}); }), "row 1 is not finite"));
    // the streamed writer refuses it too, after rows were already buffered
    const std::string msg = error_of([&] {
      io::write_csv_rows(path, {"a", "b"}, [&](io::CsvRowWriter& w) {
        for (int k = 0; k < 100000; ++k) w.row(std::vector<double>{1.0 * k, 2.0});
        w.row(std::vector<double>{3.0, bad});
      });
    });
    EXPECT_TRUE(has(msg, "column \"b\" row 100000 is not finite")) << msg;
  }
  EXPECT_EQ(slurp(path), "precious\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"keep.csv"});
}

TEST(CsvWrite, AnErrorOfTheRowSourceIsPassedOnAsItIsAndLeavesNothing) {
  TempDir dir;
  const auto path = dir.write("out.csv", "old\n");
  const std::string msg = error_of([&] {
    io::write_csv_rows(path, {"x"}, [](io::CsvRowWriter& w) {
      w.row(std::vector<double>{1});
      throw Error("input.csv:7:1: \"q\" is not a number");
    });
  });
  EXPECT_EQ(msg, "input.csv:7:1: \"q\" is not a number");  // not renamed after out.csv
  EXPECT_EQ(slurp(path), "old\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.csv"});
  // a new path is not created at all
  EXPECT_THROW(io::write_csv_rows(dir.file("new.csv"), {"x"}, [](io::CsvRowWriter&) { throw Error("no"); }), Error);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.csv"});
  // success: header and rows
  io::write_csv_rows(path, {"x", "y"}, [](io::CsvRowWriter& w) {
    w.row(std::vector<double>{1, 0.5});
    w.row(std::vector<double>{-2, 1e-7});
    EXPECT_EQ(w.rows(), 2u);
  });
  EXPECT_EQ(slurp(path), "x,y\n1,0.5\n-2,1e-07\n");
  EXPECT_THROW(io::write_csv_rows(path, {"1"}, [](io::CsvRowWriter&) {}), Error);  // a numeric name
}

// ---- .mat output: uncompressed unless asked ------------------------------------------

TEST(MatWrite, UncompressedByDefaultCompressedOnRequestBothExact) {
  TempDir dir;
  std::vector<double> x;
  for (int k = 0; k < 5000; ++k) x.push_back(std::sin(0.01 * k) + (k % 7 == 0 ? std::numeric_limits<double>::denorm_min() : 0.0));
  const auto plain = dir.file("plain.mat"), packed = dir.file("packed.mat");
  io::write_columns(plain, {"x"}, {x});
  io::WriteOptions w;
  w.compress_mat = true;
  io::write_columns(packed, {"x"}, {x}, w);
  // the first data element after the 128-byte header: miMATRIX (14) or miCOMPRESSED (15)
  auto first_type = [](const std::string& bytes) {
    std::uint32_t t = 0;
    std::memcpy(&t, bytes.data() + 128, 4);
    return t;
  };
  const std::string a = slurp(plain), b = slurp(packed);
  ASSERT_GT(a.size(), 136u);
  ASSERT_GT(b.size(), 136u);
  EXPECT_EQ(first_type(a), 14u);
  EXPECT_EQ(first_type(b), 15u);
  EXPECT_GT(a.size(), 5000u * 8u);  // the raw doubles are in the file
  expect_bits_equal(io::read_column(plain, "x"), x);
  expect_bits_equal(io::read_column(packed, "x"), x);
}

// A legitimate long line (10000 columns of 49-character numbers: ~500 KB, beyond the reader's first
// 256 KiB buffer) is read from a file like from memory.
TEST(CsvStream, LongLinesGrowTheBufferUpToTheCap) {
  TempDir dir;
  const std::string num = "0.12345678901234567890123456789012345678901234567";  // 49 characters
  std::string header, row;
  for (std::size_t i = 0; i < io::max_text_columns; ++i) {
    header += (i ? ",c" : "c") + std::to_string(i);
    row += (i ? "," : "") + (i == 9999 ? std::string("-2.5") : num);
  }
  ASSERT_GT(row.size(), std::size_t{262144});  // longer than the first buffer
  const std::string text = header + "\n" + row + "\n" + row + "\n";
  const auto path = dir.write("long.csv", text);
  EXPECT_EQ(io::read_column(path, "c9999"), (std::vector<double>{-2.5, -2.5}));
  io::ReadOptions o;
  o.column_spec = "c0";
  expect_bits_equal(streamed(path, o), std::vector<double>(2, 0.12345678901234567890123456789012345678901234567));
  EXPECT_EQ(io::parse_text_table(text, "m").column("c9999"), (std::vector<double>{-2.5, -2.5}));
}
