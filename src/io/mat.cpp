// MATLAB .mat files (the .mat side of table.hpp): the structure checks made before matio reads
// (check_mat_file: v4, v5, compressed v5, v7.3), reading variables and columns through matio,
// and writing MAT v5 files. The text/CSV side and the Table type are in table.cpp.
#include "mat.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <matio.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

#include "hysteron/error.hpp"

namespace hysteron::io::detail {

namespace {

namespace fs = std::filesystem;

// ---- .mat --------------------------------------------------------------------

struct MatCloser {
  void operator()(mat_t* m) const {
    if (m) Mat_Close(m);
  }
};
struct VarFreer {
  void operator()(matvar_t* v) const {
    if (v) Mat_VarFree(v);
  }
};
using MatPtr = std::unique_ptr<mat_t, MatCloser>;
using VarPtr = std::unique_ptr<matvar_t, VarFreer>;

void quiet_matio_log(int, char*) {}

void init_matio_log() {
  static const bool once = [] {
    Mat_LogInitFunc("hysteron", &quiet_matio_log);
    return true;
  }();
  (void)once;
}

MatPtr open_mat(const std::string& path) {
  init_matio_log();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(fmt::format("{}: no such file", path));
  if (fs::is_directory(path, ec)) throw Error(fmt::format("{}: is a directory, not a .mat file", path));
  MatPtr m(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!m) throw Error(fmt::format("{}: cannot open as a MATLAB .mat file (not a MAT v4/v5/v7.3 file?)", path));
  return m;
}

// ---- .mat structure check (before matio allocates anything) -------------------------
//
// matio trusts the sizes in a file: a truncated file is read with garbage or zeros at the end,
// and a small file that declares a huge array makes it allocate that much. check_mat_file walks
// the file's structure first, with bounds from the file size: every variable must lie inside the
// file, its declared element count must match its data, and a compressed variable must inflate
// to exactly the size it declares (read in bounded chunks; the declared count is capped by what
// its compressed bytes could hold). A v7.3 (HDF5) file's datasets are checked through HDF5
// (check_mat73): declared sizes against the bytes stored for them.

struct Bytes {
  const unsigned char* p;
  std::size_t n;      // extent: sizes are checked against it
  std::size_t avail;  // bytes readable at p (less than n for the head of a compressed variable)
};

// a * b, saturated at 2^62 (sizes beyond it cannot be in a file)
std::uint64_t mul_sat(std::uint64_t a, std::uint64_t b) {
  std::uint64_t r = 0;
  constexpr std::uint64_t cap = std::uint64_t{1} << 62;
  return __builtin_mul_overflow(a, b, &r) || r > cap ? cap : r;
}

std::uint32_t get32(const unsigned char* p, bool swap) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return swap ? __builtin_bswap32(v) : v;
}

std::size_t mat5_type_size(std::uint32_t t) {
  switch (t) {
    case 1: case 2: return 1;    // miINT8, miUINT8
    case 3: case 4: return 2;    // miINT16, miUINT16
    case 5: case 6: case 7: return 4;  // miINT32, miUINT32, miSINGLE
    case 9: case 12: case 13: return 8;  // miDOUBLE, miINT64, miUINT64
    case 16: case 17: return 1;  // miUTF8, miUTF16 (byte counts only)
    default: return 0;
  }
}

// The size of a numeric type (miINT8 .. miUINT64); 0 for the character types miUTF8 and
// miUTF16 and for unknown ones.
std::size_t mat5_numeric_size(std::uint32_t t) { return t < 16 ? mat5_type_size(t) : 0; }

// A sub-element tag at s[pos]: type and byte count, small-data format included; returns the
// offset of the data and advances pos past the (padded) element. Throws `bad` on overrun.
struct SubElement {
  std::uint32_t type;
  std::size_t bytes, data;
};

SubElement next_sub(Bytes s, std::size_t& pos, bool swap, const std::string& where, std::string_view what) {
  if (pos + 8 > s.n)
    throw Error(fmt::format("{}: truncated or inconsistent: the {} ends after the variable ({} of {} bytes)", where,
                            what, s.n, pos + 8));
  if (pos + 8 > s.avail)
    throw Error(fmt::format("{}: unsupported: the {} starts after byte {} of a compressed variable", where, what,
                            s.avail));
  const std::uint32_t w0 = get32(s.p + pos, swap);
  SubElement e{};
  if ((w0 >> 16) != 0) {  // small data element: bytes in the upper half, data in the next 4 bytes
    e.type = w0 & 0xffff;
    e.bytes = w0 >> 16;
    e.data = pos + 4;
    if (e.bytes > 4)
      throw Error(fmt::format("{}: inconsistent: a small {} of {} bytes (at most 4)", where, what, e.bytes));
    pos += 8;
    return e;
  }
  e.type = w0;
  e.bytes = get32(s.p + pos + 4, swap);
  e.data = pos + 8;
  if (e.bytes > s.n - e.data)
    throw Error(fmt::format("{}: truncated or inconsistent: its {} declares {} bytes, the variable has {} left", where,
                            what, e.bytes, s.n - e.data));
  pos = e.data + ((e.bytes + 7) / 8) * 8;
  return e;
}

// The inside of a miMATRIX element (s = its data, without the 8-byte tag), every class matio
// reads: whatever matio would allocate from the sizes in it must be backed by bytes of the file
// (numeric and char data exactly numel x the stored size; a cell's or a struct's elements each a
// nested miMATRIX, checked the same way, at most 16 levels deep; a sparse matrix's nzmax and
// columns bounded by its bytes). Names are reported in messages.
void check_mat5_matrix(Bytes s, bool swap, const std::string& path, std::size_t index, std::string* name_out,
                       int depth = 0) {
  std::string where = fmt::format("{}: variable #{}", path, index + 1);
  if (depth > 16) throw Error(fmt::format("{}: unsupported: cells or structs nested more than 16 levels deep", where));
  std::size_t pos = 0;
  const SubElement flags = next_sub(s, pos, swap, where, "array flags");
  if (flags.bytes < 8 || flags.data + 8 > s.avail) throw Error(fmt::format("{}: inconsistent: array flags of {} bytes", where, flags.bytes));
  const std::uint32_t f = get32(s.p + flags.data, swap);
  const std::uint32_t nzmax = get32(s.p + flags.data + 4, swap);
  const unsigned cls = f & 0xff;
  const bool complex = (f & 0x800) != 0;
  const SubElement dims = next_sub(s, pos, swap, where, "dimensions");
  if (dims.data + dims.bytes > s.avail) throw Error(fmt::format("{}: unsupported: too many dimensions", where));
  if (dims.type != 5 || dims.bytes % 4 != 0 || dims.bytes < 8 || dims.bytes > 4 * 32)
    throw Error(fmt::format("{}: inconsistent: bad dimensions element (type {}, {} bytes)", where, dims.type,
                            dims.bytes));
  const SubElement nm = next_sub(s, pos, swap, where, "name");
  if (nm.data + nm.bytes > s.avail) throw Error(fmt::format("{}: unsupported: a name of {} bytes", where, nm.bytes));
  std::string name(reinterpret_cast<const char*>(s.p + nm.data), nm.bytes);
  name = name.substr(0, name.find('\0'));
  if (!name.empty()) where = fmt::format("{}: variable \"{}\"", path, shown(name));
  if (name_out) *name_out = name;
  // numel with overflow check; every dimension must be non-negative
  std::uint64_t numel = 1;
  std::string dims_txt;
  std::uint32_t ncols = 0;
  for (std::size_t k = 0; k < dims.bytes / 4; ++k) {
    const std::uint32_t d = get32(s.p + dims.data + 4 * k, swap);
    if (d > 0x7fffffffu) throw Error(fmt::format("{}: inconsistent: negative dimension", where));
    if (k == 1) ncols = d;
    numel = mul_sat(numel, d);
    dims_txt += fmt::format("{}{}", k ? "x" : "", d);
  }
  auto data_part = [&](std::string_view what, bool numeric) {
    const SubElement data = next_sub(s, pos, swap, where, what);
    const std::size_t sz = numeric ? mat5_numeric_size(data.type) : mat5_type_size(data.type);
    if (sz == 0)
      throw Error(fmt::format("{}: inconsistent: data of unknown type {}", where, data.type));
    if (data.bytes != mul_sat(numel, sz))
      throw Error(fmt::format("{}: truncated or inconsistent: size {} ({} elements) needs {} bytes of data, the file "
                              "has {}",
                              where, dims_txt, numel, mul_sat(numel, sz), data.bytes));
  };
  // `count` nested miMATRIX elements (cells, struct fields), each inside this one
  auto nested = [&](std::uint64_t count) {
    if (count > (s.n - std::min(pos, s.n)) / 8)
      throw Error(fmt::format("{}: truncated or inconsistent: size {} needs {} elements, the variable has room for {}",
                              where, dims_txt, count, (s.n - std::min(pos, s.n)) / 8));
    for (std::uint64_t k = 0; k < count; ++k) {
      const SubElement e = next_sub(s, pos, swap, where, "element of a cell or struct");
      if (e.type != 14)
        throw Error(fmt::format("{}: inconsistent: an element of a cell or struct of type {} (not a matrix)", where,
                                e.type));
      if (e.data + e.bytes > s.avail)
        throw Error(fmt::format("{}: unsupported: an element of a cell or struct past byte {} of a compressed variable",
                                where, s.avail));
      if (e.bytes > 0) check_mat5_matrix(Bytes{s.p + e.data, e.bytes, e.bytes}, swap, path, index, nullptr, depth + 1);
    }
  };
  switch (cls) {
    case 6: case 7: case 8: case 9: case 10: case 11: case 12: case 13: case 14: case 15:  // numeric
      data_part("data", true);
      if (complex) data_part("imaginary part", true);
      return;
    case 4:  // char
      data_part("data", false);
      return;
    case 1:  // cell
      nested(numel);
      return;
    case 2: case 3: {  // struct, object (an object starts with its class name)
      if (cls == 3) (void)next_sub(s, pos, swap, where, "class name");
      const SubElement len = next_sub(s, pos, swap, where, "field name length");
      if (len.type != 5 || len.bytes != 4 || len.data + 4 > s.avail)
        throw Error(fmt::format("{}: inconsistent: bad field name length element", where));
      const std::uint32_t L = get32(s.p + len.data, swap);
      const SubElement names = next_sub(s, pos, swap, where, "field names");
      if (L == 0 || L > 4096 || names.bytes % L != 0)
        throw Error(fmt::format("{}: inconsistent: field names of {} bytes in slots of {}", where, names.bytes, L));
      nested(mul_sat(numel, names.bytes / L));
      return;
    }
    case 5: {  // sparse: row indices, column starts, values (and imaginary values)
      const std::uint64_t room = s.n / 4;
      if (nzmax > room || std::uint64_t{ncols} + 1 > room)
        throw Error(fmt::format("{}: truncated or inconsistent: a sparse matrix of size {} with nzmax {} in {} bytes",
                                where, dims_txt, nzmax, s.n));
      const SubElement ir = next_sub(s, pos, swap, where, "row indices");
      const SubElement jc = next_sub(s, pos, swap, where, "column starts");
      const std::size_t irs = mat5_numeric_size(ir.type), jcs = mat5_numeric_size(jc.type);
      if (irs == 0 || jcs == 0 || ir.bytes / irs > nzmax || jc.bytes / jcs != std::uint64_t{ncols} + 1)
        throw Error(fmt::format("{}: inconsistent: sparse index arrays of {} and {} bytes for size {}, nzmax {}", where,
                                ir.bytes, jc.bytes, dims_txt, nzmax));
      // the values (and imaginary values): matio allocates what their tags declare, so each must
      // lie inside the variable (next_sub) and hold at most nzmax numbers
      const int parts = complex ? 2 : 1;
      for (int k = 0; k < parts && pos < s.n; ++k) {
        const char* what = k == 0 ? "sparse values" : "sparse imaginary values";
        const SubElement v = next_sub(s, pos, swap, where, what);
        const std::size_t sz = mat5_numeric_size(v.type);
        if (sz == 0 || v.bytes / sz > nzmax)
          throw Error(fmt::format("{}: inconsistent: {} of type {} and {} bytes for nzmax {}", where, what, v.type,
                                  v.bytes, nzmax));
      }
      return;
    }
    default:  // function handles, opaque objects (tables, strings), unknown classes: matio does not
              // read their data, but sizes some of them by their dimensions (8+ bytes per element)
      if (numel > s.n / 8)
        throw Error(fmt::format("{}: truncated or inconsistent: a variable of class {} and size {} in {} bytes", where,
                                cls, dims_txt, s.n));
      return;
  }
}

// Inflates a miCOMPRESSED element (at most 1032 bytes out per byte in, zlib's maximum ratio) and
// checks its inside as an uncompressed variable. The whole variable is inflated (matio needs as
// much to read it); a declared size that does not match what inflates is an error.
void check_mat5_compressed(Bytes z, bool swap, const std::string& path, std::size_t index) {
  const std::string where = fmt::format("{}: variable #{}", path, index + 1);
  const std::size_t limit = z.n * 1032 + 1024;
  z_stream zs{};
  if (inflateInit(&zs) != Z_OK) throw Error(fmt::format("{}: cannot initialise zlib", where));
  struct End {
    z_stream* s;
    ~End() { inflateEnd(s); }
  } end{&zs};
  zs.next_in = const_cast<Bytef*>(z.p);
  zs.avail_in = static_cast<uInt>(std::min<std::size_t>(z.n, std::numeric_limits<uInt>::max()));
  std::vector<unsigned char> out(std::min<std::size_t>(limit, 1 << 16));
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    if (zs.total_out == out.size()) {
      if (out.size() >= limit) throw Error(fmt::format("{}: corrupt compressed data (expands without bound)", where));
      out.resize(std::min(limit, out.size() * 2));
    }
    zs.next_out = out.data() + zs.total_out;
    zs.avail_out = static_cast<uInt>(out.size() - zs.total_out);
    rc = inflate(&zs, Z_NO_FLUSH);
    if (rc == Z_STREAM_END) break;
    if (rc == Z_BUF_ERROR && zs.avail_out == 0) continue;  // output full: grow
    if (rc != Z_OK || (zs.avail_in == 0 && zs.avail_out != 0))
      throw Error(fmt::format("{}: truncated or corrupt compressed data ({})", where,
                              zs.msg ? zs.msg : "the compressed stream ends early"));
  }
  const std::size_t total = zs.total_out;
  if (total < 8) throw Error(fmt::format("{}: corrupt compressed variable (no matrix inside)", where));
  const std::uint32_t type = get32(out.data(), swap);
  const std::size_t bytes = get32(out.data() + 4, swap);
  if (type != 14) throw Error(fmt::format("{}: corrupt compressed variable (type {} inside, not a matrix)", where, type));
  if (8 + bytes != total)
    throw Error(fmt::format("{}: truncated or inconsistent: declares {} bytes, its compressed data holds {}", where,
                            bytes, total - 8));
  check_mat5_matrix(Bytes{out.data() + 8, bytes, bytes}, swap, path, index, nullptr);
}

