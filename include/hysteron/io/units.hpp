#pragma once
// Units as text: the unit of a header name or label ("pressure [kPa]"), a unit as compared
// ("KPa" is "kPa"), and what the controllers need of one. No file access: the C ABI uses these
// without the table readers (and their matio).
#include <string>
#include <string_view>

namespace hysteron::io {

// "[kPa]" / "(kPa)" -> "kPa" (one pair of brackets, and blanks, stripped).
std::string strip_unit_brackets(std::string_view unit);
// The unit a header name or axis label ends in, " [unit]" or " (unit)" after a blank: "Pressure
// [kPa]" -> "kPa"; "" for none ("x[0]", "sin(t)": no blank before the bracket; "p [3]": digits).
std::string trailing_unit(std::string_view text);
// The text without that unit ("Pressure [kPa]" -> "Pressure").
std::string without_unit(std::string_view text);
// A unit as compared (evaluate, simulate, invert against a model's "units"): the symbol of a unit
// of pressure, length, force, voltage, current or time ("kPa" for "kPa", "KPa", "[kPa]",
// "Pressure [kPa]"; "um" for "µm"), "" for any other text (free text is not compared). Prefixes
// keep their case: "mPa" is not "MPa".
std::string canonical_unit(std::string_view unit);
// A length unit's count per metre (canonical_unit "m" 1, "cm" 100, "mm" 1000, "um" 1e6, "nm" 1e9,
// "in" 1 / 0.0254): a controller's model_scale for a model whose output is in it; 0 for any other
// text. And whether canonical_unit names a pressure unit other than MPa (Pa, hPa, kPa, bar, mbar,
// psi, atm): the controllers' pressures are in MPa.
double length_units_per_metre(std::string_view unit);
bool pressure_unit_other_than_mpa(std::string_view unit);
// A pressure unit's MPa (canonical_unit "Pa" 1e-6, "hPa" 1e-4, "kPa" 1e-3, "MPa" 1, "bar" 0.1,
// "mbar" 1e-4, "psi" 0.00689..., "atm" 0.101325); 0 for any other text.
double mpa_per_pressure_unit(std::string_view unit);
// Why a controller (its pressure limits, PID gains and commands in MPa) cannot run on a model
// whose input is in `input_unit`: a known pressure unit other than MPa (kPa, bar, Pa, psi, ...;
// the message names it and says to refit the model with its pressure in MPa); "" for MPa, no
// unit, or a unit that is no pressure (a hand-written model has none). The controllers'
// constructors in Python, the C ABI's *_create, controller_from and export --loop refuse with it.
std::string input_unit_mismatch(std::string_view input_unit);
// Why a controller's model_scale [model output units per m] contradicts a model whose output is
// in `output_unit` (a length unit whose count per metre differs from it by more than 1e-4
// relative: a model in m under the default 1000 asks its inverse for outputs 1000x too large);
// "" where it agrees or the unit is no length (or none). The controllers' constructors in
// Python, the C ABI's *_create, controller_from and export --loop refuse with it.
std::string model_scale_mismatch(double model_scale, std::string_view output_unit);

}  // namespace hysteron::io
