#pragma once
// Small helpers shared by the I/O tests: a file's bytes, and the message of an expected error.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "hysteron/error.hpp"

namespace hysteron::test {

// The whole content of a file ("" if it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The message of the hysteron::Error f throws; "" and a test failure if it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const hysteron::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no hysteron::Error thrown";
  return {};
}

inline bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace hysteron::test