void check_mat4(Bytes f, const std::string& path) {
  std::size_t pos = 0;
  for (std::size_t index = 0; pos < f.n; ++index) {
    const std::string where = fmt::format("{}: variable #{}", path, index + 1);
    if (f.n - pos < 20)
      throw Error(fmt::format("{}: truncated: {} bytes left where a MAT v4 header needs 20", where, f.n - pos));
    // as matio reads it (mat4.c): the type word is taken byte-swapped if it is not in 0..4052
    // as stored, and its digit M (0 little-, 1 big-endian) alone decides whether the other
    // fields are swapped (a swapped type word with M = 0 leaves them as stored)
    std::uint32_t h[5];
    std::memcpy(h, f.p + pos, 20);
    if (h[0] > 4052) h[0] = __builtin_bswap32(h[0]);
    const std::uint32_t type = h[0];
    const bool swap = type <= 4052 && (type / 1000 == 1) == (std::endian::native == std::endian::little);
    if (swap)
      for (int i = 1; i < 5; ++i) h[i] = __builtin_bswap32(h[i]);
    const std::uint32_t rows = h[1], cols = h[2], imag = h[3], namelen = h[4];
    const unsigned M = type / 1000, O = (type / 100) % 10, P = (type / 10) % 10, T = type % 10;
    static constexpr std::size_t kSize[6] = {8, 4, 4, 2, 2, 1};
    if (type > 4052 || M > 1 || O != 0 || P > 5 || T > 2 || imag > 1 || rows > 0x7fffffffu ||
        cols > 0x7fffffffu || namelen == 0 || namelen > 4096)
      throw Error(fmt::format("{}: inconsistent MAT v4 header (type {}, {}x{}, name length {})", where, type, rows,
                              cols, namelen));
    if (namelen > f.n - pos - 20)
      throw Error(fmt::format("{}: truncated: the name ({} bytes) ends after the file", where, namelen));
    std::string name(reinterpret_cast<const char*>(f.p + pos + 20), namelen);
    name = name.substr(0, name.find('\0'));
    const std::string w = fmt::format("{}: variable \"{}\"", path, shown(name));
    // a sparse matrix is stored as an N x 3 (real) or N x 4 (complex) array: matio sizes it by N
    if (T == 2 && (rows == 0 || (cols != 3 && cols != 4)))
      throw Error(fmt::format("{}: inconsistent: a sparse MAT v4 matrix stored as {}x{} (expected N x 3 or N x 4)", w,
                              rows, cols));
    const std::uint64_t need = mul_sat(mul_sat(rows, cols), kSize[P] * (imag ? 2u : 1u));
    const std::size_t left = f.n - pos - 20 - namelen;
    if (need > left)
      throw Error(fmt::format("{}: truncated or inconsistent: size {}x{} needs {} bytes of data, the file has {}", w,
                              rows, cols, need, left));
    pos += 20 + namelen + static_cast<std::size_t>(need);
  }
}

