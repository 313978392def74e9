// Data tables (table.hpp): text/CSV reading (in memory, streamed), the Table type, CSV writing.
// The .mat side (checks, matio reading, writing) is in mat.cpp.
#include "hysteron/io/table.hpp"
#include "hysteron/io/numbers.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <csignal>
#include <cstdint>
#include <limits>

#include <algorithm>
#include <cctype>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <exception>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string_view>

#include "hysteron/error.hpp"
#include "mat.hpp"

namespace hysteron::io {

namespace detail {

bool is_mat_path(std::string_view path) {
  if (path.size() < 4) return false;
  std::string ext(path.substr(path.size() - 4));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".mat";
}

// Printable, bounded form of a field or name for messages: at most 40 characters, control
// bytes as \xNN (a CR-only file or a binary file must not put raw bytes in a message).
std::string shown(std::string_view s) {
  std::string out;
  const std::size_t n = std::min<std::size_t>(s.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f) out += fmt::format("\\x{:02X}", c);
    else out += static_cast<char>(c);
  }
  if (s.size() > n) out += fmt::format("... ({} bytes)", s.size());
  return out;
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;
using detail::is_mat_path;
using detail::shown;
using detail::trim;

std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

// Splits `line` into `out` (cleared, its capacity reused: no allocation per line once warm).
// Stops after max_text_columns + 1 fields (the caller reports the cap).
void split(std::string_view line, char sep, std::vector<std::string_view>& out) {
  out.clear();
  if (sep == ' ') {
    std::size_t i = 0;
    while (i < line.size() && out.size() <= max_text_columns) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i >= line.size()) break;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      out.push_back(line.substr(i, j - i));
      i = j;
    }
    return;
  }
  std::size_t start = 0;
  while (out.size() <= max_text_columns) {
    const std::size_t pos = line.find(sep, start);
    if (pos == std::string_view::npos) {
      out.push_back(unquote(line.substr(start)));
      return;
    }
    out.push_back(unquote(line.substr(start, pos - start)));
    start = pos + 1;
  }
}

using Parse = NumberParse;

// A field's number (numbers.hpp), inside its quotes if it has them.
Parse parse_unquoted(std::string_view s, double& out) { return io::parse_number(unquote(s), out); }

bool looks_numeric(std::string_view s) {
  double d = 0.0;
  const Parse p = parse_unquoted(s, d);
  return p != Parse::malformed;  // empty fields and nan/inf do not make a header
}

std::string column_label(const std::vector<std::string>& names, std::size_t i) {
  if (i < names.size() && !names[i].empty()) return fmt::format(" (column \"{}\")", shown(names[i]));
  return std::string();
}

// The next line of `avail` (ends: "\n", "\r\n" or a lone "\r"). Returns false if more input is
// needed to know where the line ends (no end yet, or a final '\r' that may start "\r\n").
bool take_line(std::string_view avail, bool at_eof, std::string_view& line, std::size_t& consumed) {
  // memchr for '\n', then for '\r' inside the line only (find_first_of("\r\n") tests each byte
  // against the set: several times slower on long buffers)
  if (avail.empty()) {
    line = avail;
    consumed = 0;
    return at_eof;
  }
  const void* lf = std::memchr(avail.data(), '\n', avail.size());
  std::size_t e = lf ? static_cast<std::size_t>(static_cast<const char*>(lf) - avail.data()) : avail.size();
  if (const void* cr = std::memchr(avail.data(), '\r', e))
    e = static_cast<std::size_t>(static_cast<const char*>(cr) - avail.data());
  else if (!lf)
    e = std::string_view::npos;
  if (e == std::string_view::npos) {
    if (!at_eof) return false;
    line = avail;
    consumed = avail.size();
    return true;
  }
  if (avail[e] == '\r' && e + 1 == avail.size() && !at_eof) return false;
  line = avail.substr(0, e);
  consumed = e + 1 + (avail[e] == '\r' && e + 1 < avail.size() && avail[e + 1] == '\n' ? 1 : 0);
  return true;
}

[[noreturn]] void line_too_long(const std::string& path, std::size_t lineno) {
  throw Error(fmt::format("{}:{}: line longer than {} bytes (the limit of a text data file's line; is this a "
                          "binary file?)",
                          path, lineno, max_text_line_bytes));
}

