// MAT v7.3 (HDF5) input (issue 13): Debian's matio is built with HDF5, so a v7.3 file is read
// like a v5 one; a v7.3 file that is cut, or whose header is not followed by HDF5 data, is an
// error naming the file and the reason (it read as "0 variables" before). The files are written
// by matio itself (Mat_CreateVer(..., MAT_FT_MAT73)); without HDF5 support in matio the tests
// are skipped with a message. The hostile files (declared sizes beyond the stored bytes) are
// made with the HDF5 C API, at the end.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <matio.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <initializer_list>
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

// ---- hostile MAT v7.3 files (issue 13): declared sizes checked against the stored bytes -------
//
// The files are made with the HDF5 C API: a 512-byte user block holding the MATLAB header, then
// HDF5 data in which a dataset declares far more than its stored bytes can hold. Each must be
// refused, naming the file, the variable and the numbers, before matio allocates what it declares
// (gigabytes): quickly and without the memory.

namespace {

// A MAT v7.3 file written with the HDF5 C API (close() writes the MATLAB header).
class H5MatFile {
 public:
  explicit H5MatFile(std::string path) : path_(std::move(path)) {
    const hid_t fcpl = H5Pcreate(H5P_FILE_CREATE);
    H5Pset_userblock(fcpl, 512);
    file_ = H5Fcreate(path_.c_str(), H5F_ACC_TRUNC, fcpl, H5P_DEFAULT);
    H5Pclose(fcpl);
  }
  H5MatFile(const H5MatFile&) = delete;
  H5MatFile& operator=(const H5MatFile&) = delete;
  ~H5MatFile() { close(); }
  hid_t id() const { return file_; }
  bool ok() const { return file_ >= 0; }

