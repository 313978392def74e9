#pragma once
// Numeric data tables: CSV-like text files and MATLAB .mat files (via matio).
//
// Text files (any extension but .mat):
//  - optional header: the first non-empty line is a header if any of its fields
//    is not a number ("nan"/"inf" count as numbers, and are then refused);
//  - one separator per file, detected from the first non-empty line: tab if it
//    has one, else ';', else ',', else runs of blanks;
//  - a units row may follow the header: a line with the header's number of fields, each a unit or
//    a placeholder for a column without one ("-", "NA", empty), none a number, at least one a unit,
//    and not the header repeated ("s,kPa,N", "[s];[bar];[mm]", "s,-,N"); it gives the columns'
//    units (column_unit), as does a header name ending in "[unit]" or "(unit)". A line after the
//    header with more units than numbers that is no units row is an error that says why;
//  - a UTF-8 BOM, blank lines and lines starting with '#' are ignored; lines end with
//    LF, CRLF or a lone CR; fields are trimmed of blanks and of one pair of double quotes;
//  - a column that is empty in every row (e.g. the leading "," of every line)
//    is allowed and reads as empty; selecting it is an error; any other empty
//    field is an error;
//  - NaN, infinity, out-of-range and malformed numbers are refused with
//    "file:line:column (column "name"): ..." (line 1-based, column = 1-based
//    field number); rows with a different number of fields name their line;
//  - at most max_text_columns fields per line and max_text_line_bytes bytes per line
//    (errors name the line); a file is read in chunks, never held whole.
// .mat files (extension .mat, any case): a column is a variable: a real numeric
// vector (1xN or Nx1) of class double, single or any integer class, or one column of
// such a 2-D matrix, named NAME:INDEX (INDEX 0-based, as CSV column indices; rows are
// samples): "data:2" is MATLAB's data(:,3). An N x 1 or 1 x N matrix is a vector ("v" or
// "v:0"). A variable named exactly like the spec wins over the NAME:INDEX reading.
// Errors name the file and variable: a missing variable (listing the file's variables),
// an index out of range (with the matrix size), a matrix named without an index, and
// sparse, complex, non-numeric (char, cell, struct, ...) and N-D (rank > 2) variables.
// MAT v7.3 (HDF5) files are read through matio (Debian's is built with HDF5) like v5 files; one
// whose HDF5 data is missing or shorter than its superblock declares is an error naming the file,
// and one with a dataset declaring more than the bytes stored for it (unwritten data or chunks,
// more than zlib's 1032:1 from its deflate data) an error naming the file and the variable,
// before matio allocates (HDF5's own metadata is left to HDF5).
// In text files a colon has no special meaning: "a:b" is a header name (a header match
// always wins; an index is a plain 0-based number).
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hysteron/io/files.hpp"  // write_file_atomically, write_text_file, check_outputs_distinct
#include "hysteron/io/units.hpp"  // canonical_unit, trailing_unit, ... (units as text)

namespace hysteron::io {

// Caps of a text data file (hostile or binary input gives a clear error, not a huge allocation).
inline constexpr std::size_t max_text_columns = 10000;
inline constexpr std::size_t max_text_line_bytes = std::size_t{1} << 20;  // 1 MiB

enum class HeaderMode { autodetect, present, absent };

struct ReadOptions {
  // Column to read: a header name (or .mat variable name, or NAME:INDEX for column
  // INDEX, 0-based, of a .mat matrix), else a 0-based index.
  // Empty: the file's only non-empty column (an error if it has several).
  std::string column_spec;
  // Field separator: 0 = autodetect, else ',', ';', '\t' or ' ' (runs of blanks).
  char separator = 0;
  HeaderMode header = HeaderMode::autodetect;
  // With an empty column_spec and a file of several non-empty columns (a .mat file of several
  // variables): the column with this header name (the variable of this name), if there is one
  // (e.g. "input" for `hysteron simulate`); if none has it, the error of an empty column_spec.
  std::string preferred_column;
};

// All columns of a file. columns[i] has num_rows() values, or none if the
// column is empty in every row.
struct Table {
  std::string source;                         // file path, for messages
  std::vector<std::string> names;             // header names (or .mat variables); "" if no header
  std::vector<std::string> units;             // a units row's fields; empty if the file has none
  std::vector<std::vector<double>> columns;