// Lines of a text held in memory.
class MemoryLines {
 public:
  MemoryLines(std::string_view text, const std::string& path) : rest_(text), path_(path) {
    if (rest_.substr(0, 3) == "\xEF\xBB\xBF") rest_.remove_prefix(3);
  }
  // The next line (false at the end); a file that ends with a line end has no empty last line.
  bool next(std::string_view& line) {
    if (rest_.empty()) return false;
    std::size_t used = 0;
    take_line(rest_, true, line, used);
    rest_.remove_prefix(used);
    if (line.size() > max_text_line_bytes) line_too_long(path_, lineno_ + 1);
    ++lineno_;
    return true;
  }

 private:
  std::string_view rest_;
  const std::string& path_;
  std::size_t lineno_ = 0;
};

// Lines of a file read in chunks through one fixed buffer (bounded memory for any file size).
class FileLines {
 public:
  explicit FileLines(const std::string& path) : path_(path) {
    std::error_code ec;
    if (fs::is_directory(path, ec)) throw Error(fmt::format("{}: is a directory, not a data file", path));
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw Error(fmt::format("{}: cannot open data file ({})", path, std::strerror(errno)));
    // a small regular file gets a buffer of its size (+1 to see the end), not the 256 KiB one
    struct stat st {};
    if (::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode) && static_cast<std::size_t>(st.st_size) < cap_)
      cap_ = std::max<std::size_t>(static_cast<std::size_t>(st.st_size) + 1, 4096);
    buf_.reset(new char[cap_]);
  }
  ~FileLines() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileLines(const FileLines&) = delete;
  FileLines& operator=(const FileLines&) = delete;

  bool next(std::string_view& line) {
    for (;;) {
      const std::string_view avail(buf_.get() + begin_, end_ - begin_);
      std::size_t used = 0;
      if ((eof_ && avail.empty())) return false;
      if (take_line(avail, eof_, line, used)) {
        begin_ += used;
        if (line.size() > max_text_line_bytes) line_too_long(path_, lineno_ + 1);
        ++lineno_;
        return true;
      }
      if (avail.size() > max_text_line_bytes + 1) line_too_long(path_, lineno_ + 1);
      fill();
    }
  }

 private:
  // the buffer starts at 256 KiB (a small file's size) and grows (up to a line's cap and a
  // chunk) only for long lines
  static constexpr std::size_t kSize = max_text_line_bytes + (std::size_t{1} << 20);

  void fill() {
    if (begin_ > 0) {
      std::memmove(buf_.get(), buf_.get() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == cap_ && cap_ < kSize) {
      const std::size_t cap = std::min(kSize, cap_ * 2);
      std::unique_ptr<char[]> bigger(new char[cap]);
      std::memcpy(bigger.get(), buf_.get(), end_);
      buf_ = std::move(bigger);
      cap_ = cap;
    }
    while (end_ < cap_) {
      const ssize_t r = ::read(fd_, buf_.get() + end_, cap_ - end_);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) throw Error(fmt::format("{}: read error ({})", path_, std::strerror(errno)));
      if (r == 0) {
        eof_ = true;
        break;
      }
      end_ += static_cast<std::size_t>(r);
      if (end_ - begin_ >= (std::size_t{1} << 16)) break;  // enough for a few lines
    }
    if (first_) {
      first_ = false;
      if (end_ >= 3 && std::memcmp(buf_.get(), "\xEF\xBB\xBF", 3) == 0) begin_ = 3;
    }
  }

  const std::string& path_;
  int fd_ = -1;
  std::unique_ptr<char[]> buf_;
  std::size_t begin_ = 0, end_ = 0, lineno_ = 0, cap_ = std::size_t{1} << 18;
  bool eof_ = false, first_ = true;
};

// The rules of a text table (table.hpp), one line at a time. After parse() returns true, the
// row's fields are in values() (present(c) false for an empty field).
class TextParser {
 public:
  TextParser(const std::string& path, const ReadOptions& opt) : path_(path), opt_(opt), sep_(opt.separator) {
    if (sep_ != 0 && sep_ != ',' && sep_ != ';' && sep_ != '\t' && sep_ != ' ')
      throw Error(fmt::format("{}: unsupported separator '{}' (use ',', ';', tab or ' ')", path, shown({&sep_, 1})));
  }