// ---- MAT v7.3 variables (HDF5), before matio reads any of them --------------------------
//
// Every object of the HDF5 data is visited through the HDF5 C API (group links from the root,
// and the object references of cells), and every dataset's declared size (elements x element
// size) must be backed by the bytes stored for it:
//  - its stored bytes (H5Dget_storage_size) lie within the file, and the data of all datasets
//    together is no more than the file;
//  - without a compression filter, the stored bytes cover the declared size (a dataset never
//    written, which HDF5 reads as fill values, is refused); with deflate, the declared size is
//    at most 1032 x the stored bytes (zlib's maximum ratio) + 1024;
//  - a chunked dataset has every chunk written (a missing chunk reads as fill values);
//  - contiguous data lies inside the file;
//  - filters other than deflate, shuffle and fletcher32, data in external files, external links
//    and virtual datasets are refused;
//  - what matio would read for all variables (cells' elements counted once per reference) is
//    at most 1032 x the file size.
// HDF5 errors are not printed while checking (its automatic error stack printing is off).

// An HDF5 identifier, closed by its function on destruction.
class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  ~H5Handle() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const noexcept { return id_; }
  explicit operator bool() const noexcept { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// HDF5 prints its error stack on stderr on every failed call unless told not to.
class H5Quiet {
 public:
  H5Quiet() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  H5Quiet(const H5Quiet&) = delete;
  H5Quiet& operator=(const H5Quiet&) = delete;
  ~H5Quiet() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

std::uint64_t add_sat(std::uint64_t a, std::uint64_t b) {
  constexpr std::uint64_t cap = std::uint64_t{1} << 62;
  return a >= cap || b >= cap - a ? cap : a + b;
}

// A byte or element count for messages (mul_sat saturates at 2^62).
std::string count_text(std::uint64_t v) {
  return v >= (std::uint64_t{1} << 62) ? std::string("more than 2^62") : fmt::format("{}", v);
}

constexpr std::uint64_t kZlibMaxRatio = 1032;

class Mat73Check {
 public:
  Mat73Check(const std::string& path, std::uint64_t file_size) : path_(path), n_(file_size) {}

  void run() {
    H5Handle file(H5Fopen(path_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!file)
      throw Error(fmt::format("{}: MAT v7.3 file whose HDF5 data cannot be opened (damaged HDF5 structure)", path_));
    H5Handle root(H5Gopen2(file.get(), "/", H5P_DEFAULT), H5Gclose);
    if (!root) throw Error(fmt::format("{}: MAT v7.3 file whose HDF5 root group cannot be read (damaged)", path_));
    // the variables are the root's links; "#refs#" (the elements of cells) and other names
    // starting with '#' are not variables: checked too, after them, and not added again
    std::uint64_t total = 0;
    const auto links = list_links(root.get(), "");
    for (const bool hidden : {false, true})
      for (const auto& l : links)
        if ((!l.name.empty() && l.name[0] == '#') == hidden) {
          const std::uint64_t c = link_cost(root.get(), l, l.name, 0);
          if (!hidden) total = add_sat(total, c);
        }
    const std::uint64_t limit = add_sat(mul_sat(n_, kZlibMaxRatio), 1024);
    if (total > limit)
      throw Error(fmt::format("{}: inconsistent: its variables declare {} bytes of data (cell elements counted once per "
                              "reference), more than its {} bytes can hold ({} at zlib's maximum ratio, 1032:1)",
                              path_, count_text(total), n_, count_text(limit)));
  }

 private:
  struct Link {
    std::string name;
    H5L_type_t type;
  };

  std::string where(const std::string& var) const { return fmt::format("{}: variable \"{}\"", path_, shown(var)); }

  std::vector<Link> list_links(hid_t g, const std::string& var) const {
    std::vector<Link> links;
    auto on_link = [](hid_t, const char* name, const H5L_info_t* info, void* op) -> herr_t {
      try {
        static_cast<std::vector<Link>*>(op)->push_back(Link{name, info->type});
        return 0;
      } catch (...) {
        return -1;
      }
    };
    if (H5Literate(g, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr, on_link, &links) < 0)
      throw Error(fmt::format("{}: damaged: the links of HDF5 group \"{}\" cannot be listed", path_,
                              var.empty() ? std::string("/") : shown(var)));
    return links;
  }

  // What matio may allocate reading the object a link of group g names.
  std::uint64_t link_cost(hid_t g, const Link& l, const std::string& var, int depth) {
    if (l.type == H5L_TYPE_EXTERNAL)
      throw Error(fmt::format("{}: unsupported: an HDF5 external link (to another file)", where(var)));
    if (l.type != H5L_TYPE_HARD && l.type != H5L_TYPE_SOFT)
      throw Error(fmt::format("{}: unsupported: an HDF5 link of user-defined type {}", where(var),
                              static_cast<int>(l.type)));
    H5Handle obj(H5Oopen(g, l.name.c_str(), H5P_DEFAULT), H5Oclose);
    if (!obj) {
      if (l.type == H5L_TYPE_SOFT) return 0;  // a dangling soft link: nothing to read
      throw Error(fmt::format("{}: damaged: its HDF5 object cannot be opened", where(var)));
    }
    return object_cost(obj.get(), var, depth);
  }

  std::uint64_t object_cost(hid_t obj, const std::string& var, int depth) {
    H5O_info_t info{};
    if (H5Oget_info2(obj, &info, H5O_INFO_BASIC) < 0)
      throw Error(fmt::format("{}: damaged: its HDF5 object header cannot be read", where(var)));
    if (info.type != H5O_TYPE_GROUP && info.type != H5O_TYPE_DATASET) return 0;  // a named datatype: no data
    if (const auto it = cost_.find(info.addr); it != cost_.end()) return it->second;
    if (depth > 16)
      throw Error(fmt::format("{}: unsupported: groups or cells nested more than 16 levels deep", where(var)));
    if (!open_.insert(info.addr).second)
      throw Error(fmt::format("{}: inconsistent: contains or references itself (a cycle in the HDF5 data)",
                              where(var)));
    std::uint64_t c = 0;
    if (info.type == H5O_TYPE_GROUP) {
      for (const auto& l : list_links(obj, var)) c = add_sat(c, link_cost(obj, l, var + "/" + l.name, depth + 1));
    } else {
      c = dataset_cost(obj, var, depth);
    }
    open_.erase(info.addr);
    cost_.emplace(info.addr, c);
    return c;
  }

  std::uint64_t dataset_cost(hid_t d, const std::string& var, int depth) {
    const std::string w = where(var);
    H5Handle space(H5Dget_space(d), H5Sclose), type(H5Dget_type(d), H5Tclose), dcpl(H5Dget_create_plist(d), H5Pclose);
    if (!space || !type || !dcpl)
      throw Error(fmt::format("{}: damaged: its HDF5 dataspace, datatype or creation properties cannot be read", w));
    // the size, shown in MATLAB's order (HDF5 lists the dimensions the other way round)
    std::uint64_t numel = 0;
    std::string dims_txt;
    std::vector<hsize_t> dims;
    switch (H5Sget_simple_extent_type(space.get())) {
      case H5S_NULL: dims_txt = "0 (null dataspace)"; break;
      case H5S_SCALAR: numel = 1; dims_txt = "1x1 (scalar)"; break;
      case H5S_SIMPLE: {
        const int rank = H5Sget_simple_extent_ndims(space.get());
        if (rank < 0 || rank > H5S_MAX_RANK) throw Error(fmt::format("{}: damaged: HDF5 dataspace of rank {}", w, rank));
        dims.resize(static_cast<std::size_t>(rank));
        if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
          throw Error(fmt::format("{}: damaged: its HDF5 dimensions cannot be read", w));
        numel = 1;
        for (std::size_t k = dims.size(); k-- > 0;) {
          numel = mul_sat(numel, dims[k]);
          dims_txt += fmt::format("{}{}", k + 1 < dims.size() ? "x" : "", dims[k]);
        }
        if (dims.empty()) dims_txt = "1x1";
        break;
      }
      default: throw Error(fmt::format("{}: damaged: unknown HDF5 dataspace type", w));
    }
    const std::size_t esize = H5Tget_size(type.get());
    if (esize == 0) throw Error(fmt::format("{}: damaged: its HDF5 datatype has no size", w));
    const std::uint64_t declared = mul_sat(numel, esize);
    const std::string size_txt = fmt::format("size {} ({} elements of {} bytes, {} bytes)", dims_txt,
                                             count_text(numel), esize, count_text(declared));
    if (H5Pget_external_count(dcpl.get()) > 0)
      throw Error(fmt::format("{}: unsupported: its data is stored in an external file", w));
    bool deflate = false;
    const int nfilters = H5Pget_nfilters(dcpl.get());
    for (int i = 0; i < nfilters; ++i) {
      unsigned flags = 0, config = 0, cd[8] = {};
      std::size_t ncd = 8;
      char fname[64] = {};
      const H5Z_filter_t id =
          H5Pget_filter2(dcpl.get(), static_cast<unsigned>(i), &flags, &ncd, cd, sizeof fname, fname, &config);
      if (id == H5Z_FILTER_DEFLATE) deflate = true;
      else if (id != H5Z_FILTER_SHUFFLE && id != H5Z_FILTER_FLETCHER32)
        throw Error(fmt::format("{}: unsupported: HDF5 filter {} (deflate, shuffle and fletcher32 are read)", w, id));
    }
    const std::uint64_t stored = H5Dget_storage_size(d);
    if (stored > n_)
      throw Error(fmt::format("{}: truncated or inconsistent: {} declares {} bytes of stored data, the file has {}",
                              w, size_txt, stored, n_));
    stored_total_ = add_sat(stored_total_, stored);
    if (stored_total_ > n_)
      throw Error(fmt::format("{}: inconsistent: the data stored for the datasets so far adds up to {} bytes, more "
                              "than the file's {} (shared or overlapping data)",
                              w, stored_total_, n_));
    switch (H5Pget_layout(dcpl.get())) {
      case H5D_COMPACT: break;  // inside its object header, of the size stored there
      case H5D_CONTIGUOUS:
        if (stored > 0) {
          // H5Dget_offset counts from the start of the HDF5 data; here it starts at byte 512
          // (after the MATLAB header) or later, so this bound is never tighter than the truth
          const haddr_t at = H5Dget_offset(d);
          if (at == HADDR_UNDEF || at > n_ || stored > n_ - at)
            throw Error(fmt::format("{}: truncated or inconsistent: {} is stored at byte {} for {} bytes, after the "
                                    "end of the file ({} bytes)",
                                    w, size_txt, at == HADDR_UNDEF ? std::string("(undefined)") : fmt::format("{}", at),
                                    stored, n_));
        }
        break;
      case H5D_CHUNKED: {
        std::vector<hsize_t> chunk(dims.size());
        if (dims.empty() || H5Pget_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()) !=
                                static_cast<int>(chunk.size()))
          throw Error(fmt::format("{}: damaged: chunked HDF5 data whose chunk dimensions cannot be read", w));
        std::uint64_t expected = numel == 0 ? 0 : 1;
        for (std::size_t k = 0; k < dims.size() && expected > 0; ++k) {
          if (chunk[k] == 0) throw Error(fmt::format("{}: damaged: a chunk dimension of 0", w));
          expected = mul_sat(expected, dims[k] / chunk[k] + (dims[k] % chunk[k] != 0 ? 1 : 0));
        }
        hsize_t written = 0;  // H5S_ALL is not handled by HDF5 1.10 here: the dataset's dataspace
        if (H5Dget_num_chunks(d, space.get(), &written) < 0)
          throw Error(fmt::format("{}: damaged: its HDF5 chunk index cannot be read", w));
        if (written < expected)
          throw Error(fmt::format("{}: truncated or inconsistent: {} has {} of its {} chunks written ({} bytes stored; "
                                  "the missing chunks would read as fill values); the file has {} bytes",
                                  w, size_txt, written, count_text(expected), stored, n_));
        break;
      }
      default: throw Error(fmt::format("{}: unsupported: an HDF5 virtual dataset (data in other datasets)", w));
    }
    if (deflate) {
      const std::uint64_t limit = add_sat(mul_sat(stored, kZlibMaxRatio), 1024);
      if (declared > limit)
        throw Error(fmt::format("{}: truncated or inconsistent: {} from {} bytes of compressed data, which inflate to at "
                                "most {} (zlib's maximum ratio, 1032:1); the file has {} bytes",
                                w, size_txt, stored, count_text(limit), n_));
    } else if (stored < declared) {
      throw Error(fmt::format("{}: truncated or inconsistent: {} but {} bytes stored{}; the file has {} bytes", w,
                              size_txt, stored, stored == 0 ? " (no data written: it would read as fill values)" : "",
                              n_));
    }
    std::uint64_t cost = declared;
    // a cell: object references to its elements (in "#refs#"), which matio reads as well
    if (numel > 0 && H5Tget_class(type.get()) == H5T_REFERENCE && H5Tequal(type.get(), H5T_STD_REF_OBJ) > 0) {
      std::vector<hobj_ref_t> refs(static_cast<std::size_t>(numel));
      if (H5Dread(d, H5T_STD_REF_OBJ, H5S_ALL, H5S_ALL, H5P_DEFAULT, refs.data()) < 0)
        throw Error(fmt::format("{}: damaged: its HDF5 object references cannot be read", w));
      for (std::size_t k = 0; k < refs.size(); ++k) {
        H5Handle obj(H5Rdereference2(d, H5P_DEFAULT, H5R_OBJECT, &refs[k]), H5Oclose);
        if (!obj) continue;  // a reference to nothing: matio cannot read it either
        cost = add_sat(cost, object_cost(obj.get(), fmt::format("{}{{{}}}", var, k + 1), depth + 1));
      }
    }
    return cost;
  }

  const std::string& path_;
  std::uint64_t n_;
  std::unordered_map<haddr_t, std::uint64_t> cost_;  // per object address: what matio may allocate reading it
  std::unordered_set<haddr_t> open_;                 // being visited: met again, a cycle
  std::uint64_t stored_total_ = 0;
};

// MAT v7.3: an HDF5 file after a 512-byte MATLAB header. Its superblock (HDF5 format
// specification, "Superblock", versions 0-3) must be there, and the file must be as long as the
// end-of-file address it declares (a cut file otherwise reads as "0 variables" through matio).
// Then the variables, through HDF5 (Mat73Check above).
void check_mat73(Bytes f, const std::string& path) {
  static constexpr unsigned char sig[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  std::size_t at = 0;
  for (std::size_t off = 512; off + 8 <= f.n; off *= 2)  // HDF5 looks at 0, 512, 1024, 2048, ...
    if (std::memcmp(f.p + off, sig, 8) == 0) {
      at = off;
      break;
    }
  if (at == 0)
    throw Error(fmt::format("{}: MAT v7.3 header but no HDF5 data after it (no HDF5 signature at byte 512 or "
                            "beyond; the file has {} bytes): truncated or not a MAT file",
                            path, f.n));
  auto need = [&](std::size_t end) {
    if (end > f.n)
      throw Error(fmt::format("{}: MAT v7.3 (HDF5) file truncated: its superblock at byte {} is cut ({} bytes)", path,
                              at, f.n));
  };
  need(at + 16);
  const unsigned version = f.p[at + 8];
  std::size_t offsets = 0, eof_pos = 0;
  if (version <= 1) {
    offsets = f.p[at + 13];
    eof_pos = at + 24 + (version == 1 ? 4 : 0) + 2 * offsets;  // base, free-space, then end of file
  } else if (version <= 3) {
    offsets = f.p[at + 9];
    eof_pos = at + 12 + 2 * offsets;  // base, superblock extension, then end of file
  } else {
    throw Error(fmt::format("{}: MAT v7.3 (HDF5) file with an unknown superblock version {}", path, version));
  }
  if (offsets != 2 && offsets != 4 && offsets != 8)
    throw Error(fmt::format("{}: MAT v7.3 (HDF5) superblock declares {}-byte addresses (2, 4 or 8 expected): damaged",
                            path, offsets));
  need(eof_pos + offsets);
  std::uint64_t eof = 0;
  for (std::size_t i = offsets; i-- > 0;) eof = eof << 8 | f.p[eof_pos + i];
  // The end-of-file address counts from the start of the file (the 512-byte MATLAB header
  // included); read as relative to the HDF5 data it would only be larger.
  if (eof > f.n)
    throw Error(fmt::format("{}: MAT v7.3 (HDF5) file truncated: its superblock declares {} bytes, the file has {}",
                            path, eof, f.n));
  const H5Quiet quiet;
  Mat73Check(path, f.n).run();
}

// Throws hysteron::Error naming the file and the variable if the file is truncated or its sizes
// are inconsistent. MAT v7.3 (HDF5) files: check_mat73 (the superblock, then every dataset's
// declared size against its stored bytes, through HDF5).
void check_mat_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;  // open_mat reports it
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) {
    ::close(fd);
    return;
  }
  const std::size_t n = static_cast<std::size_t>(st.st_size);
  // a small file is read (mapping it costs more), a large one mapped
  std::vector<unsigned char> small;
  void* map = MAP_FAILED;
  if (n <= (std::size_t{1} << 16)) {
    small.resize(n);
    std::size_t got = 0;
    while (got < n) {
      const ssize_t r = ::read(fd, small.data() + got, n - got);
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) {
        const int err = r < 0 ? errno : EIO;
        ::close(fd);
        throw Error(fmt::format("{}: cannot read: {}", path, std::strerror(err)));
      }
      got += static_cast<std::size_t>(r);
    }
  } else {
    map = ::mmap(nullptr, n, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      throw Error(fmt::format("{}: cannot read: {}", path, std::strerror(err)));
    }
  }
  ::close(fd);
  struct Unmap {
    void* p;
    std::size_t n;
    ~Unmap() {
      if (p != MAP_FAILED) ::munmap(p, n);
    }
  } unmap{map, n};
  const Bytes f{map != MAP_FAILED ? static_cast<const unsigned char*>(map) : small.data(), n, n};
  // matio reads a file as v5 / v7.3 only with the endian mark and one of their two versions;
  // any other file, a 128-byte header with an unknown version included, it reads as MAT v4
  const bool mark = n >= 128 && ((f.p[126] == 'I' && f.p[127] == 'M') || (f.p[126] == 'M' && f.p[127] == 'I'));
  const bool swap = mark && f.p[126] == 'M';
  const unsigned version = !mark ? 0 : swap ? (f.p[124] << 8 | f.p[125]) : (f.p[125] << 8 | f.p[124]);
  if (version != 0x0100 && version != 0x0200) {
    check_mat4(f, path);
    return;
  }
  if (version == 0x0200) return check_mat73(f, path);  // v7.3 (HDF5)
  std::size_t pos = 128;
  for (std::size_t index = 0; pos < n; ++index) {
    if (n - pos < 8)
      throw Error(fmt::format("{}: variable #{}: truncated: {} bytes left where a tag needs 8", path, index + 1,
                              n - pos));
    const std::uint32_t type = get32(f.p + pos, swap);
    const std::size_t bytes = get32(f.p + pos + 4, swap);
    const std::size_t data = pos + 8;
    std::string name;
    if (type == 14 || type == 15) {
      if (bytes > n - data)
        throw Error(fmt::format("{}: variable #{}: truncated: declares {} bytes, the file has {} left (of {})", path,
                                index + 1, bytes, n - data, n));
      if (type == 14)
        check_mat5_matrix(Bytes{f.p + data, bytes, bytes}, swap, path, index, &name);
      else
        check_mat5_compressed(Bytes{f.p + data, bytes, bytes}, swap, path, index);
    } else if (bytes > n - data) {
      throw Error(fmt::format("{}: element #{}: truncated: declares {} bytes, the file has {} left", path, index + 1,
                              bytes, n - data));
    }
    pos = data + bytes;
    if (type != 15) pos = std::min(n, data + ((bytes + 7) / 8) * 8);
  }
}