  std::size_t num_columns() const noexcept { return columns.size(); }
  std::size_t num_rows() const noexcept;
  // Index of a column by name, else by its name without a unit ("pressure" for a column
  // "pressure [kPa]", if only one has it), else by 0-based index; empty spec = the only
  // non-empty column. Throws hysteron::Error listing the columns that exist.
  std::size_t column_index(std::string_view spec) const;
  // The column's values; throws hysteron::Error as column_index() does, and if
  // the column is empty in every row.
  const std::vector<double>& column(std::string_view spec) const;
};

// Column i's unit: its units-row field, else trailing_unit of its header name; brackets are
// stripped ("[kPa]" -> "kPa"). "" if it has none.
std::string column_unit(const Table& t, std::size_t i);
// Column i's header name without_unit ("pressure [kPa]" -> "pressure").
std::string column_quantity(const Table& t, std::size_t i);

// A text table held in memory (the rules above); `source` names it in errors.
Table parse_text_table(std::string_view text, const std::string& source, const ReadOptions& options = {});

// Reads a whole text table (or every numeric vector variable of a .mat file,
// which must then all have the same length, followed by the columns "NAME:0",
// "NAME:1", ... of each 2-D matrix with that many rows; other matrices, and variables
// that are not real numeric or hold NaN/infinity, are left out). Throws hysteron::Error.
Table read_table(const std::string& path, const ReadOptions& options = {});

// One column of a text file or one variable (or matrix column NAME:INDEX) of a .mat
// file (options.column_spec; empty = the file's only variable, which must be a vector).
std::vector<double> read_column(const std::string& path, const ReadOptions& options);
std::vector<double> read_column(const std::string& path, const std::string& column);
// The same column with its header name and unit (column_quantity, column_unit; a .mat variable:
// the spec, no unit).
struct NamedColumn {
  std::vector<double> values;
  std::string name, unit;
  // the column's 0-based index in a text file; npos for a .mat variable (name is its selector)
  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
  std::size_t index = npos;
  // Whether a and b are one column of one file (read from it by read_named_column).
  static bool same(const NamedColumn& a, const NamedColumn& b) {
    return a.index != npos ? a.index == b.index : b.index == npos && a.name == b.name;
  }
};
NamedColumn read_named_column(const std::string& path, const ReadOptions& options);

// Streams one column (selected as read_column does, preferred_column included) of a text file:
// on_value(v) for each row in order, in bounded memory (the file is read in chunks). The whole
// file is checked as read_column checks it, so an error can come after earlier values were
// delivered. A .mat file is read whole, then delivered the same way.
// on_column (if given) is called once with the chosen column's name and unit (no values), before
// the first value: a caller can refuse the column there, before any value was delivered.
void for_each_value(const std::string& path, const ReadOptions& options, const std::function<void(double)>& on_value,
                    const std::function<void(const NamedColumn&)>& on_column = {});

struct WriteOptions {
  bool compress_mat = false;  // .mat: zlib-compressed variables (smaller, several times slower)
};

// Writes equal-length columns with a header line of `names` as CSV (values in the shortest
// form that reads back exactly, std::to_chars) or, for a .mat path, as Nx1 double variables
// (MAT v5, uncompressed unless options.compress_mat; names must be MATLAB identifiers).
// Atomic: see write_file_atomically. Path "-" writes CSV to stdout.
// Non-finite values, unequal lengths and bad names are refused before any file
// is created.
void write_columns(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<std::vector<double>>& columns, const WriteOptions& options = {});

// CSV rows written through a fixed buffer (no allocation per row), numbers as write_columns
// writes them. Made by write_csv_rows.
class CsvRowWriter {
 public:
  // One row of names().size() values; a non-finite value is an error naming its column and row.
  void row(std::span<const double> values);
  std::size_t rows() const noexcept { return rows_; }
  ~CsvRowWriter();
  CsvRowWriter(const CsvRowWriter&) = delete;
  CsvRowWriter& operator=(const CsvRowWriter&) = delete;

 private:
  friend void write_csv_rows(const std::string&, const std::vector<std::string>&,
                             const std::function<void(CsvRowWriter&)>&);
  CsvRowWriter(int fd, std::string where, std::vector<std::string> names);
  void flush();
  std::size_t capacity() const noexcept;
  int fd_;
  std::string where_;
  std::vector<std::string> names_;
  std::unique_ptr<char[]> buf_;
  std::size_t used_ = 0, rows_ = 0;
};

// Writes a CSV file (header `names`) whose rows fill(writer) produces, atomically as
// write_columns does (path "-": stdout). If fill throws, nothing is left at `path` (a regular
// file keeps its old content; a device or FIFO may have received part of the rows).
void write_csv_rows(const std::string& path, const std::vector<std::string>& names,
                    const std::function<void(CsvRowWriter&)>& fill);

}  // namespace hysteron::io