  // One line, without its line end. True if it is a data row.
  bool parse(std::string_view line) {
    ++lineno_;
    // (here, not in a reader: the file's and the in-memory reader must agree)
    if (lineno_ == 1 && line.size() >= 2 && (line.substr(0, 2) == "\xFF\xFE" || line.substr(0, 2) == "\xFE\xFF"))
      throw Error(fmt::format("{}: the file is UTF-16 encoded (byte-order mark {}): save it as UTF-8 text or "
                              "\"CSV UTF-8\"",
                              path_, line[0] == '\xFF' ? "FF FE" : "FE FF"));
    if (line.find('\0') != std::string_view::npos)
      throw Error(fmt::format("{}:{}: a NUL byte: the file is binary or UTF-16 encoded; save it as UTF-8 text",
                              path_, lineno_));
    const std::string_view tl = trim(line);
    if (tl.empty() || tl.front() == '#') return false;
    // Excel's separator directive ("sep=;") before the header
    if (first_ && tl.size() == 5 && tl.substr(0, 4) == "sep=") {
      const char c = tl[4];
      if (c != ',' && c != ';' && c != '\t' && c != ' ')
        throw Error(fmt::format("{}:{}: unsupported separator '{}' (use ',', ';', tab or ' ')", path_, lineno_,
                                shown(tl.substr(4))));
      if (sep_ != 0 && sep_ != c)
        throw Error(fmt::format("{}:{}: the file declares separator '{}', the options ask for '{}'", path_, lineno_,
                                shown(tl.substr(4)), shown({&sep_, 1})));
      sep_ = c;
      return false;
    }
    if (first_) return first_line(line);
    split(line, sep_, fields_);
    // the first line after a header whose units were joined (a units row or a data row) with a
    // field for each part as written: the header as written
    if (!split_names_.empty() && fields_.size() != nfields_ && fields_.size() == split_names_.size()) {
      names_ = std::move(split_names_);
      resize_columns(names_.size());
    }
    split_names_.clear();
    if (units_pending_) {
      units_pending_ = false;
      if (units_line()) return false;
    } else {
      units_refusal_.clear();  // said of the line after the header only
    }
    if (fields_.size() != nfields_) {
      if (fields_.size() > max_text_columns) too_many_columns();
      throw Error(fmt::format("{}:{}: row has {} fields, expected {} (as on line {}){}", path_, lineno_,
                              fields_.size(), nfields_, first_line_, units_refusal_));
    }
    for (std::size_t c = 0; c < nfields_; ++c) {
      double v = 0.0;
      switch (parse_field(fields_[c], v)) {
        case Parse::ok:
          if (filled_[c] != rows_) {
            throw Error(fmt::format("{}:{}:{}{}: empty field (the column has values on other lines)", path_,
                                    first_empty_line_[c], c + 1, column_label(names_, c)));
          }
          values_[c] = v;
          present_[c] = 1;
          ++filled_[c];
          break;
        case Parse::empty:
          if (filled_[c] != 0)
            throw Error(fmt::format("{}:{}:{}{}: empty field (the column has values on other lines)", path_, lineno_,
                                    c + 1, column_label(names_, c)));
          if (first_empty_line_[c] == 0) first_empty_line_[c] = lineno_;
          present_[c] = 0;
          break;
        case Parse::malformed:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is not a number{}{}", path_, lineno_, c + 1,
                                  column_label(names_, c), shown(fields_[c]),
                                  fields_[c].find(',') == std::string_view::npos
                                      ? ""
                                      : " (a decimal comma is read only when the first data row has one)",
                                  units_refusal_));
        case Parse::non_finite:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is not a finite number (NaN and infinity are refused){}",
                                  path_, lineno_, c + 1, column_label(names_, c), shown(fields_[c]),
                                  units_refusal_));
        case Parse::out_of_range:
          throw Error(fmt::format("{}:{}:{}{}: \"{}\" is out of the range of a double", path_, lineno_, c + 1,
                                  column_label(names_, c), shown(fields_[c])));
      }
    }
    ++rows_;
    return true;
  }

  // Throws if the file had no non-empty line.
  void finish() const {
    if (first_) throw Error(fmt::format("{}: no data (the file is empty)", path_));
  }

  std::size_t num_fields() const { return nfields_; }
  std::size_t rows() const { return rows_; }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<std::string>& units() const { return units_; }
  double value(std::size_t c) const { return values_[c]; }
  bool present(std::size_t c) const { return present_[c] != 0; }

 private:
  [[noreturn]] void too_many_columns() const {
    throw Error(fmt::format("{}:{}: more than {} fields (the limit of a text data file's columns)", path_, lineno_,
                            max_text_columns));
  }

  bool first_line(std::string_view line) {
    if (sep_ == 0) {
      if (line.find('\t') != std::string_view::npos) sep_ = '\t';
      else if (line.find(';') != std::string_view::npos) sep_ = ';';
      else if (line.find(',') != std::string_view::npos) sep_ = ',';
      else sep_ = ' ';
    }
    split(line, sep_, fields_);
    if (fields_.size() > max_text_columns) too_many_columns();
    nfields_ = fields_.size();
    first_line_ = lineno_;
    first_ = false;
    bool header = opt_.header == HeaderMode::present;
    if (opt_.header == HeaderMode::autodetect)
      header = std::any_of(fields_.begin(), fields_.end(), [&](std::string_view f) {
        double v = 0.0;
        return !looks_numeric(f) && !(sep_ != ',' && parse_comma(f, v) != Parse::malformed);
      });
    filled_.assign(nfields_, 0);
    first_empty_line_.assign(nfields_, 0);
    values_.assign(nfields_, 0.0);
    present_.assign(nfields_, 0);
    if (!header) {
      names_.assign(nfields_, std::string());
      return parse_again(line);
    }
    for (auto f : fields_) names_.emplace_back(unquote(f));
    if (sep_ == ' ') join_header_units();
    units_pending_ = true;
    return false;
  }

  // A blank-separated header splits a name from its unit ("t [s] p [kPa]": 4 fields for 2
  // columns): a field that is a bracketed unit alone is joined to the name before it (one without
  // a unit of its own). Should the next line (a units row or the first data row) have the
  // unjoined number of fields, the header is taken as written (split_names_).
  void join_header_units() {
    std::vector<std::string> joined;
    for (const std::string& n : names_) {
      const bool unit_alone = !n.empty() && (n.front() == '[' || n.front() == '(') && !trailing_unit("x " + n).empty();
      if (unit_alone && !joined.empty() && !joined.back().empty() && trailing_unit(joined.back()).empty())
        joined.back() += " " + n;
      else
        joined.push_back(n);
    }
    if (joined.size() == names_.size()) return;
    split_names_ = std::move(names_);
    names_ = std::move(joined);
    resize_columns(names_.size());
  }

  void resize_columns(std::size_t n) {
    nfields_ = n;
    filled_.assign(nfields_, 0);
    first_empty_line_.assign(nfields_, 0);
    values_.assign(nfields_, 0.0);
    present_.assign(nfields_, 0);
  }

  // The line after the header (in fields_) is a units row ("s,kPa,N", "[s];[bar];[mm]", "s,kPa,-")
  // if it has the header's number of fields, each of them a unit, a placeholder for a column
  // without one ("-", "NA", or empty) and none a number, at least one a unit, and it does not
  // repeat the header (a data row has only numbers and empty fields). Where a row with a unit in
  // it is not taken, units_refusal_ says why, for the data rows' error on that line.
  bool units_line() {
    units_refusal_.clear();
    std::size_t unit_fields = 0, numbers = 0, number_field = 0, other_field = 0;
    bool repeats_header = fields_.size() == nfields_;
    for (std::size_t c = 0; c < fields_.size(); ++c) {
      const std::string_view f = unquote(fields_[c]);
      double v = 0.0;
      if (f.empty() || is_placeholder(f)) {
      } else if (parse_field(fields_[c], v) != Parse::malformed) {
        if (number_field == 0) number_field = c + 1;
        ++numbers;
      } else if (looks_like_unit(f)) {
        ++unit_fields;
      } else if (other_field == 0) {
        other_field = c + 1;
      }
      repeats_header = repeats_header && f == names_[c];
    }
    // data (a malformed data row, mostly numbers, gets no word on units), placeholders only, the header again
    if (unit_fields == 0 || unit_fields <= numbers || repeats_header) return false;
    if (fields_.size() != nfields_) {
      units_refusal_ = fmt::format("; line {} is not read as a units row: it has {} fields, the header {}",
                                   lineno_, fields_.size(), nfields_);
      return false;
    }
    if (number_field != 0 || other_field != 0) {
      const std::size_t c = number_field != 0 ? number_field : other_field;
      units_refusal_ = fmt::format(
          "; line {} is not read as a units row: its field {} \"{}\" is {} (write \"-\" for a column without a unit)",
          lineno_, c, shown(unquote(fields_[c - 1])), number_field != 0 ? "a number" : "no unit");
      return false;
    }
    units_.clear();
    for (const std::string_view f : fields_) {
      const std::string_view u = unquote(f);
      units_.emplace_back(is_placeholder(u) ? std::string_view{} : u);
    }
    return true;
  }

  // A units row's field for a column without a unit.
  static bool is_placeholder(std::string_view f) {
    for (const std::string_view p : {"-", "--", "NA", "N/A", "n/a", "na", "null", "NULL", "none", "None"})
      if (f == p) return true;
    return false;
  }

  // A units row's field: a letter, '%' or a non-ASCII byte (µ, °) in it, and not a placeholder.
  static bool looks_like_unit(std::string_view f) {
    if (is_placeholder(f)) return false;
    return std::any_of(f.begin(), f.end(), [](char ch) {
      const auto u = static_cast<unsigned char>(ch);
      return std::isalpha(u) || ch == '%' || u >= 0x80;
    });
  }

  // A number with a decimal comma ("13,123"): parse_unquoted of the field with ',' read as '.'.
  static Parse parse_comma(std::string_view f, double& v) {
    if (f.find(',') == std::string_view::npos || f.size() > 128) return Parse::malformed;
    char tmp[128];
    std::copy(f.begin(), f.end(), tmp);
    std::replace(tmp, tmp + f.size(), ',', '.');
    return parse_unquoted({tmp, f.size()}, v);
  }
  // A field of a data row: a decimal comma is read in a file not separated by ',' whose first
  // data row has one (European spreadsheets: "13,123;8,18"); the whole file is then read so.
  Parse parse_field(std::string_view f, double& v) {
    const Parse p = parse_unquoted(f, v);
    if (p != Parse::malformed || sep_ == ',') return p;
    if (!decimal_comma_ && rows_ == 0 && parse_comma(f, v) != Parse::malformed) decimal_comma_ = true;
    return decimal_comma_ ? parse_comma(f, v) : p;
  }

  // The first line is a data row: parse it as one.
  bool parse_again(std::string_view line) {
    --lineno_;
    return parse(line);
  }

  const std::string& path_;
  const ReadOptions& opt_;
  char sep_;
  bool first_ = true, decimal_comma_ = false, units_pending_ = false;
  std::size_t nfields_ = 0, first_line_ = 0, rows_ = 0, lineno_ = 0;
  std::vector<std::string> names_, units_;  // units_: a units row's fields, else empty
  std::vector<std::string> split_names_;  // a blank-separated header as split, where its units were joined
  std::string units_refusal_;  // why the line after the header, with a unit in it, is no units row
  std::vector<std::string_view> fields_;
  std::vector<std::size_t> filled_, first_empty_line_;  // non-empty fields per column; first empty one's line
  std::vector<double> values_;
  std::vector<char> present_;
};