std::vector<std::string> mat_variable_names(const std::string& path) {
  MatPtr m = open_mat(path);
  std::vector<std::string> names;
  for (;;) {
    VarPtr v(Mat_VarReadNextInfo(m.get()));
    if (!v) break;
    if (v->name) names.emplace_back(v->name);
  }
  return names;
}

std::string list_names(const std::vector<std::string>& names) {
  if (names.empty()) return "none";
  std::string s;
  for (const auto& n : names) {
    if (!s.empty()) s += ", ";
    s += '"' + n + '"';
  }
  return s;
}

template <class T>
void copy_data(const void* data, std::size_t n, std::vector<double>& out) {
  const T* p = static_cast<const T*>(data);
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(p[i]);
}

const char* class_name(matio_classes c) {
  switch (c) {
    case MAT_C_CELL: return "cell";
    case MAT_C_STRUCT: return "struct";
    case MAT_C_OBJECT: return "object";
    case MAT_C_CHAR: return "char";
    case MAT_C_SPARSE: return "sparse";
    case MAT_C_FUNCTION: return "function handle";
    case MAT_C_OPAQUE: return "opaque (e.g. a table, string or datetime object)";
    default: return "unknown";
  }
}

std::string dims_text(const matvar_t& v) {
  std::string dims;
  for (int i = 0; i < v.rank; ++i) dims += fmt::format("{}{}", i ? "x" : "", v.dims[i]);
  return dims;
}

