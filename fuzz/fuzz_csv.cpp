// libFuzzer target: the text-table (CSV) reader, in memory (parse_text_table) and streamed
// from a file in chunks (for_each_value); both must agree. Only hysteron::Error may escape
// the reader: any other exception, a crash, a hang or a huge allocation is a finding.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_common.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/table.hpp"

namespace io = hysteron::io;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  // first byte: separator, header mode and which column to select
  const std::uint8_t mode = data[0];
  ++data;
  --size;
  io::ReadOptions opt;
  static constexpr char kSep[4] = {0, ',', ';', '\t'};
  opt.separator = kSep[mode & 3];
  opt.header = static_cast<io::HeaderMode>(((mode >> 2) & 3) % 3);
  static const char* const kSpec[8] = {"", "0", "1", "a", "b", "input", "2", "a:0"};
  opt.column_spec = kSpec[(mode >> 4) & 7];
  if (mode & 0x80) opt.preferred_column = "input";

  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::vector<double> from_memory;
  bool memory_ok = true;
  try {
    const io::Table t = io::parse_text_table(text, "fuzz.csv", opt);
    for (const auto& c : t.columns)
      if (!c.empty() && c.size() != t.num_rows()) std::abort();  // columns are all-empty or full
    from_memory = t.column(opt.column_spec);
  } catch (const hysteron::Error& e) {
    if (std::strlen(e.what()) > 4096) std::abort();  // messages stay short
    memory_ok = false;
  }

  const std::string path = hysteron::fuzz::scratch_file("input.csv", data, size);
  std::vector<double> streamed;
  bool stream_ok = true;
  try {
    io::for_each_value(path, opt, [&](double v) { streamed.push_back(v); });
  } catch (const hysteron::Error& e) {
    if (std::strlen(e.what()) > 4096) std::abort();
    stream_ok = false;
  }
  // the streamed reader applies preferred_column, the table's column() does not: compare
  // only without it; every value delivered by both must be the same
  if (opt.preferred_column.empty() && memory_ok && stream_ok) {
    if (streamed.size() != from_memory.size()) std::abort();
    if (std::memcmp(streamed.data(), from_memory.data(), streamed.size() * sizeof(double)) != 0) std::abort();
  }
  if (opt.preferred_column.empty() && memory_ok != stream_ok) std::abort();
  return 0;
}
