// JSON <-> MATLAB values (see mx_json.hpp).
#include "mx_json.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

namespace hysteron::mex {

namespace {

// ---- JSON -> MATLAB ------------------------------------------------------------

bool all_of_type(const nlohmann::json& a, bool (*pred)(const nlohmann::json&)) {
  for (const auto& e : a)
    if (!pred(e)) return false;
  return true;
}

bool is_number_or_null(const nlohmann::json& e) { return e.is_number() || e.is_null(); }
bool is_bool(const nlohmann::json& e) { return e.is_boolean(); }
bool is_object(const nlohmann::json& e) { return e.is_object(); }

double number(const nlohmann::json& e) {
  return e.is_null() ? std::numeric_limits<double>::quiet_NaN() : e.get<double>();
}

// Field names of an object, made valid and unique, in the object's (sorted) order.
std::vector<std::string> field_names(const nlohmann::json& obj) {
  std::vector<std::string> names;
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    std::string name = valid_field_name(it.key());
    std::string unique = name;
    for (int k = 2; std::find(names.begin(), names.end(), unique) != names.end(); ++k)
      unique = fmt::format("{}_{}", name.substr(0, 58), k);
    names.push_back(unique);
  }
  return names;
}

mxArray* make_struct(const std::vector<const nlohmann::json*>& objects) {
  const std::vector<std::string> names = field_names(*objects.front());
  std::vector<const char*> cnames;
  for (const auto& n : names) cnames.push_back(n.c_str());
  mxArray* s = mxCreateStructMatrix(1, objects.size(), static_cast<int>(cnames.size()), cnames.data());
  for (std::size_t i = 0; i < objects.size(); ++i) {
    int f = 0;
    for (auto it = objects[i]->begin(); it != objects[i]->end(); ++it, ++f)
      mxSetFieldByNumber(s, i, f, to_mx(it.value()));
  }
  return s;
}

bool same_keys(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.size() != b.size()) return false;
  for (auto ia = a.begin(), ib = b.begin(); ia != a.end(); ++ia, ++ib)
    if (ia.key() != ib.key()) return false;
  return true;
}

// ---- MATLAB -> JSON --------------------------------------------------------------

std::string class_name(const mxArray* a) { return mxGetClassName(a); }

nlohmann::json number_json(double v, const std::string& path, bool inf_as_null, bool nan_as_null) {
  if (std::isnan(v) && nan_as_null) return nullptr;
  if (std::isnan(v) && inf_as_null)  // (a jsondecode'd null is NaN)
    throw MexError(id_non_finite, fmt::format("{} is NaN: use -Inf or Inf for an unbounded side (jsondecode reads "
                                              "JSON's null as NaN)",
                                              path));
  if (std::isnan(v)) throw MexError(id_non_finite, fmt::format("{} is NaN (numbers must be finite)", path));
  if (std::isinf(v)) {
    if (inf_as_null) return nullptr;
    throw MexError(id_non_finite, fmt::format("{} is {} (numbers must be finite)", path, v > 0 ? "Inf" : "-Inf"));
  }
  // integral doubles as integers (JSON integers where a reader needs one: "schema", "n",
  // the rig's bit counts); -0 stays a double
  if (v == std::trunc(v) && std::abs(v) <= 9007199254740992.0 && !(v == 0.0 && std::signbit(v)))
    return static_cast<std::int64_t>(v);
  return v;
}

// The elements of a numeric or logical array given by the user: every read of the user's numbers
// (data, model fields, options) passes here. A sparse array's data holds only its non-zeros, not
// the matrix (read as full it gives wrong numbers or reads beyond them): refused.
const void* user_data(const mxArray* a, const std::string& what) {
  if (mxIsSparse(a))
    throw MexError(id_bad_argument,
                   fmt::format("{}: a sparse {} array; sparse arrays are not supported: use full(x)", what,
                               dims(a)));
  return mxGetData(a);
}

template <class T>
nlohmann::json integer_json(const void* data, std::size_t k) {
  return static_cast<const T*>(data)[k];
}

