// Output files (files.hpp): atomic replacement of regular files, direct writes to
// devices and FIFOs, temporary files removed on signals, and the same-file check of
// outputs against inputs. No matio here: the model-file writer (and so the C ABI)
// needs these without the data-table code.
#include "hysteron/io/files.hpp"

#include <cctype>
#include <algorithm>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "hysteron/error.hpp"

namespace hysteron::io {

namespace {

namespace fs = std::filesystem;

void write_all(int fd, std::string_view text, const std::string& where) {
  while (!text.empty()) {
    const ssize_t w = ::write(fd, text.data(), text.size());
    if (w < 0) {
      if (errno == EINTR) continue;
      throw Error(fmt::format("{}: write failed: {}", where, std::strerror(errno)));
    }
    text.remove_prefix(static_cast<std::size_t>(w));
  }
}

std::atomic<unsigned> temp_counter{0};

}  // namespace

// ---- writing --------------------------------------------------------------------

namespace {

// Temporary files and directories, for remove_temporary_files() (called from signal handlers):
// a singly linked list of nodes that only grows (nodes are allocated here, never in the handler,
// and reused once free), so a batch of any size is tracked. A node's path is a heap copy
// published through an atomic pointer; unregistering takes the pointer back and frees it unless a
// handler is walking the list (then it is left: the process is about to die). seq_cst throughout:
// a handler that counted itself in before unregister_temp read the count may still read the path;
// one that counted itself in after sees the pointer already taken.
struct TempNode {
  std::atomic<const char*> path{nullptr};
  std::atomic<bool> claimed{true};
  std::atomic<bool> directory{false};
  TempNode* next = nullptr;  // set before the node is published, never changed
};
std::atomic<TempNode*> g_temp_head{nullptr};
std::atomic<int> g_temp_handlers{0};  // remove_temporary_files() calls in progress
static_assert(std::atomic<const char*>::is_always_lock_free && std::atomic<TempNode*>::is_always_lock_free &&
              std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free);

TempNode* register_temp(const std::string& p, bool directory = false) {
  char* copy = new char[p.size() + 1];
  std::memcpy(copy, p.c_str(), p.size() + 1);
  TempNode* node = nullptr;
  for (TempNode* n = g_temp_head.load(); n != nullptr && node == nullptr; n = n->next) {
    bool expected = false;
    if (n->claimed.compare_exchange_strong(expected, true)) node = n;
  }
  if (node == nullptr) {
    node = new TempNode;
    TempNode* head = g_temp_head.load();
    do node->next = head;
    while (!g_temp_head.compare_exchange_weak(head, node));
  }
  node->directory.store(directory);
  node->path.store(copy);
  return node;
}

void unregister_temp(TempNode* node) {
  if (node == nullptr) return;
  const char* p = node->path.exchange(nullptr);
  if (g_temp_handlers.load() == 0) delete[] p;
  node->claimed.store(false);
}

// A live temporary file: removed (and unregistered) unless released after the rename.
class TempFile {
 public:
  explicit TempFile(std::string p) : path_(std::move(p)), node_(register_temp(path_)) {}
  ~TempFile() {
    if (!path_.empty()) ::unlink(path_.c_str());
    unregister_temp(node_);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }
  void release() {
    unregister_temp(node_);
    node_ = nullptr;
    path_.clear();
  }

 private:
  std::string path_;
  TempNode* node_;
};

// Follows symbolic links (a chain of at most 40) to the file they name; the last target may not exist.
std::string resolve_symlinks(const std::string& path) {
  fs::path p(path);
  for (int hops = 0;; ++hops) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p.string();
    if (hops >= 40) throw Error(fmt::format("{}: too many levels of symbolic links", path));
    std::error_code ec;
    fs::path target = fs::read_symlink(p, ec);
    if (ec) throw Error(fmt::format("{}: cannot read the symbolic link: {}", path, ec.message()));
    p = target.is_absolute() ? target : (p.has_parent_path() ? p.parent_path() / target : target);
  }
}

void fsync_path(const std::string& p, const std::string& where) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(fmt::format("{}: cannot reopen the temporary file: {}", where, std::strerror(errno)));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0 && err != EINVAL && err != EROFS) throw Error(fmt::format("{}: write failed: {}", where, std::strerror(err)));
}

// Copies the finished temporary file into the existing inode of `target` (kept hard links).
void copy_into(const std::string& tmp, const std::string& target, const std::string& where) {
  const int in = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) throw Error(fmt::format("{}: cannot reopen the temporary file: {}", where, std::strerror(errno)));
  const int out = ::open(target.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (out < 0) {
    const int err = errno;
    ::close(in);
    throw Error(fmt::format("{}: cannot open for writing: {}", where, std::strerror(err)));
  }
  std::vector<char> buf(1 << 16);
  try {
    for (;;) {
      const ssize_t r = ::read(in, buf.data(), buf.size());
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) throw Error(fmt::format("{}: cannot read the temporary file: {}", where, std::strerror(errno)));
      if (r == 0) break;
      write_all(out, std::string_view(buf.data(), static_cast<std::size_t>(r)), where);
    }
    if (::fsync(out) != 0 && errno != EINVAL) throw Error(fmt::format("{}: write failed: {}", where, std::strerror(errno)));
  } catch (...) {
    ::close(in);
    ::close(out);
    throw;
  }
  ::close(in);
  if (::close(out) != 0) throw Error(fmt::format("{}: write failed: {}", where, std::strerror(errno)));
}

