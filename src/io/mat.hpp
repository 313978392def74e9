#pragma once
// Internal to the io library (not installed): the .mat side of hysteron/io/table.hpp (mat.cpp)
// and the helpers both sides share (table.cpp).
#include <string>
#include <string_view>
#include <vector>

#include "hysteron/io/table.hpp"

namespace hysteron::io::detail {

// units.cpp (so that the unit helpers need no table reader)
// The text without leading blanks and tabs and trailing blanks, tabs and CRs.
std::string_view trim(std::string_view s);

// table.cpp
bool is_mat_path(std::string_view path);  // extension .mat, any case
// Printable, bounded form of a field or name for messages (at most 40 characters, control bytes
// as \xNN).
std::string shown(std::string_view s);

// mat.cpp
// read_table for a .mat file.
Table read_mat_table(const std::string& path);
// read_column for a .mat file: spec "" (the only variable; of several, the one named `preferred`
// if there is one, as for a text file's column), NAME, or NAME:INDEX.
std::vector<double> read_mat_variable(const std::string& path, const std::string& spec,
                                      const std::string& preferred = {});
bool is_matlab_identifier(std::string_view s);
// Writes Nx1 double variables as MAT v5 to `tmp`, then re-checks what was written.
void write_mat(const std::string& tmp, const std::vector<std::string>& names,
               const std::vector<std::vector<double>>& columns, bool compress);

}  // namespace hysteron::io::detail