// Element k of a numeric array whose data `d` is (user_data).
nlohmann::json numeric_element(const mxArray* a, const void* d, std::size_t k, const std::string& path,
                               bool inf_as_null, bool nan_as_null) {
  switch (mxGetClassID(a)) {
    case mxDOUBLE_CLASS: return number_json(static_cast<const double*>(d)[k], path, inf_as_null, nan_as_null);
    case mxSINGLE_CLASS: return number_json(static_cast<const float*>(d)[k], path, inf_as_null, nan_as_null);
    case mxINT8_CLASS: return integer_json<std::int8_t>(d, k);
    case mxUINT8_CLASS: return integer_json<std::uint8_t>(d, k);
    case mxINT16_CLASS: return integer_json<std::int16_t>(d, k);
    case mxUINT16_CLASS: return integer_json<std::uint16_t>(d, k);
    case mxINT32_CLASS: return integer_json<std::int32_t>(d, k);
    case mxUINT32_CLASS: return integer_json<std::uint32_t>(d, k);
    case mxINT64_CLASS: return integer_json<std::int64_t>(d, k);
    case mxUINT64_CLASS: return integer_json<std::uint64_t>(d, k);
    default: break;
  }
  throw MexError(id_bad_argument, fmt::format("{}: unsupported class {}", path, class_name(a)));
}

void require_2d(const mxArray* a, const std::string& path) {
  if (mxGetNumberOfDimensions(a) > 2)
    throw MexError(id_bad_argument, fmt::format("{}: {}-dimensional arrays are not supported (use a vector)", path,
                                                mxGetNumberOfDimensions(a)));
}

// Elements of a numeric or logical array: scalar -> value, vector -> array, matrix -> rows.
template <class Element>
nlohmann::json array_json(const mxArray* a, const std::string& path, Element element) {
  require_2d(a, path);
  const std::size_t m = mxGetM(a), n = mxGetN(a), count = m * n;
  if (count == 1) return element(0, path);
  nlohmann::json out = nlohmann::json::array();
  if (m <= 1 || n <= 1) {
    for (std::size_t k = 0; k < count; ++k) out.push_back(element(k, fmt::format("{}({})", path, k + 1)));
    return out;
  }
  for (std::size_t i = 0; i < m; ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (std::size_t jj = 0; jj < n; ++jj)  // column-major storage
      row.push_back(element(i + jj * m, fmt::format("{}({},{})", path, i + 1, jj + 1)));
    out.push_back(std::move(row));
  }
  return out;
}

}  // namespace

std::string dims(const mxArray* a) {
  const mwSize nd = mxGetNumberOfDimensions(a);
  const mwSize* d = mxGetDimensions(a);
  std::string out;
  for (mwSize k = 0; k < nd; ++k) out += fmt::format("{}{}", k ? "x" : "", d[k]);
  return out;
}

std::string valid_field_name(const std::string& key) {
  std::string name;
  for (char c : key) name += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
  if (name.empty() || !std::isalpha(static_cast<unsigned char>(name.front()))) name = "x" + name;
  if (name.size() > 63) name.resize(63);
  return name;
}

mxArray* to_mx(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return mxCreateDoubleScalar(std::numeric_limits<double>::quiet_NaN());
    case nlohmann::json::value_t::boolean: return mxCreateLogicalScalar(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
    case nlohmann::json::value_t::number_float: return mxCreateDoubleScalar(j.get<double>());
    case nlohmann::json::value_t::string: return mxCreateString(j.get_ref<const std::string&>().c_str());
    case nlohmann::json::value_t::object: return make_struct({&j});
    case nlohmann::json::value_t::array: {
      const std::size_t n = j.size();
      if (n == 0) return mxCreateDoubleMatrix(0, 0, mxREAL);
      if (all_of_type(j, is_number_or_null) && !all_of_type(j, [](const nlohmann::json& e) { return e.is_null(); })) {
        mxArray* a = mxCreateDoubleMatrix(1, n, mxREAL);
        double* d = static_cast<double*>(mxGetData(a));
        for (std::size_t k = 0; k < n; ++k) d[k] = number(j[k]);
        return a;
      }
      if (all_of_type(j, is_bool)) {
        mxArray* a = mxCreateLogicalMatrix(1, n);
        mxLogical* d = mxGetLogicals(a);
        for (std::size_t k = 0; k < n; ++k) d[k] = j[k].get<bool>();
        return a;
      }
      if (all_of_type(j, is_object)) {
        bool same = true;
        for (const auto& e : j) same = same && same_keys(e, j.front());
        if (same && !j.front().empty()) {
          std::vector<const nlohmann::json*> objects;
          for (const auto& e : j) objects.push_back(&e);
          return make_struct(objects);
        }
      }
      mxArray* c = mxCreateCellMatrix(1, n);
      for (std::size_t k = 0; k < n; ++k) mxSetCell(c, k, to_mx(j[k]));
      return c;
    }
    case nlohmann::json::value_t::binary:
    case nlohmann::json::value_t::discarded: break;
  }
  throw MexError(id_internal, "unsupported JSON value");
}

