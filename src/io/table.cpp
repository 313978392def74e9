#include "hysteron/io/table.hpp"

#include <fcntl.h>
#include <matio.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <zlib.h>
#include <unistd.h>

#include <fmt/format.h>

#include <csignal>
#include <cstdint>
#include <limits>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include "hysteron/error.hpp"

namespace hysteron::io {

namespace {

namespace fs = std::filesystem;

bool is_mat_path(std::string_view path) {
  if (path.size() < 4) return false;
  std::string ext(path.substr(path.size() - 4));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".mat";
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

std::vector<std::string_view> split(std::string_view line, char sep) {
  std::vector<std::string_view> out;
  if (sep == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i >= line.size()) break;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      out.push_back(line.substr(i, j - i));
      i = j;
    }
    return out;
  }
  std::size_t start = 0;
  for (;;) {
    const std::size_t pos = line.find(sep, start);
    if (pos == std::string_view::npos) {
      out.push_back(unquote(line.substr(start)));
      return out;
    }
    out.push_back(unquote(line.substr(start, pos - start)));
    start = pos + 1;
  }
}

enum class Parse { ok, empty, malformed, non_finite, out_of_range };

Parse parse_number(std::string_view s, double& out) {
  s = unquote(s);
  if (s.empty()) return Parse::empty;
  if (s.front() == '+') s.remove_prefix(1);
  if (s.empty() || s.front() == '+') return Parse::malformed;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), out);
  if (res.ptr != s.data() + s.size()) return Parse::malformed;
  if (res.ec == std::errc::result_out_of_range) {
    // from_chars also reports underflow (denormal/zero) as out of range; only overflow is an error
    errno = 0;
    const std::string tmp(s);
    out = std::strtod(tmp.c_str(), nullptr);
    if (!std::isfinite(out)) return Parse::out_of_range;
    return Parse::ok;
  }
  if (res.ec != std::errc()) return Parse::malformed;
  if (!std::isfinite(out)) return Parse::non_finite;
  return Parse::ok;
}

bool looks_numeric(std::string_view s) {
  double d = 0.0;
  const Parse p = parse_number(s, d);
  return p != Parse::malformed;  // empty fields and nan/inf do not make a header
}

std::string column_label(const std::vector<std::string>& names, std::size_t i) {
  if (i < names.size() && !names[i].empty()) return fmt::format(" (column \"{}\")", names[i]);
  return std::string();
}

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw Error(fmt::format("{}: is a directory, not a data file", path));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open data file ({})", path, std::strerror(errno)));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(fmt::format("{}: read error", path));
  return ss.str();
}

