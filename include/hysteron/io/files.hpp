#pragma once
// Writing output files safely (issue 13): atomic replacement of regular files,
// direct writes to devices and FIFOs, the temporary files of interrupted writes
// removed by a signal handler, and outputs checked against inputs. Used by the
// data tables (table.hpp), model files (model_file.hpp) and every result writer.
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hysteron::io {

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
// Files replaced together (ExperimentResult::write): while a FileBatch is alive on a thread,
// write_file_atomically on that thread fills and flushes each regular file's temporary file as
// above but does not move it into place; commit() then does, for all of them in the order they
// were written (renames; the copies into files with hard links). Destroyed without commit()
// (an error while writing one of them), it removes every temporary file: none of the paths has
// changed. Devices, FIFOs and stdout are written directly, as without a batch. A commit that
// fails part way (a rename refused) throws Error naming the file; the files before it are
// replaced, the rest not. Batches do not nest (a second one on the same thread throws).
class FileBatch {
 public:
  FileBatch();
  ~FileBatch();
  FileBatch(const FileBatch&) = delete;
  FileBatch& operator=(const FileBatch&) = delete;
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// write_file_atomically with a text body; path "-" writes to stdout.
void write_text_file(const std::string& path, std::string_view text);

// Removes the temporary files of the writes in progress (every one, however many a FileBatch
// holds) and the paths registered by live TemporaryPath objects: files first, then directories
// (rmdir: those left empty). Async-signal-safe (no allocation, no lock; unlink(2) and rmdir(2)
// only): meant for a program's signal handler, which should then restore the default action and
// re-raise the signal. The library installs no handler itself (a host program such as Python
// keeps its own).
void remove_temporary_files() noexcept;

// A temporary file or directory of the program's own (e.g. the plots' gnuplot directory), removed
// by remove_temporary_files() while this object lives; the destructor only unregisters it (its
// owner removes it). Register a directory before the files in it.
class TemporaryPath {
 public:
  explicit TemporaryPath(const std::string& path, bool directory = false);
  ~TemporaryPath();
  TemporaryPath(const TemporaryPath&) = delete;
  TemporaryPath& operator=(const TemporaryPath&) = delete;

 private:
  void* node_;
};

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
// Before a long computation whose result goes to a file (an experiment's report, a sweep's
// table): throws hysteron::Error naming the option and the path if it could not be written
// there, because it is a directory or its directory does not exist or is not writable.
// Writes nothing. Empty paths and "-" pass.
void check_output_file(const NamedPath& output);
// Whether a report path names an HTML page (ends in .html or .htm, any case): the CLI's --report
// and Python's fit(report=) write HTML there and JSON elsewhere (Python refuses the rest).
bool is_html_path(std::string_view path);
// The same for an output directory its writer creates (ExperimentResult::write, with its
// parents): the directory, or its nearest existing ancestor, must be a writable directory.
void check_output_directory(const NamedPath& output);
// check_outputs_distinct, then check_output_file on each output: what a command that writes
// files calls before it reads its inputs or computes anything.
void check_output_files(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

}  // namespace hysteron::io