nlohmann::json to_json(const mxArray* a, const std::string& path, const ToJsonOptions& options) {
  if (a == nullptr) return nullptr;
  const std::size_t count = mxGetNumberOfElements(a);
  if (mxIsStruct(a)) {
    require_2d(a, path);
    const int nf = mxGetNumberOfFields(a);
    auto object = [&](std::size_t k, const std::string& p) {
      nlohmann::json o = nlohmann::json::object();
      for (int f = 0; f < nf; ++f) {
        const std::string name = mxGetFieldNameByNumber(a, f);
        ToJsonOptions sub = options;
        if (options.null_subtrees.count(name) != 0) sub.all_null = true;
        const bool inf_null = options.infinite_as_null.count(name) != 0 && !options.all_null;
        const mxArray* v = mxGetFieldByNumber(a, k, f);
        const std::string fp = p + "." + name;
        if (inf_null && v && (mxIsDouble(v) || mxIsSingle(v)) && !mxIsComplex(v)) {
          // numbers of this field: -Inf/Inf -> null (e.g. an unbounded input limit)
          const void* d = user_data(v, fp);
          o[name] = array_json(v, fp, [&](std::size_t i, const std::string& ep) {
            return numeric_element(v, d, i, ep, true, false);
          });
          if (mxGetNumberOfElements(v) == 0) o[name] = nlohmann::json::array();
        } else {
          o[name] = to_json(v, fp, sub);
        }
      }
      return o;
    };
    if (count == 1) return object(0, path);
    nlohmann::json out = nlohmann::json::array();
    for (std::size_t k = 0; k < count; ++k) out.push_back(object(k, fmt::format("{}({})", path, k + 1)));
    return out;
  }
  if (mxIsCell(a)) {
    nlohmann::json out = nlohmann::json::array();
    for (std::size_t k = 0; k < count; ++k)
      out.push_back(to_json(mxGetCell(a, k), fmt::format("{}{{{}}}", path, k + 1), options));
    return out;
  }
  if (mxIsChar(a)) {
    if (count == 0) return "";
    if (mxGetM(a) != 1 || mxGetNumberOfDimensions(a) > 2)
      throw MexError(id_bad_argument, fmt::format("{}: expected a text row (char), got a {} char array", path,
                                                  dims(a)));
    char* s = mxArrayToString(a);
    if (s == nullptr) throw MexError(id_bad_argument, fmt::format("{}: cannot convert the text", path));
    std::string out(s);
    mxFree(s);
    return out;
  }
  if (mxIsLogical(a)) {
    const auto* d = static_cast<const mxLogical*>(user_data(a, path));
    if (count == 0) return nlohmann::json::array();
    return array_json(a, path, [&](std::size_t k, const std::string&) { return nlohmann::json(d[k] != 0); });
  }
  if (mxIsNumeric(a)) {
    if (mxIsComplex(a)) throw MexError(id_bad_argument, fmt::format("{}: complex numbers are not supported", path));
    const void* d = user_data(a, path);
    if (count == 0) return nlohmann::json::array();
    return array_json(a, path, [&](std::size_t k, const std::string& ep) {
      return numeric_element(a, d, k, ep, options.all_null, options.all_null);
    });
  }
  throw MexError(id_bad_argument, fmt::format("{}: values of class {} are not supported", path, class_name(a)));
}

// ---- argument helpers -----------------------------------------------------------------