template <class Lines>
Table read_text_lines(Lines& lines, const std::string& path, const ReadOptions& opt) {
  TextParser parser(path, opt);
  std::vector<std::vector<double>> cols;
  std::string_view line;
  while (lines.next(line)) {
    if (!parser.parse(line)) continue;
    if (cols.size() != parser.num_fields()) cols.resize(parser.num_fields());
    for (std::size_t c = 0; c < cols.size(); ++c)
      if (parser.present(c)) cols[c].push_back(parser.value(c));
  }
  parser.finish();
  Table t;
  t.source = path;
  t.names = parser.names();
  t.units = parser.units();
  cols.resize(parser.num_fields());
  t.columns = std::move(cols);
  return t;
}

Table read_text_table(const std::string& path, const ReadOptions& opt) {
  FileLines lines(path);
  return read_text_lines(lines, path, opt);
}

// The column named `name` exactly (names.size() if none). A header may repeat a name (two
// "spare" columns, an export's duplicated labels): that is refused only where the name is
// selected, as it cannot tell which one is meant; the error counts columns from 0, as every other.
std::size_t find_named_column(const Table& t, std::string_view name) {
  const std::size_t n = t.names.size();
  for (std::size_t i = 0; i < n; ++i)
    if (t.names[i] == name) {
      for (std::size_t k = i + 1; k < n; ++k)
        if (t.names[k] == name)
          throw Error(fmt::format("{}: column name \"{}\" appears twice (columns {} and {}, counted from 0): choose "
                                  "one by its 0-based index, or rename one",
                                  t.source, shown(name), i, k));
      return i;
    }
  return n;
}