// A real, full, numeric 2-D variable: values in column-major order (MATLAB's).
struct MatArray {
  std::string name;
  std::string where;  // "path: variable \"name\"", for messages
  std::size_t rows = 0, cols = 0;
  std::vector<double> values;
  bool is_vector() const noexcept { return rows <= 1 || cols <= 1; }  // empty counts as a vector
  std::string size_text() const { return fmt::format("{}x{}", rows, cols); }
};

MatArray read_mat_array(const std::string& path, const std::string& name) {
  MatPtr m = open_mat(path);
  VarPtr v(Mat_VarRead(m.get(), name.c_str()));
  if (!v) {
    m.reset();
    const auto names = mat_variable_names(path);
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw Error(fmt::format("{}: variable \"{}\" cannot be read (corrupt, truncated or of an unsupported kind)", path,
                              name));
    throw Error(fmt::format("{}: no variable \"{}\"; the file has {}", path, name, list_names(names)));
  }
  MatArray a;
  a.name = name;
  a.where = fmt::format("{}: variable \"{}\"", path, name);
  const std::string expected = "expected a real numeric vector or 2-D matrix (double, single or an integer class)";
  if (v->class_type == MAT_C_SPARSE)
    throw Error(fmt::format("{}: is a sparse matrix (size {}); {}: convert it with full() before saving", a.where,
                            dims_text(*v), expected));
  switch (v->class_type) {
    case MAT_C_DOUBLE: case MAT_C_SINGLE: case MAT_C_INT8: case MAT_C_UINT8: case MAT_C_INT16:
    case MAT_C_UINT16: case MAT_C_INT32: case MAT_C_UINT32: case MAT_C_INT64: case MAT_C_UINT64: break;
    default: throw Error(fmt::format("{}: is not numeric (class {}); {}", a.where, class_name(v->class_type), expected));
  }
  if (v->isComplex) throw Error(fmt::format("{}: is complex (size {}); {}", a.where, dims_text(*v), expected));
  if (v->rank != 2)
    throw Error(fmt::format("{}: is a {}-D array (size {}); {}", a.where, v->rank, dims_text(*v), expected));
  a.rows = v->dims[0];
  a.cols = v->dims[1];
  const std::size_t n = a.rows * a.cols;
  if (n > 0 && !v->data) throw Error(fmt::format("{}: has no data", a.where));
  if (n > 0) {
    auto& out = a.values;
    switch (v->data_type) {
      case MAT_T_DOUBLE: copy_data<double>(v->data, n, out); break;
      case MAT_T_SINGLE: copy_data<float>(v->data, n, out); break;
      case MAT_T_INT8: copy_data<std::int8_t>(v->data, n, out); break;
      case MAT_T_UINT8: copy_data<std::uint8_t>(v->data, n, out); break;
      case MAT_T_INT16: copy_data<std::int16_t>(v->data, n, out); break;
      case MAT_T_UINT16: copy_data<std::uint16_t>(v->data, n, out); break;
      case MAT_T_INT32: copy_data<std::int32_t>(v->data, n, out); break;
      case MAT_T_UINT32: copy_data<std::uint32_t>(v->data, n, out); break;
      case MAT_T_INT64: copy_data<std::int64_t>(v->data, n, out); break;
      case MAT_T_UINT64: copy_data<std::uint64_t>(v->data, n, out); break;
      default: throw Error(fmt::format("{}: unsupported data type {}", a.where, static_cast<int>(v->data_type)));
    }
  }
  return a;
}

