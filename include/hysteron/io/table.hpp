#pragma once
// Numeric data tables: CSV-like text files and MATLAB .mat files (via matio).
//
// Text files (any extension but .mat):
//  - optional header: the first non-empty line is a header if any of its fields
//    is not a number ("nan"/"inf" count as numbers, and are then refused);
//  - one separator per file, detected from the first non-empty line: tab if it
//    has one, else ';', else ',', else runs of blanks;
//  - a UTF-8 BOM, CRLF line endings, blank lines and lines starting with '#' are
//    ignored; fields are trimmed of blanks and of one pair of double quotes;
//  - a column that is empty in every row (e.g. the leading "," of every line)
//    is allowed and reads as empty; selecting it is an error; any other empty
//    field is an error;
//  - NaN, infinity, out-of-range and malformed numbers are refused with
//    "file:line:column (column "name"): ..." (line 1-based, column = 1-based
//    field number); rows with a different number of fields name their line.
// .mat files (extension .mat, any case): a column is a variable: a real numeric
// vector (1xN or Nx1) of class double, single or any integer class, or one column of
// such a 2-D matrix, named NAME:INDEX (INDEX 0-based, as CSV column indices; rows are
// samples): "data:2" is MATLAB's data(:,3). An N x 1 or 1 x N matrix is a vector ("v" or
// "v:0"). A variable named exactly like the spec wins over the NAME:INDEX reading.
// Errors name the file and variable: a missing variable (listing the file's variables),
// an index out of range (with the matrix size), a matrix named without an index, and
// sparse, complex, non-numeric (char, cell, struct, ...) and N-D (rank > 2) variables.
// In text files a colon has no special meaning: "a:b" is a header name (a header match
// always wins; an index is a plain 0-based number).
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace hysteron::io {

enum class HeaderMode { autodetect, present, absent };

struct ReadOptions {
  // Column to read: a header name (or .mat variable name, or NAME:INDEX for column
  // INDEX, 0-based, of a .mat matrix), else a 0-based index.
  // Empty: the file's only non-empty column (an error if it has several).
  std::string column_spec;
  // Field separator: 0 = autodetect, else ',', ';', '\t' or ' ' (runs of blanks).
  char separator = 0;
  HeaderMode header = HeaderMode::autodetect;
};

// All columns of a file. columns[i] has num_rows() values, or none if the
// column is empty in every row.
struct Table {
  std::string source;                         // file path, for messages
  std::vector<std::string> names;             // header names (or .mat variables); "" if no header
  std::vector<std::vector<double>> columns;

  std::size_t num_columns() const noexcept { return columns.size(); }
  std::size_t num_rows() const noexcept;
  // Index of a column by name, else by 0-based index; empty spec = the only
  // non-empty column. Throws hysteron::Error listing the columns that exist.
  std::size_t column_index(std::string_view spec) const;
  // The column's values; throws hysteron::Error as column_index() does, and if
  // the column is empty in every row.
  const std::vector<double>& column(std::string_view spec) const;
};

// Reads a whole text table (or every numeric vector variable of a .mat file,
// which must then all have the same length, followed by the columns "NAME:0",
// "NAME:1", ... of each 2-D matrix with that many rows; other matrices, and variables
// that are not real numeric or hold NaN/infinity, are left out). Throws hysteron::Error.
Table read_table(const std::string& path, const ReadOptions& options = {});

// One column of a text file or one variable (or matrix column NAME:INDEX) of a .mat
// file (options.column_spec; empty = the file's only variable, which must be a vector).
std::vector<double> read_column(const std::string& path, const ReadOptions& options);
std::vector<double> read_column(const std::string& path, const std::string& column);

// Writes equal-length columns with a header line of `names` as CSV (values
// printed with %.17g, so they read back exactly) or, for a .mat path, as Nx1
// double variables (MAT v5, compressed; names must be MATLAB identifiers).
// Atomic: see write_file_atomically. Path "-" writes CSV to stdout.
// Non-finite values, unequal lengths and bad names are refused before any file
// is created.
void write_columns(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<std::vector<double>>& columns);

// Writes `path` through write(file), which fills the file it is given:
//  - a new path or an existing regular file: a new temporary file ".NAME.tmp-..." in the
//    same directory is filled, flushed to disk, then renamed over `path` (atomic: readers see
//    the old or the new file, never a torn one). The existing file's permission bits (and, as
//    root, its owner) are kept. A symbolic link is followed: its target is replaced, the link
//    stays. A file without any write permission bit (e.g. mode 444), or one the caller cannot
//    write, is refused and left untouched. A file with several hard links (st_nlink > 1) keeps
//    them: once the temporary file is complete, its content is copied into the same inode;
//    that copy is NOT atomic (a crash during it leaves a partly written file).
//  - "-": write("/dev/stdout"); an existing device, FIFO or socket (/dev/null, /dev/stdout, a
//    named pipe): written directly, never replaced.
// If write throws or any write, flush or close fails, the temporary file is removed, `path` is
// left as it was and a hysteron::Error naming `path` is thrown. Temporary files alive when the
// process is killed by a signal are removed by remove_temporary_files(), if the program's
// handler calls it (the hysteron CLI does, for SIGINT, SIGTERM and SIGHUP).
void write_file_atomically(const std::string& path, const std::function<void(const std::string& temp_path)>& write);
// write_file_atomically with a text body; path "-" writes to stdout.
void write_text_file(const std::string& path, std::string_view text);

// Removes the temporary files of the writes in progress (at most 64 at once are tracked).
// Async-signal-safe (no allocation, unlink(2) only): meant for a program's signal handler,
// which should then restore the default action and re-raise the signal. The library installs
// no handler itself (a host program such as Python keeps its own).
void remove_temporary_files() noexcept;

// A file named on the command line and the option that named it, e.g. {"--out", "m.json"}.
struct NamedPath {
  std::string option;
  std::string path;
};
// Throws hysteron::Error naming both options and files if an output is the same file as an
// input (same device and inode: through symbolic and hard links), or if two outputs are the
// same file (an existing one, or the same new path). Empty paths, "-" and non-regular files
// (devices, FIFOs) are never "the same file". Call it before reading any input.
void check_outputs_distinct(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

}  // namespace hysteron::io