// The column ReadOptions selects in `t` (preferred_column included).
std::size_t select_column(const Table& t, const ReadOptions& opt) {
  if (opt.column_spec.empty() && !opt.preferred_column.empty()) {
    std::size_t nonempty = 0;
    for (const auto& c : t.columns) nonempty += c.empty() ? 0 : 1;
    if (nonempty != 1) {
      if (const std::size_t i = find_named_column(t, opt.preferred_column); i < t.names.size()) return i;
      // or the one column so named with a unit ("output [mm]")
      std::size_t found = t.names.size(), count = 0;
      for (std::size_t i = 0; i < t.names.size(); ++i)
        if (t.names[i] != column_quantity(t, i) && column_quantity(t, i) == opt.preferred_column) found = i, ++count;
      if (count == 1) return found;
    }
  }
  return t.column_index(opt.column_spec);
}

void write_all(int fd, const char* p, std::size_t n, const std::string& where) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw Error(fmt::format("{}: write failed: {}", where, std::strerror(errno)));
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

// Why a CSV column name cannot be written (empty string: it can).
bool usable_csv_name(const std::string& name) {
  return !name.empty() && name.find_first_of(",;\t\"\r\n") == std::string::npos && name == trim(name) &&
         !looks_numeric(name);
}

void check_csv_names(const std::string& path, const std::vector<std::string>& names) {
  if (names.empty()) throw Error(fmt::format("{}: no columns to write", path));
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (!usable_csv_name(names[i]))
      throw Error(fmt::format("{}: \"{}\" is not a usable CSV column name (non-empty, not a number, no separators, "
                              "quotes or surrounding blanks)",
                              path, names[i]));
    for (std::size_t k = 0; k < i; ++k)
      if (names[k] == names[i]) throw Error(fmt::format("{}: column name \"{}\" given twice", path, names[i]));
  }
}

