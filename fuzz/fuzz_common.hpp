#pragma once
// Shared by the libFuzzer targets: a private directory for files a reader needs a path for.
#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace hysteron::fuzz {

// A directory made once per process (in /dev/shm when there is one: no disk writes),
// removed at exit with the files the target wrote into it.
inline const std::string& scratch_dir() {
  static const std::string dir = [] {
    std::string tmpl = (::access("/dev/shm", W_OK) == 0 ? std::string("/dev/shm") : std::string("/tmp")) +
                       "/hysteron-fuzz-XXXXXX";
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