std::string get_string(const mxArray* a, const std::string& what) {
  if (a == nullptr || !mxIsChar(a) || (mxGetNumberOfElements(a) > 0 && mxGetM(a) != 1))
    throw MexError(id_bad_argument,
                   fmt::format("{}: expected a text (char row), got {}", what, a ? class_name(a) : "nothing"));
  if (mxGetNumberOfElements(a) == 0) return "";
  char* s = mxArrayToString(a);
  if (s == nullptr) throw MexError(id_bad_argument, fmt::format("{}: cannot convert the text", what));
  std::string out(s);
  mxFree(s);
  return out;
}

double get_scalar(const mxArray* a, const std::string& what) {
  if (a == nullptr || !(mxIsNumeric(a) || mxIsLogical(a)) || mxIsComplex(a) || mxGetNumberOfElements(a) != 1)
    throw MexError(id_bad_argument,
                   fmt::format("{}: expected a real number (scalar), got {}", what,
                               a ? fmt::format("a {} {}", dims(a), class_name(a)) : "nothing"));
  const void* d = user_data(a, what);
  if (mxIsLogical(a)) return *static_cast<const mxLogical*>(d) ? 1.0 : 0.0;
  const double v = mxGetScalar(a);  // (of any numeric class; a full array: user_data)
  if (!std::isfinite(v)) throw MexError(id_non_finite, fmt::format("{} must be finite, got {}", what, v));
  return v;
}

bool get_bool(const mxArray* a, const std::string& what) {
  if (a != nullptr && mxIsLogical(a) && mxGetNumberOfElements(a) == 1)
    return *static_cast<const mxLogical*>(user_data(a, what)) != 0;
  const double v = get_scalar(a, what);
  if (v != 0.0 && v != 1.0) throw MexError(id_bad_argument, fmt::format("{}: expected true or false, got {}", what, v));
  return v != 0.0;
}

long long get_integer(const mxArray* a, const std::string& what) {
  const double v = get_scalar(a, what);
  if (!std::isfinite(v) || v != std::trunc(v) || std::abs(v) > 9007199254740992.0)
    throw MexError(id_bad_argument, fmt::format("{}: expected an integer, got {}", what, v));
  return static_cast<long long>(v);
}

std::vector<double> get_vector(const mxArray* a, const std::string& what) {
  if (a == nullptr || !mxIsDouble(a) || mxIsComplex(a) || mxGetNumberOfDimensions(a) > 2 ||
      (mxGetM(a) > 1 && mxGetN(a) > 1))
    throw MexError(id_bad_argument,
                   fmt::format("{}: expected a real double vector, got {}", what,
                               a ? fmt::format("a {} {}{}", dims(a), mxIsComplex(a) ? "complex " : "",
                                               class_name(a))
                                 : "nothing"));
  const double* d = static_cast<const double*>(user_data(a, what));
  return std::vector<double>(d, d + mxGetNumberOfElements(a));
}

void require_finite(const std::vector<double>& v, const std::string& what) {
  for (std::size_t k = 0; k < v.size(); ++k)
    if (!std::isfinite(v[k]))
      throw MexError(id_non_finite, fmt::format("{}({}) is {}: the samples must be finite", what, k + 1,
                                                std::isnan(v[k]) ? "NaN" : (v[k] > 0 ? "Inf" : "-Inf")));
}

mxArray* make_vector(const std::vector<double>& v, const mxArray* like) {
  const bool row = like != nullptr && mxGetM(like) == 1 && mxGetN(like) != 1;
  mxArray* a = row ? mxCreateDoubleMatrix(1, v.size(), mxREAL) : mxCreateDoubleMatrix(v.size(), 1, mxREAL);
  if (!v.empty()) std::copy(v.begin(), v.end(), static_cast<double*>(mxGetData(a)));
  return a;
}

mxArray* make_logical_vector(const std::vector<bool>& v, const mxArray* like) {
  const bool row = like != nullptr && mxGetM(like) == 1 && mxGetN(like) != 1;
  mxArray* a = row ? mxCreateLogicalMatrix(1, v.size()) : mxCreateLogicalMatrix(v.size(), 1);
  mxLogical* d = mxGetLogicals(a);
  for (std::size_t k = 0; k < v.size(); ++k) d[k] = v[k];
  return a;
}

}  // namespace hysteron::mex