// An empty column (in every row) or a column of no data: the error Table::column gives.
void check_column_has_data(const Table& t, std::size_t i) {
  if (!t.columns[i].empty()) return;
  const std::string name =
      i < t.names.size() && !t.names[i].empty() ? fmt::format(" \"{}\"", shown(t.names[i])) : std::string();
  if (t.num_rows() > 0) throw Error(fmt::format("{}: column {}{} is empty in every row", t.source, i, name));
  throw Error(fmt::format("{}: column {} has no data", t.source, i));
}

}  // namespace

// ---- Table ---------------------------------------------------------------------

std::size_t Table::num_rows() const noexcept {
  std::size_t n = 0;
  for (const auto& c : columns) n = std::max(n, c.size());
  return n;
}

std::size_t Table::column_index(std::string_view spec) const {
  // the columns for a message: at most 20 named, then how many more (a wide file must not give
  // a message of megabytes)
  auto describe = [&] {
    std::string s;
    const std::size_t shown_max = 20;
    for (std::size_t i = 0; i < columns.size() && i < shown_max; ++i) {
      if (!s.empty()) s += ", ";
      s += std::to_string(i);
      if (i < names.size() && !names[i].empty()) s += fmt::format(" \"{}\"", shown(names[i]));
      if (columns[i].empty()) s += " (empty)";
    }
    if (columns.size() > shown_max) s += fmt::format(", ... ({} more)", columns.size() - shown_max);
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
  if (const std::size_t i = find_named_column(*this, spec); i < names.size()) return i;
  std::size_t idx = 0;
  const auto res = std::from_chars(spec.data(), spec.data() + spec.size(), idx);
  if (res.ec == std::errc() && res.ptr == spec.data() + spec.size()) {
    if (idx >= columns.size())
      throw Error(fmt::format("{}: column index {} is out of range; the file has {} columns: {}", source, idx,
                              columns.size(), describe()));
    return idx;
  }
  // the name without its unit: "pressure" selects "pressure [kPa]" if no other column is "pressure [...]"
  {
    std::size_t found = names.size(), count = 0;
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] != column_quantity(*this, i) && column_quantity(*this, i) == spec) {
        found = i;
        ++count;
      }
    if (count == 1) return found;
    if (count > 1)
      throw Error(fmt::format("{}: {} columns are named \"{}\" with a unit; choose one by its whole name or its "
                              "0-based index; columns are: {}",
                              source, count, spec, describe()));
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
  check_column_has_data(*this, i);
  return columns[i];
}

