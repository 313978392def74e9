// hysteron::report: HTML escaping from the report layer.
#include <hysteron/report.hpp>

#include <cstdio>

int main() {
  const std::string s = hysteron::report::html_escape("<a & b>");
  std::printf("consumer report: %s\n", s.c_str());
  return s == "&lt;a &amp; b&gt;" ? 0 : 1;
}