Table read_text_table(const std::string& path, const ReadOptions& opt) {
  const std::string text = read_file(path);
  std::string_view all(text);
  if (all.substr(0, 3) == "\xEF\xBB\xBF") all.remove_prefix(3);

  Table t;
  t.source = path;
  char sep = opt.separator;
  if (sep != 0 && sep != ',' && sep != ';' && sep != '\t' && sep != ' ')
    throw Error(fmt::format("{}: unsupported separator '{}' (use ',', ';', tab or ' ')", path, sep));
  bool first = true;
  bool have_header = false;
  std::size_t nfields = 0;
  std::size_t first_line = 0;
  std::vector<std::size_t> filled;  // number of non-empty fields per column
  std::size_t rows = 0;
  std::size_t lineno = 0;
  std::vector<std::vector<double>> cols;
  // first empty field per column (line number), reported if the column is not all-empty
  std::vector<std::size_t> first_empty_line;

  std::size_t pos = 0;
  while (pos <= all.size()) {
    std::size_t nl = all.find('\n', pos);
    if (nl == std::string_view::npos) nl = all.size();
    std::string_view line = all.substr(pos, nl - pos);
    pos = nl + 1;
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string_view tl = trim(line);
    if (tl.empty() || tl.front() == '#') {
      if (nl == all.size()) break;
      continue;
    }
    if (first) {
      if (sep == 0) {
        if (line.find('\t') != std::string_view::npos) sep = '\t';
        else if (line.find(';') != std::string_view::npos) sep = ';';
        else if (line.find(',') != std::string_view::npos) sep = ',';
        else sep = ' ';
      }
      const auto fields = split(line, sep);
      nfields = fields.size();
      first_line = lineno;
      if (opt.header == HeaderMode::present) have_header = true;
      else if (opt.header == HeaderMode::autodetect)
        have_header = std::any_of(fields.begin(), fields.end(), [](std::string_view f) { return !looks_numeric(f); });
      cols.assign(nfields, {});
      filled.assign(nfields, 0);
      first_empty_line.assign(nfields, 0);
      first = false;
      if (have_header) {
        for (auto f : fields) t.names.emplace_back(unquote(f));
        // A name given twice would select the first column silently.
        for (std::size_t i = 0; i < t.names.size(); ++i)
          for (std::size_t k = 0; k < i; ++k)
            if (!t.names[i].empty() && t.names[i] == t.names[k])
              throw Error(fmt::format("{}:{}: column name \"{}\" appears twice (columns {} and {}); rename one",
                                      path, lineno, t.names[i], k + 1, i + 1));
        if (nl == all.size()) break;
        continue;
      }
      t.names.assign(nfields, std::string());
    }
    const auto fields = split(line, sep);
    if (fields.size() != nfields)
      throw Error(fmt::format("{}:{}: row has {} fields, expected {} (as on line {})", path, lineno, fields.size(),
                              nfields, first_line));
    for (std::size_t c = 0; c < nfields; ++c) {
      double v = 0.0;
      switch (parse_number(fields[c], v)) {
        case Parse::ok:
          if (filled[c] != rows) {
            throw Error(fmt::format("{}:{}:{}{}: empty field (the column has values on other lines)", path,
                                    first_empty_line[c], c + 1, column_label(t.names, c)));
          }
          cols[c].push_back(v);
          ++filled[c];
          break;
        case Parse::empty:
          if (filled[c] != 0)
            throw Error(fmt::format("{}:{}:{}{}: empty field (the column has values on other lines)", path, lineno,
                                    c + 1, column_label(t.names, c)));
          if (first_empty_line[c] == 0) first_empty_line[c] = lineno;
          break;
        case Parse::malformed:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is not a number", path, lineno, c + 1, column_label(t.names, c),
                                  fields[c]));
        case Parse::non_finite:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is not a finite number (NaN and infinity are refused)", path,
                                  lineno, c + 1, column_label(t.names, c), fields[c]));
        case Parse::out_of_range:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is out of the range of a double", path, lineno, c + 1,
                                  column_label(t.names, c), fields[c]));
      }
    }
    ++rows;
    if (nl == all.size()) break;
  }
  if (first) throw Error(fmt::format("{}: no data (the file is empty)", path));
  t.columns = std::move(cols);
  return t;
}

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
// its compressed bytes could hold).

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

// The inside of a miMATRIX element (s = its data, without the 8-byte tag). Only numeric classes
// are checked in detail (the ones hysteron reads); names are reported in messages.
void check_mat5_matrix(Bytes s, bool swap, const std::string& path, std::size_t index, std::string* name_out) {
  std::string where = fmt::format("{}: variable #{}", path, index + 1);
  std::size_t pos = 0;
  const SubElement flags = next_sub(s, pos, swap, where, "array flags");
  if (flags.bytes < 8 || flags.data + 8 > s.avail) throw Error(fmt::format("{}: inconsistent: array flags of {} bytes", where, flags.bytes));
  const std::uint32_t f = get32(s.p + flags.data, swap);
  const unsigned cls = f & 0xff;
  const bool complex = (f & 0x800) != 0;
  const SubElement dims = next_sub(s, pos, swap, where, "dimensions");
  if (dims.data + dims.bytes > s.avail) throw Error(fmt::format("{}: unsupported: too many dimensions", where));
  if (dims.type != 5 || dims.bytes % 4 != 0 || dims.bytes < 8)
    throw Error(fmt::format("{}: inconsistent: bad dimensions element (type {}, {} bytes)", where, dims.type,
                            dims.bytes));
  const SubElement nm = next_sub(s, pos, swap, where, "name");
  if (nm.data + nm.bytes > s.avail) throw Error(fmt::format("{}: unsupported: a name of {} bytes", where, nm.bytes));
  std::string name(reinterpret_cast<const char*>(s.p + nm.data), nm.bytes);
  name = name.substr(0, name.find('\0'));
  if (!name.empty()) where = fmt::format("{}: variable \"{}\"", path, name);
  if (name_out) *name_out = name;
  // numel with overflow check; every dimension must be non-negative
  std::uint64_t numel = 1;
  std::string dims_txt;
  for (std::size_t k = 0; k < dims.bytes / 4; ++k) {
    const std::uint32_t d = get32(s.p + dims.data + 4 * k, swap);
    if (d > 0x7fffffffu) throw Error(fmt::format("{}: inconsistent: negative dimension", where));
    numel = mul_sat(numel, d);
    dims_txt += fmt::format("{}{}", k ? "x" : "", d);
  }
  if (cls < 6 || cls > 15) return;  // cell, struct, char, sparse, ...: matio reads them, hysteron refuses them
  for (int part = 0; part < (complex ? 2 : 1); ++part) {
    const SubElement data = next_sub(s, pos, swap, where, part ? "imaginary part" : "data");
    const std::size_t sz = mat5_type_size(data.type);
    if (sz == 0 || data.type >= 16)
      throw Error(fmt::format("{}: inconsistent: data of unknown type {}", where, data.type));
    if (data.bytes != mul_sat(numel, sz))
      throw Error(fmt::format("{}: truncated or inconsistent: size {} ({} elements) needs {} bytes of data, the file "
                              "has {}",
                              where, dims_txt, numel, mul_sat(numel, sz), data.bytes));
  }
}