Table parse_text_table(std::string_view text, const std::string& source, const ReadOptions& options) {
  MemoryLines lines(text, source);
  return read_text_lines(lines, source, options);
}

Table read_table(const std::string& path, const ReadOptions& options) {
  if (!is_mat_path(path)) return read_text_table(path, options);
  return detail::read_mat_table(path);
}

std::vector<double> read_column(const std::string& path, const ReadOptions& options) {
  return read_named_column(path, options).values;
}

std::string column_unit(const Table& t, std::size_t i) {
  if (i < t.units.size() && !trim(t.units[i]).empty()) return strip_unit_brackets(t.units[i]);
  if (i >= t.names.size()) return std::string();
  return trailing_unit(t.names[i]);
}

std::string column_quantity(const Table& t, std::size_t i) {
  return i < t.names.size() ? without_unit(t.names[i]) : std::string();
}

NamedColumn read_named_column(const std::string& path, const ReadOptions& options) {
  NamedColumn c;
  if (is_mat_path(path)) {
    c.values = detail::read_mat_variable(path, options.column_spec, options.preferred_column);
    c.name = options.column_spec;
    return c;
  }
  Table t = read_text_table(path, options);
  const std::size_t i = select_column(t, options);
  check_column_has_data(t, i);
  c.name = column_quantity(t, i);
  c.unit = column_unit(t, i);
  c.index = i;
  c.values = std::move(t.columns[i]);
  return c;
}

std::vector<double> read_column(const std::string& path, const std::string& column) {
  ReadOptions o;
  o.column_spec = column;
  return read_column(path, o);
}

void for_each_value(const std::string& path, const ReadOptions& options, const std::function<void(double)>& on_value,
                    const std::function<void(const NamedColumn&)>& on_column) {
  if (is_mat_path(path)) {
    NamedColumn c = read_named_column(path, options);
    if (on_column) on_column({{}, c.name, c.unit, NamedColumn::npos});
    for (const double v : c.values) on_value(v);
    return;
  }
  FileLines lines(path);
  TextParser parser(path, options);
  // The column is chosen at the first data row: a column empty there is empty in every row
  // (else the parser stops at the first row that has a value in it).
  auto choose = [&] {
    Table probe;
    probe.source = path;
    probe.names = parser.names();
    probe.columns.resize(parser.num_fields());
    for (std::size_t c = 0; c < probe.columns.size() && parser.rows() > 0; ++c)
      if (parser.present(c)) probe.columns[c].push_back(parser.value(c));
    const std::size_t i = select_column(probe, options);
    check_column_has_data(probe, i);
    if (on_column) {
      probe.units = parser.units();
      on_column({{}, column_quantity(probe, i), column_unit(probe, i), i});
    }
    return i;
  };
  constexpr std::size_t none = static_cast<std::size_t>(-1);
  std::size_t col = none;
  std::string_view line;
  while (lines.next(line)) {
    if (!parser.parse(line)) continue;
    if (col == none) col = choose();
    on_value(parser.value(col));
  }
  parser.finish();
  if (col == none) choose();  // no data row: the error of read_column
}

