// libFuzzer target: the .mat reader (structure checks, then matio). The input is written to a
// scratch file (matio reads files only) and read as a whole table and by variable name.
// Only hysteron::Error may escape; a crash, a hang or a huge allocation is a finding.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "fuzz_common.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"

namespace io = hysteron::io;

// Debian's HDF5 1.10 (not instrumented) leaks object-header cache entries when it fails to open
// a damaged object (e.g. H5Gopen2 on a corrupt root group: 848 bytes through matio's Mat_Open
// alone, 1,696 through hysteron's v7.3 check, which opens it first). Those leaks are HDF5's, on
// its error paths: leak reports whose allocation stack is inside libhdf5 are not findings.
extern "C" const char* __lsan_default_suppressions() { return "leak:libhdf5_serial.so\n"; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = hysteron::fuzz::scratch_file("input.mat", data, size);
  try {
    const io::Table t = io::read_table(path);
    for (const auto& c : t.columns)
      if (c.size() != t.num_rows()) std::abort();  // every column of a .mat table has all rows
  } catch (const hysteron::Error&) {
  }
  for (const char* spec : {"", "x", "data:1"}) {
    try {
      (void)io::read_column(path, spec);
    } catch (const hysteron::Error&) {
    }
  }
  return 0;
}