// Column `col` of a matrix, or the whole vector (col = npos); refuses NaN/infinity in what is read.
std::vector<double> mat_column(const MatArray& a, std::size_t col) {
  std::vector<double> out;
  if (a.is_vector()) {
    out = a.values;
    for (std::size_t i = 0; i < out.size(); ++i)
      if (!std::isfinite(out[i]))
        throw Error(fmt::format("{}: element {} (1-based) is not a finite number (NaN and infinity are refused)",
                                a.where, i + 1));
    return out;
  }
  out.assign(a.values.begin() + static_cast<std::ptrdiff_t>(col * a.rows),
             a.values.begin() + static_cast<std::ptrdiff_t>((col + 1) * a.rows));
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!std::isfinite(out[i]))
      throw Error(fmt::format("{}: row {}, column {} (0-based column; row 1-based) is not a finite number (NaN and "
                              "infinity are refused)",
                              a.where, i + 1, col));
  return out;
}

std::string choose_column_hint(const std::string& name, const MatArray& a) {
  return fmt::format("is a {} matrix ({} rows = samples, {} columns); choose a column with \"{}:0\" .. \"{}:{}\" "
                     "(0-based column index)",
                     a.size_text(), a.rows, a.cols, name, name, a.cols - 1);
}

}  // namespace

