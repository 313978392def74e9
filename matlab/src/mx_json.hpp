#pragma once
// JSON <-> MATLAB values for the MEX gateway, with the MATLAB MEX C API only (mex.h),
// so that the same source builds with MATLAB's `mex` and Octave's `mkoctfile --mex`.
//
// JSON -> MATLAB
//   object -> 1x1 struct (keys that are not valid MATLAB names are made valid:
//             other characters become '_', a leading non-letter gets an 'x' in front)
//   array of numbers (and nulls) -> 1xN double (null -> NaN); of booleans -> 1xN logical;
//   of objects with the same keys -> 1xN struct array; [] -> [] (0x0 double);
//   anything else -> 1xN cell
//   number -> double, true/false -> logical, string -> char row, null -> NaN
// MATLAB -> JSON
//   struct 1x1 -> object, struct array -> array of objects; cell -> array;
//   char row -> string; logical -> bool (array for several); real numeric vector -> array
//   (a scalar -> a number; an integral double -> an integer; a matrix -> array of rows);
//   NaN and +-Inf are an error naming the field, except for the fields listed in
//   ToJsonOptions::infinite_as_null (-Inf/Inf -> null) and the subtrees listed in
//   ToJsonOptions::null_subtrees (free-form data such as a model's "metadata": NaN -> null).
// Sparse arrays are refused wherever a number is read (data, model fields, options): a
// MexError(id_bad_argument) naming the argument, "use full(x)".
// Every error is a MexError whose message names the argument and the field path
// (e.g. "model.c(2)").
#include <mex.h>

#include <nlohmann/json.hpp>

#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hysteron::mex {

// An error raised by the gateway itself, with its MATLAB identifier ("hysteron:...").
class MexError : public std::runtime_error {
 public:
  MexError(std::string id, const std::string& message) : std::runtime_error(message), id_(std::move(id)) {}
  const std::string& id() const noexcept { return id_; }

 private:
  std::string id_;
};

// The identifiers the gateway raises (docs/matlab.md lists them).
inline constexpr const char* id_bad_argument = "hysteron:badArgument";  // wrong type, size, option
inline constexpr const char* id_non_finite = "hysteron:nonFinite";      // NaN or Inf in data
inline constexpr const char* id_bad_model = "hysteron:badModel";        // invalid model struct / JSON
inline constexpr const char* id_model_file = "hysteron:modelFile";      // unreadable / unwritable model file
inline constexpr const char* id_fit_input = "hysteron:fitInvalidInput"; // fit refused the data or options
inline constexpr const char* id_error = "hysteron:error";               // any other hysteron::Error
inline constexpr const char* id_internal = "hysteron:internal";         // a bug (unexpected exception)

struct ToJsonOptions {
  std::set<std::string> infinite_as_null;  // field names whose -Inf/Inf become null
  std::set<std::string> null_subtrees;     // field names under which NaN and +-Inf become null
  bool all_null = false;                   // (set inside such a subtree)
};

mxArray* to_mx(const nlohmann::json& j);
nlohmann::json to_json(const mxArray* a, const std::string& path, const ToJsonOptions& options = {});

// The array's size as MATLAB prints it: "3x4", "1x1x200" (every dimension, not mxGetN's product).
std::string dims(const mxArray* a);

// A MATLAB name for a JSON key (see above).
std::string valid_field_name(const std::string& key);

// Argument helpers (throw MexError with id_bad_argument naming `what`).
std::string get_string(const mxArray* a, const std::string& what);
double get_scalar(const mxArray* a, const std::string& what);
bool get_bool(const mxArray* a, const std::string& what);
long long get_integer(const mxArray* a, const std::string& what);
// A real double vector (any orientation, possibly empty) as a copy.
std::vector<double> get_vector(const mxArray* a, const std::string& what);
// Throws MexError(id_non_finite) naming the first NaN/Inf as what(k) (1-based).
void require_finite(const std::vector<double>& v, const std::string& what);
// A double vector shaped like `like` (row or column; column if `like` is null).
mxArray* make_vector(const std::vector<double>& v, const mxArray* like);
mxArray* make_logical_vector(const std::vector<bool>& v, const mxArray* like);

}  // namespace hysteron::mex