[[noreturn]] void rethrow_named(const std::string& path) {
  try {
    throw;
  } catch (const Error& e) {
    const std::string msg = e.what();
    if (msg.rfind(path, 0) == 0) throw;
    throw Error(fmt::format("{}: {}", path, msg));
  }
}

}  // namespace

// ---- batches (FileBatch) -----------------------------------------------------------

namespace {
// A complete, flushed temporary file waiting for FileBatch::commit().
struct PendingFile {
  std::unique_ptr<TempFile> tmp;
  std::string real;  // the file to replace (symbolic links resolved)
  std::string path;  // as given, for messages
  bool hard_links = false;
};

// The pending files of the thread's open batch (FileBatch::Impl owns them).
thread_local std::vector<PendingFile>* t_batch = nullptr;
}  // namespace

struct FileBatch::Impl {
  std::vector<PendingFile> pending;
};

namespace {

// Moves a complete temporary file into place (see write_file_atomically).
void commit_file(PendingFile& f) {
  if (f.hard_links) {
    copy_into(f.tmp->path(), f.real, f.path);  // the inode kept (not atomic)
    f.tmp.reset();                             // removes the temporary file
    return;
  }
  if (std::rename(f.tmp->path().c_str(), f.real.c_str()) != 0)
    throw Error(fmt::format("{}: cannot rename the temporary file into place: {}", f.path, std::strerror(errno)));
  f.tmp->release();
}
}  // namespace

FileBatch::FileBatch() : impl_(std::make_unique<Impl>()) {
  if (t_batch != nullptr) throw Error("FileBatch: a batch is already open on this thread");
  t_batch = &impl_->pending;
}

FileBatch::~FileBatch() {
  if (t_batch == &impl_->pending) t_batch = nullptr;
  // impl_'s pending temporary files are removed by their TempFile
}

void FileBatch::commit() {
  if (t_batch == &impl_->pending) t_batch = nullptr;
  for (PendingFile& f : impl_->pending) commit_file(f);
  impl_->pending.clear();
}

void remove_temporary_files() noexcept {
  g_temp_handlers.fetch_add(1);
  for (const bool directories : {false, true})  // the files, then the directories they were in
    for (TempNode* n = g_temp_head.load(); n != nullptr; n = n->next)
      // path before directory: register_temp stores directory then path, so a path seen here comes
      // with its own kind (a reused node is never skipped as the other kind)
      if (const char* p = n->path.load(); p != nullptr && n->directory.load() == directories)
        directories ? ::rmdir(p) : ::unlink(p);
  g_temp_handlers.fetch_sub(1);
}

TemporaryPath::TemporaryPath(const std::string& path, bool directory) : node_(register_temp(path, directory)) {}

TemporaryPath::~TemporaryPath() { unregister_temp(static_cast<TempNode*>(node_)); }

void write_file_atomically(const std::string& path, const std::function<void(const std::string& temp_path)>& write) {
  if (path.empty()) throw Error("output path is empty");
  if (path == "-") {  // standard output: written directly
    write("/dev/stdout");
    return;
  }
  if (path == "/dev/stdout" || path == "/dev/stderr" || path.starts_with("/dev/fd/") ||
      path.starts_with("/proc/self/fd/")) {  // a descriptor of this process, whatever it is open on
    write(path);
    return;
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    throw Error(fmt::format("{}: is a directory; expected a file name", path));
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // a device, FIFO or socket (/dev/null, /dev/stdout, ...): written in place (renaming a file
    // over it would replace it)
    try {
      write(path);
    } catch (...) {
      rethrow_named(path);
    }
    return;
  }
  const std::string real = resolve_symlinks(path);  // a symlink's target is replaced, the link stays
  const bool exists = ::stat(real.c_str(), &st) == 0;
  const fs::path target(real);
  if (!target.has_filename()) throw Error(fmt::format("{}: is a directory; expected a file name", path));
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(fmt::format("{}: directory {} does not exist", path, dir.string()));
  if (exists) {
    if ((st.st_mode & 0222) == 0)
      throw Error(fmt::format("{}: is read-only (mode {:03o}); not replacing it (make it writable or choose another "
                              "output file)",
                              path, st.st_mode & 07777));
    if (::access(real.c_str(), W_OK) != 0)
      throw Error(fmt::format("{}: not writable ({}); not replacing it", path, std::strerror(errno)));
  }
  std::unique_ptr<TempFile> tmp;
  int fd = -1;
  std::random_device rd;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    tmp = std::make_unique<TempFile>((dir / fmt::format(".{}.tmp-{}-{}-{:08x}", target.filename().string(),
                                                        ::getpid(), temp_counter++, rd()))
                                         .string());
    fd = ::open(tmp->path().c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
      const int err = errno;
      tmp->release();  // not ours
      if (err != EEXIST)
        throw Error(fmt::format("{}: cannot create a temporary file in {}: {}", path, dir.string(), std::strerror(err)));
    }
  }
  if (fd < 0) throw Error(fmt::format("{}: cannot create a temporary file in {}", path, dir.string()));
  if (exists) {
    // keep the existing file's permission bits (and, where allowed, its owner)
    (void)::fchmod(fd, st.st_mode & 07777);
    if (::geteuid() == 0) (void)::fchown(fd, st.st_uid, st.st_gid);
  }
  ::close(fd);
  try {
    write(tmp->path());
    // flush to disk before the rename, so a crash leaves the old or the new file, never a torn one
    fsync_path(tmp->path(), path);
    // hard links: the new content goes into the same inode (not atomic: see the header)
    PendingFile f{std::move(tmp), real, path, exists && st.st_nlink > 1};
    if (t_batch != nullptr) {  // a FileBatch moves it into place with the others
      t_batch->push_back(std::move(f));
      return;
    }
    commit_file(f);
  } catch (const Error&) {
    rethrow_named(path);
  }
}

