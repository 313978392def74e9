// MAT v7.3 (HDF5) input (issue 13): Debian's matio is built with HDF5, so a v7.3 file is read
// like a v5 one; a v7.3 file that is cut, or whose header is not followed by HDF5 data, is an
// error naming the file and the reason (it read as "0 variables" before). The files are written
// by matio itself (Mat_CreateVer(..., MAT_FT_MAT73)); without HDF5 support in matio the tests
// are skipped with a message.
#include <gtest/gtest.h>
#include <matio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"
#include "temp_dir.hpp"

namespace {

using hysteron::test::TempDir;
namespace io = hysteron::io;

// Writes "input" (n x 1) and "data" (n x 2: input, 2 * input + 1) as MAT v7.3; false if matio cannot.
bool write_mat73(const std::string& path, const std::vector<double>& x) {
  mat_t* m = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT73);
  if (!m) return false;
  const std::size_t n = x.size();
  std::vector<double> data(2 * n);  // column-major
  for (std::size_t k = 0; k < n; ++k) data[k] = x[k], data[n + k] = 2 * x[k] + 1;
  std::size_t d1[2] = {n, 1}, d2[2] = {n, 2};
  bool ok = true;
  for (auto [name, dims, ptr] : {std::tuple{"input", d1, const_cast<double*>(x.data())}, std::tuple{"data", d2, data.data()}}) {
    matvar_t* v = Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, ptr, 0);
    ok = ok && v && Mat_VarWrite(m, v, MAT_COMPRESSION_NONE) == 0;
    Mat_VarFree(v);
  }
  return Mat_Close(m) == 0 && ok;
}

std::vector<double> signal(std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) x[k] = 0.3 + 0.1 * std::sin(static_cast<double>(k) / 50.0) + 1e-17 * k;
  return x;
}

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The error message of read_column(path, spec), or "" if it read.
std::string read_error(const std::string& path, const std::string& spec) {
  try {
    (void)io::read_column(path, spec);
  } catch (const hysteron::Error& e) {
    return e.what();
  }
  return "";
}

TEST(Mat73, IsReadLikeAV5File) {
  TempDir dir;
  const auto x = signal(3000);
  const std::string path = dir.file("v73.mat");
  if (!write_mat73(path, x)) GTEST_SKIP() << "this matio cannot write MAT v7.3 (built without HDF5)";
  ASSERT_EQ(bytes_of(path).substr(0, 19), "MATLAB 7.3 MAT-file");
  EXPECT_EQ(io::read_column(path, "input"), x);
  const auto col1 = io::read_column(path, "data:1");
  ASSERT_EQ(col1.size(), x.size());
  for (std::size_t k = 0; k < x.size(); ++k) ASSERT_EQ(col1[k], 2 * x[k] + 1) << k;
  const io::Table t = io::read_table(path);
  EXPECT_EQ(t.names, (std::vector<std::string>{"input", "data:0", "data:1"}));
  EXPECT_EQ(t.column("data:0"), x);
  // the same data as a v5 file (written by hysteron) read back identically
  io::write_columns(dir.file("v5.mat"), {"input"}, {x});
  EXPECT_EQ(io::read_column(dir.file("v5.mat"), "input"), io::read_column(path, "input"));
  EXPECT_NE(read_error(path, "nosuch").find("no variable \"nosuch\""), std::string::npos) << read_error(path, "nosuch");
}

TEST(Mat73, CutOrHeaderOnlyFilesAreClearErrors) {
  TempDir dir;
  const std::string path = dir.file("v73.mat");
  if (!write_mat73(path, signal(3000))) GTEST_SKIP() << "this matio cannot write MAT v7.3 (built without HDF5)";
  const std::string whole = bytes_of(path);
  ASSERT_GT(whole.size(), 4000u);
  struct Case {
    std::string name, bytes, expect;
  };
  const Case cases[] = {
      {"half.mat", whole.substr(0, whole.size() / 2), "MAT v7.3 (HDF5) file truncated: its superblock declares"},
      {"minus1.mat", whole.substr(0, whole.size() - 1), "MAT v7.3 (HDF5) file truncated"},
      {"superblock_cut.mat", whole.substr(0, 530), "its superblock at byte 512 is cut"},
      {"header_only.mat", whole.substr(0, 512), "MAT v7.3 header but no HDF5 data after it"},
      {"junk.mat", whole.substr(0, 512) + std::string(2000, 'x'), "MAT v7.3 header but no HDF5 data after it"},
  };
  for (const auto& c : cases) {
    const std::string p = dir.write(c.name, c.bytes);
    const std::string msg = read_error(p, "input");
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.name << ": " << msg;
    EXPECT_NE(msg.find(c.name), std::string::npos) << c.name << ": " << msg;  // names the file
    const std::string table_msg = [&] {
      try {
        (void)io::read_table(p);
      } catch (const hysteron::Error& e) {
        return std::string(e.what());
      }
      return std::string();
    }();
    EXPECT_NE(table_msg.find(c.expect), std::string::npos) << c.name << ": " << table_msg;
  }
}

}  // namespace