// Inflates a miCOMPRESSED element (at most `limit` bytes of output) and checks its inside.
void check_mat5_compressed(Bytes z, bool swap, const std::string& path, std::size_t index) {
  const std::string where = fmt::format("{}: variable #{}", path, index + 1);
  // zlib expands at most ~1032:1: a larger declared size cannot be real data
  const std::size_t limit = z.n * 1032 + 1024;
  z_stream zs{};
  if (inflateInit(&zs) != Z_OK) throw Error(fmt::format("{}: cannot initialise zlib", where));
  struct End {
    z_stream* s;
    ~End() { inflateEnd(s); }
  } end{&zs};
  zs.next_in = const_cast<Bytef*>(z.p);
  zs.avail_in = static_cast<uInt>(std::min<std::size_t>(z.n, std::numeric_limits<uInt>::max()));
  // the head (tag, flags, dims, name, data tag) is kept; the rest is only counted
  std::vector<unsigned char> head(4096), chunk(1 << 16);
  std::size_t head_len = 0;
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    unsigned char* out = head_len < head.size() ? head.data() + head_len : chunk.data();
    const std::size_t room = head_len < head.size() ? head.size() - head_len : chunk.size();
    zs.next_out = out;
    zs.avail_out = static_cast<uInt>(room);
    rc = inflate(&zs, Z_NO_FLUSH);
    if (head_len < head.size()) head_len += room - zs.avail_out;
    if (rc == Z_STREAM_END) break;
    if (rc != Z_OK || (zs.avail_in == 0 && zs.avail_out != 0))
      throw Error(fmt::format("{}: truncated or corrupt compressed data ({})", where,
                              zs.msg ? zs.msg : "the compressed stream ends early"));
    if (zs.total_out > limit) throw Error(fmt::format("{}: corrupt compressed data (expands without bound)", where));
  }
  if (head_len < 8) throw Error(fmt::format("{}: corrupt compressed variable (no matrix inside)", where));
  const std::uint32_t type = get32(head.data(), swap);
  const std::size_t bytes = get32(head.data() + 4, swap);
  if (type != 14) throw Error(fmt::format("{}: corrupt compressed variable (type {} inside, not a matrix)", where, type));
  if (8 + bytes != zs.total_out)
    throw Error(fmt::format("{}: truncated or inconsistent: declares {} bytes, its compressed data holds {}", where,
                            bytes, zs.total_out - 8));
  // the head holds the tags up to the data tag of any sane variable; the data is only counted
  check_mat5_matrix(Bytes{head.data() + 8, bytes, head_len - 8}, swap, path, index, nullptr);
}

void check_mat4(Bytes f, const std::string& path) {
  std::size_t pos = 0;
  for (std::size_t index = 0; pos < f.n; ++index) {
    const std::string where = fmt::format("{}: variable #{}", path, index + 1);
    if (f.n - pos < 20)
      throw Error(fmt::format("{}: truncated: {} bytes left where a MAT v4 header needs 20", where, f.n - pos));
    std::uint32_t h[5];
    std::memcpy(h, f.p + pos, 20);
    if (h[0] > 9999) {  // the other byte order
      for (auto& v : h) v = __builtin_bswap32(v);
    }
    const std::uint32_t type = h[0], rows = h[1], cols = h[2], imag = h[3], namelen = h[4];
    const unsigned M = type / 1000, O = (type / 100) % 10, P = (type / 10) % 10, T = type % 10;
    static constexpr std::size_t kSize[6] = {8, 4, 4, 2, 2, 1};
    if (M > 4 || O != 0 || P > 5 || T > 2 || imag > 1 || rows > 0x7fffffffu || cols > 0x7fffffffu ||
        namelen == 0 || namelen > 4096)
      throw Error(fmt::format("{}: inconsistent MAT v4 header (type {}, {}x{}, name length {})", where, type, rows,
                              cols, namelen));
    if (namelen > f.n - pos - 20)
      throw Error(fmt::format("{}: truncated: the name ({} bytes) ends after the file", where, namelen));
    std::string name(reinterpret_cast<const char*>(f.p + pos + 20), namelen);
    name = name.substr(0, name.find('\0'));
    const std::string w = fmt::format("{}: variable \"{}\"", path, name);
    const std::uint64_t need = mul_sat(mul_sat(rows, cols), kSize[P] * (imag ? 2u : 1u));
    const std::size_t left = f.n - pos - 20 - namelen;
    if (need > left)
      throw Error(fmt::format("{}: truncated or inconsistent: size {}x{} needs {} bytes of data, the file has {}", w,
                              rows, cols, need, left));
    pos += 20 + namelen + static_cast<std::size_t>(need);
  }
}