// A .mat column spec: "" (the file's only variable; of several, the one named `preferred` if
// any, as select_column does for a text file), a variable name (a vector, or an N x 1 / 1 x N
// matrix), or NAME:INDEX (column INDEX, 0-based, of the 2-D matrix NAME). A variable whose name
// is the whole spec wins over the NAME:INDEX reading (MATLAB names cannot hold ':', but other
// writers' files may).
std::vector<double> read_mat_variable(const std::string& path, const std::string& spec, const std::string& preferred) {
  check_mat_file(path);
  std::string name = spec;
  std::optional<std::size_t> col;
  if (name.empty()) {
    const auto names = mat_variable_names(path);
    const bool has_preferred =
        !preferred.empty() && std::find(names.begin(), names.end(), preferred) != names.end();
    if (names.size() != 1 && !has_preferred) {
      const std::string none = preferred.empty() ? std::string() : fmt::format(", none named \"{}\"", shown(preferred));
      throw Error(fmt::format("{}: has {} variables ({}){}; choose one by name (NAME:INDEX for a column of a matrix)",
                              path, names.size(), list_names(names), none));
    }
    name = names.size() == 1 ? names[0] : preferred;
  } else if (const auto colon = spec.rfind(':'); colon != std::string::npos) {
    const auto names = mat_variable_names(path);
    if (std::find(names.begin(), names.end(), spec) == names.end()) {
      name = spec.substr(0, colon);
      const std::string_view idx = std::string_view(spec).substr(colon + 1);
      std::size_t k = 0;
      const auto res = std::from_chars(idx.data(), idx.data() + idx.size(), k);
      if (name.empty() || idx.empty() || res.ec != std::errc() || res.ptr != idx.data() + idx.size())
        throw Error(fmt::format("{}: \"{}\" is not a column of the file: expected a variable name or NAME:INDEX "
                                "(INDEX = 0-based column of the matrix NAME); the file has {}",
                                path, spec, list_names(names)));
      if (std::find(names.begin(), names.end(), name) == names.end())
        throw Error(fmt::format("{}: no variable \"{}\" (in \"{}\"); the file has {}", path, name, spec,
                                list_names(names)));
      col = k;
    }
  }
  const MatArray a = read_mat_array(path, name);
  if (!col) {
    if (!a.is_vector()) throw Error(fmt::format("{}: {}", a.where, choose_column_hint(name, a)));
    return mat_column(a, 0);
  }
  const std::size_t ncols = a.is_vector() ? 1 : a.cols;
  if (*col >= ncols) {
    if (a.is_vector())
      throw Error(fmt::format("{}: column index {} is out of range: the variable is a vector (size {}), a single "
                              "column: use \"{}\" or \"{}:0\"",
                              a.where, *col, a.size_text(), name, name));
    throw Error(fmt::format("{}: column index {} is out of range: the variable is a {} matrix ({} columns, indices "
                            "0..{})",
                            a.where, *col, a.size_text(), a.cols, a.cols - 1));
  }
  return mat_column(a, *col);
}