void write_columns(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<std::vector<double>>& columns, const WriteOptions& options) {
  const bool mat = path != "-" && is_mat_path(path);
  if (names.size() != columns.size())
    throw Error(fmt::format("{}: {} column names for {} columns", path, names.size(), columns.size()));
  if (columns.empty()) throw Error(fmt::format("{}: no columns to write", path));
  if (!mat) check_csv_names(path, names);
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (mat && !detail::is_matlab_identifier(names[i]))
      throw Error(fmt::format("{}: \"{}\" is not a valid MATLAB variable name (a letter, then letters, digits, _)",
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
    write_csv_rows(path, names, [&](CsvRowWriter& w) {
      std::vector<double> row(columns.size());
      for (std::size_t r = 0; r < columns[0].size(); ++r) {
        for (std::size_t c = 0; c < columns.size(); ++c) row[c] = columns[c][r];
        w.row(row);
      }
    });
    return;
  }
  write_file_atomically(path, [&](const std::string& tmp) { detail::write_mat(tmp, names, columns, options.compress_mat); });
}

// ---- streamed CSV output -----------------------------------------------------------

namespace {
constexpr std::size_t kCsvNumberMax = 32;  // std::to_chars of a double: at most 24 characters
}

CsvRowWriter::CsvRowWriter(int fd, std::string where, std::vector<std::string> names)
    : fd_(fd), where_(std::move(where)), names_(std::move(names)) {
  std::string header;
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (i) header += ',';
    header += names_[i];
  }
  header += '\n';
  write_all(fd_, header.data(), header.size(), where_);
  buf_.reset(new char[capacity()]);
}

CsvRowWriter::~CsvRowWriter() = default;

std::size_t CsvRowWriter::capacity() const noexcept {
  return std::max<std::size_t>(std::size_t{1} << 20, names_.size() * (kCsvNumberMax + 1) * 2);
}

void CsvRowWriter::row(std::span<const double> values) {
  if (values.size() != names_.size())
    throw Error(fmt::format("{}: a row of {} values for {} columns", where_, values.size(), names_.size()));
  if (capacity() - used_ < values.size() * (kCsvNumberMax + 1) + 1) flush();
  char* p = buf_.get() + used_;
  for (std::size_t c = 0; c < values.size(); ++c) {
    if (!std::isfinite(values[c]))
      throw Error(fmt::format("{}: column \"{}\" row {} is not finite ({})", where_, names_[c], rows_, values[c]));
    if (c) *p++ = ',';
    p = std::to_chars(p, p + kCsvNumberMax, values[c]).ptr;
  }
  *p++ = '\n';
  used_ = static_cast<std::size_t>(p - buf_.get());
  ++rows_;
}

void CsvRowWriter::flush() {
  write_all(fd_, buf_.get(), used_, where_);
  used_ = 0;
}

void write_csv_rows(const std::string& path, const std::vector<std::string>& names,
                    const std::function<void(CsvRowWriter&)>& fill) {
  check_csv_names(path, names);
  // an error of fill (e.g. a bad line of the input being streamed) is passed on as it is, not
  // renamed after the output file
  std::exception_ptr fill_error;
  try {
    write_file_atomically(path, [&](const std::string& target) {
    const bool to_stdout = target == "/dev/stdout";
    int fd = STDOUT_FILENO;
    if (to_stdout) {
      if (std::fflush(stdout) != 0) throw Error("writing to stdout failed");
    } else {
      fd = ::open(target.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
      if (fd < 0) throw Error(fmt::format("cannot open for writing: {}", std::strerror(errno)));
    }
    struct Closer {
      int fd;
      ~Closer() {
        if (fd >= 0) ::close(fd);
      }
    } closer{to_stdout ? -1 : fd};
    CsvRowWriter w(fd, to_stdout ? std::string("stdout") : path, names);
    try {
      fill(w);
    } catch (...) {
      fill_error = std::current_exception();
      throw Error("stopped");
    }
    w.flush();
    closer.fd = -1;
    if (!to_stdout && ::close(fd) != 0) throw Error(fmt::format("write failed: {}", std::strerror(errno)));
    });
  } catch (...) {
    if (fill_error) std::rethrow_exception(fill_error);
    throw;
  }
}

}  // namespace hysteron::io