void write_text_file(const std::string& path, std::string_view text) {
  if (path == "-" || path == "/dev/stdout") {
    std::fwrite(text.data(), 1, text.size(), stdout);
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) throw Error("writing to stdout failed");
    return;
  }
  write_file_atomically(path, [&](const std::string& tmp) {
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) throw Error(fmt::format("cannot open for writing: {}", std::strerror(errno)));
    try {
      write_all(fd, text, path);
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (::close(fd) != 0) throw Error(fmt::format("write failed: {}", std::strerror(errno)));
  });
}

namespace {
// The file a path names (through symlinks), if it exists and is a regular file.
std::optional<std::pair<dev_t, ino_t>> file_id(const std::string& path) {
  struct stat st {};
  if (path.empty() || path == "-" || ::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  return std::pair<dev_t, ino_t>{st.st_dev, st.st_ino};
}

std::string same_file_name(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? path : p.string();
}
}  // namespace

void check_outputs_distinct(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  auto refuse = [](const NamedPath& out, const NamedPath& other, std::string_view what) {
    throw Error(fmt::format("{} {} and {} {} are the same file; refusing to overwrite {} (choose another output file)",
                            out.option, out.path, other.option, other.path, what));
  };
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const auto id = file_id(outputs[i].path);
    if (id)
      for (const auto& in : inputs)
        if (file_id(in.path) == id) refuse(outputs[i], in, "an input");
    for (std::size_t k = 0; k < i; ++k) {
      if (outputs[i].path.empty() || outputs[k].path.empty() || outputs[i].path == "-" || outputs[k].path == "-")
        continue;
      const auto other = file_id(outputs[k].path);
      struct stat st {};
      const bool special = ::stat(outputs[i].path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
      if ((id && other && *id == *other) || (!id && !other && !special &&
                                             same_file_name(outputs[i].path) == same_file_name(outputs[k].path)))
        refuse(outputs[i], outputs[k], "another output");
    }
  }
}

namespace {
// check_output_file / check_output_directory: `dir` (an existing directory) takes new files
void require_writable(const NamedPath& output, const fs::path& dir) {
  if (::access(dir.c_str(), W_OK) != 0)
    throw Error(fmt::format("{} {}: cannot write into directory {}: {} (nothing was run or written)", output.option,
                            output.path, dir.string(), std::strerror(errno)));
}
}  // namespace

void check_output_file(const NamedPath& output) {
  const std::string& path = output.path;
  if (path.empty() || path == "-") return;
  std::error_code ec;
  const fs::path p(path);
  if (fs::is_directory(p, ec))
    throw Error(fmt::format("{} {}: is a directory; expected a file name", output.option, path));
  if (fs::exists(p, ec)) return;  // replaced (a read-only file is refused when written, before anything is lost)
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    throw Error(fmt::format("{} {}: directory {} does not exist (nothing was run or written)", output.option, path,
                            dir.string()));
  require_writable(output, dir);
}

void check_output_directory(const NamedPath& output) {
  const std::string& path = output.path;
  if (path.empty()) return;
  std::error_code ec;
  fs::path d = fs::path(path).lexically_normal();
  if (d.has_filename() == false && d.has_parent_path()) d = d.parent_path();  // "out/" -> "out"
  // the directory, or the nearest ancestor that exists (the writer creates the rest)
  fs::path existing = d;
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (existing.empty()) existing = ".";
  if (!fs::is_directory(existing, ec))
    throw Error(fmt::format("{} {}: {} is not a directory (nothing was run or written)", output.option, path,
                            existing.string()));
  require_writable(output, existing);
}

void check_output_files(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  check_outputs_distinct(outputs, inputs);
  for (const auto& o : outputs) check_output_file(o);
}

bool is_html_path(std::string_view path) {
  std::string lower(path);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return lower.ends_with(".html") || lower.ends_with(".htm");
}

}  // namespace hysteron::io
