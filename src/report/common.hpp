#pragma once
// Private to the report layer: what the experiment report (html.cpp) and the sweep
// page (sweep_html.cpp) share.
#include <fmt/format.h>

#include <cmath>
#include <ctime>
#include <string>
#include <string_view>

namespace hysteron::report::detail {

inline std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

// The document head of both pages up to the title and the command line (html.cpp): the
// shared style, the page's max width [px] and its own CSS rules after it.
std::string page_head(std::string_view title, std::string_view command_line, int max_width_px,
                      std::string_view extra_css);

// A number for an HTML cell: `digits` significant digits, a dash when not finite.
inline std::string num(double v, int digits = 4) {
  if (!std::isfinite(v)) return "&ndash;";
  return fmt::format("{:.{}g}", v, digits);
}

// One colour per variant kind, the same in every figure.
inline const char* variant_color(const std::string& v) {
  if (v == "compensated") return "#d62728";
  if (v == "faithful") return "#1f77b4";
  if (v == "baseline") return "#7f7f7f";
  if (v == "learning") return "#2ca02c";
  if (v == "adaptive") return "#9467bd";
  return "#8c564b";
}

}  // namespace hysteron::report::detail
