#pragma once
// Shared by the libFuzzer targets: a private directory for files a reader needs a path for.
#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace hysteron::fuzz {

// A directory made once per process, removed at exit with the files the target wrote into
// it. It is made in $HYSTERON_FUZZ_SCRATCH if set (`make fuzz` sets build-fuzz/scratch and
// empties it after each target: a finding, a timeout or an out-of-memory stop ends the
// process with _Exit, which runs no atexit handler), else in /dev/shm when there is one (no
// disk writes), else in /tmp.
inline const std::string& scratch_dir() {
  static const std::string dir = [] {
    const char* env = std::getenv("HYSTERON_FUZZ_SCRATCH");
    const std::string base = env && *env                          ? std::string(env)
                             : ::access("/dev/shm", W_OK) == 0 ? std::string("/dev/shm")
                                                               : std::string("/tmp");
    std::string tmpl = base + "/hysteron-fuzz-XXXXXX";
    if (!::mkdtemp(tmpl.data())) std::abort();
    return tmpl;
  }();
  return dir;
}

// Writes data to `name` in the scratch directory (removed at exit); returns its path.
inline std::string scratch_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
  static std::string registered;
  const std::string path = scratch_dir() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  if (std::fclose(f) != 0) std::abort();
  if (registered.empty()) {
    registered = path;
    std::atexit([] {
      ::unlink(registered.c_str());
      ::rmdir(scratch_dir().c_str());
    });
  }
  return path;
}

}  // namespace hysteron::fuzz