// Throws hysteron::Error naming the file and the variable if the file is truncated or its sizes
// are inconsistent. MAT v7.3 (HDF5) files are left to matio.
void check_mat_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;  // open_mat reports it
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) {
    ::close(fd);
    return;
  }
  const std::size_t n = static_cast<std::size_t>(st.st_size);
  void* map = ::mmap(nullptr, n, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED) throw Error(fmt::format("{}: cannot read: {}", path, std::strerror(errno)));
  struct Unmap {
    void* p;
    std::size_t n;
    ~Unmap() { ::munmap(p, n); }
  } unmap{map, n};
  const Bytes f{static_cast<const unsigned char*>(map), n, n};
  const bool v5 = n >= 128 && ((f.p[126] == 'I' && f.p[127] == 'M') || (f.p[126] == 'M' && f.p[127] == 'I'));
  if (!v5) {
    check_mat4(f, path);
    return;
  }
  const bool swap = f.p[126] == 'M';
  const unsigned version = swap ? (f.p[124] << 8 | f.p[125]) : (f.p[125] << 8 | f.p[124]);
  if (version == 0x0200) return;  // v7.3 (HDF5)
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

// A .mat column spec: "" (the file's only variable), a variable name (a vector, or an N x 1 /
// 1 x N matrix), or NAME:INDEX (column INDEX, 0-based, of the 2-D matrix NAME). A variable whose
// name is the whole spec wins over the NAME:INDEX reading (MATLAB names cannot hold ':', but
// other writers' files may).
std::vector<double> read_mat_variable(const std::string& path, const std::string& spec) {
  check_mat_file(path);
  std::string name = spec;
  std::optional<std::size_t> col;
  if (name.empty()) {
    const auto names = mat_variable_names(path);
    if (names.size() != 1)
      throw Error(fmt::format("{}: has {} variables ({}); choose one by name (NAME:INDEX for a column of a matrix)",
                              path, names.size(), list_names(names)));
    name = names[0];
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
               const std::vector<std::vector<double>>& columns) {
  init_matio_log();
  MatPtr m(Mat_CreateVer(tmp.c_str(), nullptr, MAT_FT_MAT5));
  if (!m) throw Error("cannot create the .mat file");
  for (std::size_t i = 0; i < names.size(); ++i) {
    size_t dims[2] = {columns[i].size(), 1};
    // matio takes a non-const pointer; with MAT_F_DONT_COPY_DATA it neither copies nor frees nor writes to it
    VarPtr v(Mat_VarCreate(names[i].c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                           const_cast<double*>(columns[i].data()), MAT_F_DONT_COPY_DATA));
    if (!v) throw Error(fmt::format("cannot create .mat variable \"{}\"", names[i]));
    if (Mat_VarWrite(m.get(), v.get(), MAT_COMPRESSION_ZLIB) != 0)
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

std::string csv_text(const std::vector<std::string>& names, const std::vector<std::vector<double>>& columns) {
  fmt::memory_buffer buf;
  for (std::size_t i = 0; i < names.size(); ++i) fmt::format_to(std::back_inserter(buf), "{}{}", i ? "," : "", names[i]);
  buf.push_back('\n');
  const std::size_t rows = columns.empty() ? 0 : columns[0].size();
  char num[40];
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c) buf.push_back(',');
      const int len = std::snprintf(num, sizeof num, "%.17g", columns[c][r]);
      buf.append(num, num + len);
    }
    buf.push_back('\n');
  }
  return std::string(buf.data(), buf.size());
}

}  // namespace

// ---- Table ---------------------------------------------------------------------

std::size_t Table::num_rows() const noexcept {
  std::size_t n = 0;
  for (const auto& c : columns) n = std::max(n, c.size());
  return n;
}