  // A dataset of MATLAB size rows x cols (HDF5 lists {cols, rows}) with creation properties
  // `dcpl` (H5P_DEFAULT: contiguous), the attribute MATLAB_class = cls; the caller closes it.
  hid_t dataset(hid_t loc, const char* name, hsize_t rows, hsize_t cols, hid_t dcpl, hid_t type = H5T_IEEE_F64LE,
                const char* cls = "double") const {
    const hsize_t dims[2] = {cols, rows};
    const hid_t space = H5Screate_simple(2, dims, nullptr);
    const hid_t d = H5Dcreate2(loc, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    H5Sclose(space);
    const hid_t st = H5Tcopy(H5T_C_S1);
    H5Tset_size(st, std::strlen(cls));
    const hid_t scalar = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(d, "MATLAB_class", st, scalar, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, st, cls);
    H5Aclose(a);
    H5Sclose(scalar);
    H5Tclose(st);
    return d;
  }

  void close() {
    if (file_ < 0) return;
    H5Fclose(file_);
    file_ = -1;
    std::string header = "MATLAB 7.3 MAT-file, written by hysteron's tests with the HDF5 C API, HDF5 schema 1.00 .";
    header.resize(116, ' ');
    header += std::string(8, '\0');         // subsystem data offset
    header += std::string("\x00\x02IM", 4);  // version 0x0200 (little-endian), endian mark
    std::fstream f(path_, std::ios::in | std::ios::out | std::ios::binary);
    f.write(header.data(), static_cast<std::streamsize>(header.size()));
  }

 private:
  std::string path_;
  hid_t file_ = -1;
};

hid_t chunked(std::initializer_list<hsize_t> chunk_dims, bool deflate) {
  const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  const std::vector<hsize_t> c(chunk_dims);
  H5Pset_chunk(dcpl, static_cast<int>(c.size()), c.data());
  if (deflate) H5Pset_deflate(dcpl, 6);
  return dcpl;
}

long max_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// read_column's and read_table's error for a hostile file: both the same check; each must come
// in well under a second and without the declared gigabytes (the process' peak RSS grows < 64 MB).
std::string hostile_error(const std::string& path, const std::string& spec) {
  const long rss0 = max_rss_kb();
  const auto t0 = std::chrono::steady_clock::now();
  const std::string msg = read_error(path, spec);
  std::string table_msg;
  try {
    (void)io::read_table(path);
  } catch (const hysteron::Error& e) {
    table_msg = e.what();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(msg, table_msg);
  EXPECT_LT(seconds, 2.0) << path;
  EXPECT_LT(max_rss_kb() - rss0, 64 * 1024) << path;
  std::printf("[ hostile  ] %s: refused in %.1f ms\n", std::filesystem::path(path).filename().c_str(), seconds * 1e3);
  return msg;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

// 10^9 doubles declared (8 GB), no storage ever allocated: HDF5 would return fill values and
// matio would allocate 8 GB for them.
TEST(Mat73, UnwrittenHugeDatasetIsRefusedBeforeMatioAllocates) {
  TempDir dir;
  const std::string path = dir.file("unwritten.mat");
  {
    H5MatFile f(path);
    ASSERT_TRUE(f.ok());
    const double x[3] = {1, 2, 3};
    const hid_t small = f.dataset(f.id(), "x", 3, 1, H5P_DEFAULT);
    H5Dwrite(small, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, x);
    H5Dclose(small);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_LATE);
    H5Dclose(f.dataset(f.id(), "huge", 1000000000, 1, dcpl));
    H5Pclose(dcpl);
  }
  const auto size = std::filesystem::file_size(path);
  ASSERT_LT(size, 4096u);
  const std::string msg = hostile_error(path, "x");
  EXPECT_TRUE(has(msg, path + ": variable \"huge\": truncated or inconsistent: size 1000000000x1 (1000000000 elements "
                          "of 8 bytes, 8000000000 bytes) but 0 bytes stored (no data written: it would read as fill "
                          "values); the file has " + std::to_string(size) + " bytes")) << msg;
}

// A chunked dataset of 10^9 doubles with one chunk of 1000 written: the other 999,999 would read
// as fill values.
TEST(Mat73, ChunkedDatasetWithMissingChunksIsRefused) {
  TempDir dir;
  const std::string path = dir.file("chunks_missing.mat");
  {
    H5MatFile f(path);
    ASSERT_TRUE(f.ok());
    const hid_t dcpl = chunked({1, 1000}, false);
    const hid_t d = f.dataset(f.id(), "x", 1000000000, 1, dcpl);
    H5Pclose(dcpl);
    std::vector<double> first(1000, 0.5);
    const hsize_t start[2] = {0, 0}, count[2] = {1, 1000};
    const hid_t fspace = H5Dget_space(d);
    H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hid_t mspace = H5Screate_simple(2, count, nullptr);
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, mspace, fspace, H5P_DEFAULT, first.data()), 0);
    H5Sclose(mspace);
    H5Sclose(fspace);
    H5Dclose(d);
  }
  const std::string msg = hostile_error(path, "x");
  EXPECT_TRUE(has(msg, path + ": variable \"x\": truncated or inconsistent: size 1000000000x1 (1000000000 elements of "
                          "8 bytes, 8000000000 bytes) has 1 of its 1000000 chunks written (8000 bytes stored; the "
                          "missing chunks would read as fill values)")) << msg;
}

// Deflate chunks of 800 MB declared, each 16 bytes stored (written raw with H5Dwrite_chunk): no
// zlib stream inflates more than 1032 bytes per byte.
TEST(Mat73, DeflateDatasetDeclaringMoreThanZlibCanInflateIsRefused) {
  TempDir dir;
  const std::string path = dir.file("deflate_bomb.mat");
  {
    H5MatFile f(path);
    ASSERT_TRUE(f.ok());
    const hid_t dcpl = chunked({1, 100000000}, true);
    const hid_t d = f.dataset(f.id(), "x", 1000000000, 1, dcpl);
    H5Pclose(dcpl);
    const unsigned char junk[16] = {0x78, 0x9c, 0x63, 0x60, 0x18, 0x05, 0xa3, 0x60};
    for (hsize_t k = 0; k < 10; ++k) {
      const hsize_t offset[2] = {0, k * 100000000};
      ASSERT_GE(H5Dwrite_chunk(d, H5P_DEFAULT, 0, offset, sizeof junk, junk), 0);
    }
    H5Dclose(d);
  }
  const std::string msg = hostile_error(path, "x");
  EXPECT_TRUE(has(msg, path + ": variable \"x\": truncated or inconsistent: size 1000000000x1 (1000000000 elements of "
                          "8 bytes, 8000000000 bytes) from 160 bytes of compressed data, which inflate to at most "
                          "166144 (zlib's maximum ratio, 1032:1)")) << msg;
}

// A cell (object references) whose element, in "#refs#", is an unwritten 8 GB dataset: named
// after the cell; and dimensions whose product overflows 64 bits.
TEST(Mat73, CellElementsAndAbsurdDimensionsAreChecked) {
  TempDir dir;
  const std::string cell = dir.file("cell.mat");
  {
    H5MatFile f(cell);
    ASSERT_TRUE(f.ok());
    const hid_t refs = H5Gcreate2(f.id(), "#refs#", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_LATE);
    H5Dclose(f.dataset(refs, "a", 1000000000, 1, dcpl));
    H5Pclose(dcpl);
    H5Gclose(refs);
    hobj_ref_t ref[2];
    ASSERT_GE(H5Rcreate(&ref[0], f.id(), "/#refs#/a", H5R_OBJECT, -1), 0);
    ref[1] = ref[0];
    const hid_t c = f.dataset(f.id(), "c", 2, 1, H5P_DEFAULT, H5T_STD_REF_OBJ, "cell");
    ASSERT_GE(H5Dwrite(c, H5T_STD_REF_OBJ, H5S_ALL, H5S_ALL, H5P_DEFAULT, ref), 0);
    H5Dclose(c);
  }
  const std::string m1 = hostile_error(cell, "c");
  EXPECT_TRUE(has(m1, cell + ": variable \"c{1}\": truncated or inconsistent: size 1000000000x1")) << m1;
  EXPECT_TRUE(has(m1, "but 0 bytes stored")) << m1;

  const std::string absurd = dir.file("absurd.mat");
  {
    H5MatFile f(absurd);
    ASSERT_TRUE(f.ok());
    const hsize_t big = hsize_t{1} << 40;
    const hsize_t dims[3] = {big, big, big}, chunk[3] = {1, 1, 1};
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 3, chunk);
    const hid_t space = H5Screate_simple(3, dims, nullptr);
    const hid_t d = H5Dcreate2(f.id(), "x", H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    H5Sclose(space);
    H5Pclose(dcpl);
    if (d < 0) GTEST_SKIP() << "HDF5 refuses to create a dataset of 2^120 elements";
    H5Dclose(d);
  }
  const std::string m2 = hostile_error(absurd, "x");
  EXPECT_TRUE(has(m2, absurd + ": variable \"x\": truncated or inconsistent: size 1099511627776x1099511627776x"
                              "1099511627776 (more than 2^62 elements of 8 bytes, more than 2^62 bytes) has 0 of its "
                              "more than 2^62 chunks written")) << m2;
}

// A cell of 2000 references to one deflated dataset of 10^6 zeros (8 MB declared, a few KB
// stored; valid on its own): matio would read 16 GB for it.
TEST(Mat73, CellReferencingOneDatasetManyTimesIsRefused) {
  TempDir dir;
  const std::string path = dir.file("shared.mat");
  {
    H5MatFile f(path);
    ASSERT_TRUE(f.ok());
    const hid_t refs = H5Gcreate2(f.id(), "#refs#", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t dcpl = chunked({1, 100000}, true);
    const hid_t z = f.dataset(refs, "z", 1000000, 1, dcpl);
    H5Pclose(dcpl);
    const std::vector<double> zeros(1000000, 0.0);
    ASSERT_GE(H5Dwrite(z, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros.data()), 0);
    H5Dclose(z);
    H5Gclose(refs);
    std::vector<hobj_ref_t> ref(2000);
    ASSERT_GE(H5Rcreate(&ref[0], f.id(), "/#refs#/z", H5R_OBJECT, -1), 0);
    std::fill(ref.begin(), ref.end(), ref[0]);
    const hid_t c = f.dataset(f.id(), "c", 2000, 1, H5P_DEFAULT, H5T_STD_REF_OBJ, "cell");
    ASSERT_GE(H5Dwrite(c, H5T_STD_REF_OBJ, H5S_ALL, H5S_ALL, H5P_DEFAULT, ref.data()), 0);
    H5Dclose(c);
  }
  const std::string msg = hostile_error(path, "c");
  EXPECT_TRUE(has(msg, path + ": inconsistent: its variables declare 16000016000 bytes of data (cell elements counted "
                          "once per reference), more than its")) << msg;
}

// Valid v7.3 files still read: a few MB, compressed and not, one of zeros compressed near zlib's
// maximum ratio, and one with a cell, a struct, a char array and an empty matrix beside the
// vectors (their HDF5 objects, the cell's references included, are visited by the check).
TEST(Mat73, ValidFilesCompressedOrNotOfAFewMBStillRead) {
  TempDir dir;
  const auto x = signal(400000);
  const std::vector<double> zeros(1000000, 0.0);
  for (const bool compress : {false, true}) {
    const std::string path = dir.file(compress ? "big_z.mat" : "big.mat");
    mat_t* m = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT73);
    if (!m) GTEST_SKIP() << "this matio cannot write MAT v7.3 (built without HDF5)";
    std::size_t d1[2] = {x.size(), 1}, dz[2] = {zeros.size(), 1}, d0[2] = {0, 0}, dc[2] = {1, 5}, dcell[2] = {2, 1};
    const std::size_t one[2] = {1, 1};
    const auto compression = compress ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE;
    auto write = [&](matvar_t* v) {
      ASSERT_NE(v, nullptr);
      EXPECT_EQ(Mat_VarWrite(m, v, compression), 0);
      Mat_VarFree(v);
    };
    write(Mat_VarCreate("input", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d1, const_cast<double*>(x.data()), MAT_F_DONT_COPY_DATA));
    write(Mat_VarCreate("zeros", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dz, const_cast<double*>(zeros.data()),
                        MAT_F_DONT_COPY_DATA));
    write(Mat_VarCreate("empty", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, d0, nullptr, 0));
    char text[] = "hello";
    write(Mat_VarCreate("label", MAT_C_CHAR, MAT_T_UINT8, 2, dc, text, 0));
    double a = 1.5, b[3] = {1, 2, 3};
    std::size_t db[2] = {3, 1};
    matvar_t* cell = Mat_VarCreate("c", MAT_C_CELL, MAT_T_CELL, 2, dcell, nullptr, 0);
    Mat_VarSetCell(cell, 0, Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, const_cast<std::size_t*>(one), &a, 0));
    Mat_VarSetCell(cell, 1, Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, db, b, 0));
    write(cell);
    const char* fields[1] = {"gain"};
    matvar_t* s = Mat_VarCreateStruct("s", 2, const_cast<std::size_t*>(one), fields, 1);
    Mat_VarSetStructFieldByName(s, "gain", 0,
                                Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, const_cast<std::size_t*>(one), &a, 0));
    write(s);
    ASSERT_EQ(Mat_Close(m), 0);
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(io::read_column(path, "input"), x) << path;
    EXPECT_EQ(io::read_column(path, "zeros"), zeros) << path;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[ valid    ] %s (%ju bytes): two variables read in %.1f ms\n", compress ? "big_z.mat" : "big.mat",
                static_cast<std::uintmax_t>(std::filesystem::file_size(path)), seconds * 1e3);
    EXPECT_EQ(read_error(path, "c"), path + ": variable \"c\": is not numeric (class cell); expected a real numeric "
                                            "vector or 2-D matrix (double, single or an integer class)");
  }
}

// The hostile file kept for the fuzzer (fuzz/regressions/mat/, 991 bytes, HDF5's latest format):
// a dataset of 10^9 doubles with no storage.
TEST(Mat73, FuzzRegressionUnwrittenDatasetIsRefused) {
  const std::string path =
      std::string(HYSTERON_SOURCE_DIR) + "/fuzz/regressions/mat/v73-unwritten-dataset-of-1e9-doubles.mat";
  ASSERT_LT(std::filesystem::file_size(path), 4096u);
  const std::string msg = hostile_error(path, "x");
  EXPECT_TRUE(has(msg, path + ": variable \"x\": truncated or inconsistent: size 1000000000x1 (1000000000 elements of "
                          "8 bytes, 8000000000 bytes) but 0 bytes stored (no data written: it would read as fill "
                          "values); the file has 991 bytes")) << msg;
}