bool is_matlab_identifier(std::string_view s) {
  if (s.empty() || s.size() > 63 || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

void write_mat(const std::string& tmp, const std::vector<std::string>& names,
               const std::vector<std::vector<double>>& columns, bool compress) {
  init_matio_log();
  MatPtr m(Mat_CreateVer(tmp.c_str(), nullptr, MAT_FT_MAT5));
  if (!m) throw Error("cannot create the .mat file");
  for (std::size_t i = 0; i < names.size(); ++i) {
    size_t dims[2] = {columns[i].size(), 1};
    // matio takes a non-const pointer; with MAT_F_DONT_COPY_DATA it neither copies nor frees nor writes to it
    VarPtr v(Mat_VarCreate(names[i].c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                           const_cast<double*>(columns[i].data()), MAT_F_DONT_COPY_DATA));
    if (!v) throw Error(fmt::format("cannot create .mat variable \"{}\"", names[i]));
    if (Mat_VarWrite(m.get(), v.get(), compress ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE) != 0)
      throw Error(fmt::format("cannot write .mat variable \"{}\"", names[i]));
  }
  if (Mat_Close(m.release()) != 0) throw Error("cannot close the .mat file (disk full?)");
  // matio does not report every failed write (a full disk can lose buffered data silently):
  // the file written must have the structure and the sizes of what was written
  struct stat st {};
  if (::stat(tmp.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;  // a device or a FIFO: nothing to re-read
  try {
    check_mat_file(tmp);
    if (mat_variable_names(tmp) != names) throw Error("variables missing");
  } catch (const Error& e) {
    throw Error(fmt::format("the .mat file was not written completely (disk full?): {}", e.what()));
  }
}

// The .mat side of read_table (table.hpp).
Table read_mat_table(const std::string& path) {
  check_mat_file(path);
  Table t;
  t.source = path;
  // vectors first (in file order), then the columns "NAME:0", "NAME:1", ... of the 2-D matrices
  // with as many rows as the vectors have elements (or as the first such matrix, if no vector)
  std::vector<MatArray> matrices;
  for (const auto& name : mat_variable_names(path)) {
    MatArray a;
    std::vector<double> v;
    try {
      a = read_mat_array(path, name);
      if (!a.is_vector()) {
        matrices.push_back(std::move(a));
        continue;
      }
      v = mat_column(a, 0);
    } catch (const Error&) {
      continue;  // not a real numeric vector or matrix (or not finite): not a column
    }
    if (!t.columns.empty() && v.size() != t.columns[0].size())
      throw Error(fmt::format("{}: variable \"{}\" has {} elements but \"{}\" has {}; read them one by one", path,
                              name, v.size(), t.names[0], t.columns[0].size()));
    t.names.push_back(name);
    t.columns.push_back(std::move(v));
  }
  for (const auto& a : matrices) {
    if (!t.columns.empty() && a.rows != t.columns[0].size()) continue;
    for (std::size_t j = 0; j < a.cols; ++j) {
      std::vector<double> v;
      try {
        v = mat_column(a, j);
      } catch (const Error&) {
        continue;
      }
      t.names.push_back(fmt::format("{}:{}", a.name, j));
      t.columns.push_back(std::move(v));
    }
  }
  return t;
}

}  // namespace hysteron::io::detail