std::size_t Table::column_index(std::string_view spec) const {
  auto describe = [&] {
    std::string s;
    for (std::size_t i = 0; i < columns.size(); ++i) {
      if (!s.empty()) s += ", ";
      s += std::to_string(i);
      if (i < names.size() && !names[i].empty()) s += fmt::format(" \"{}\"", names[i]);
      if (columns[i].empty()) s += " (empty)";
    }
    return s;
  };
  if (spec.empty()) {
    std::size_t found = columns.size(), count = 0;
    for (std::size_t i = 0; i < columns.size(); ++i)
      if (!columns[i].empty()) {
        found = i;
        ++count;
      }
    if (count != 1)
      throw Error(fmt::format("{}: has {} non-empty columns ({}); choose one (by name or 0-based index)", source,
                              count, describe()));
    return found;
  }
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == spec) return i;
  std::size_t idx = 0;
  const auto res = std::from_chars(spec.data(), spec.data() + spec.size(), idx);
  if (res.ec == std::errc() && res.ptr == spec.data() + spec.size()) {
    if (idx >= columns.size())
      throw Error(fmt::format("{}: column index {} is out of range; the file has {} columns: {}", source, idx,
                              columns.size(), describe()));
    return idx;
  }
  // NAME:INDEX selects a column of a .mat matrix variable (read_column); in a text file a colon is
  // an ordinary character of a header name
  const std::string hint = spec.find(':') != std::string_view::npos && !is_mat_path(source)
                               ? " (NAME:INDEX selects a column of a matrix in a .mat file only; in a text file, "
                                 "name the column by its header or its 0-based index)"
                               : std::string();
  throw Error(fmt::format("{}: no column named \"{}\"{}; columns are: {}", source, spec, hint, describe()));
}

const std::vector<double>& Table::column(std::string_view spec) const {
  const std::size_t i = column_index(spec);
  if (columns[i].empty() && num_rows() > 0)
    throw Error(fmt::format("{}: column {}{} is empty in every row", source, i,
                            i < names.size() && !names[i].empty() ? fmt::format(" \"{}\"", names[i]) : std::string()));
  if (columns[i].empty()) throw Error(fmt::format("{}: column {} has no data", source, i));
  return columns[i];
}

Table read_table(const std::string& path, const ReadOptions& options) {
  if (!is_mat_path(path)) return read_text_table(path, options);
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

std::vector<double> read_column(const std::string& path, const ReadOptions& options) {
  if (is_mat_path(path)) return read_mat_variable(path, options.column_spec);
  const Table t = read_text_table(path, options);
  return t.column(options.column_spec);
}

std::vector<double> read_column(const std::string& path, const std::string& column) {
  ReadOptions o;
  o.column_spec = column;
  return read_column(path, o);
}

void write_columns(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<std::vector<double>>& columns) {
  const bool mat = path != "-" && is_mat_path(path);
  if (names.size() != columns.size())
    throw Error(fmt::format("{}: {} column names for {} columns", path, names.size(), columns.size()));
  if (columns.empty()) throw Error(fmt::format("{}: no columns to write", path));
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (mat && !is_matlab_identifier(names[i]))
      throw Error(fmt::format("{}: \"{}\" is not a valid MATLAB variable name (a letter, then letters, digits, _)",
                              path, names[i]));
    if (!mat && (names[i].empty() || names[i].find_first_of(",;\t\"\r\n") != std::string::npos ||
                 names[i] != trim(names[i]) || looks_numeric(names[i])))
      throw Error(fmt::format("{}: \"{}\" is not a usable CSV column name (non-empty, not a number, no separators, "
                              "quotes or surrounding blanks)",
                              path, names[i]));
    for (std::size_t k = 0; k < i; ++k)
      if (names[k] == names[i]) throw Error(fmt::format("{}: column name \"{}\" given twice", path, names[i]));
    if (columns[i].size() != columns[0].size())
      throw Error(fmt::format("{}: column \"{}\" has {} values but \"{}\" has {} (columns must have equal length)",
                              path, names[i], columns[i].size(), names[0], columns[0].size()));
    for (std::size_t r = 0; r < columns[i].size(); ++r)
      if (!std::isfinite(columns[i][r]))
        throw Error(fmt::format("{}: column \"{}\" row {} is not finite ({})", path, names[i], r, columns[i][r]));
  }
  if (!mat) {
    write_text_file(path, csv_text(names, columns));
    return;
  }
  write_file_atomically(path, [&](const std::string& tmp) { write_mat(tmp, names, columns); });
}

}  // namespace hysteron::io
