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
