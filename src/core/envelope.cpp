#include "hysteron/envelope.hpp"

#include "format.hpp"

#include <limits>
#include <numbers>

#include "hysteron/error.hpp"

namespace hysteron {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

std::string_view envelope_name(EnvelopeKind kind) noexcept {
  switch (kind) {
    case EnvelopeKind::identity: return "identity";
    case EnvelopeKind::affine: return "affine";
    case EnvelopeKind::tanh: return "tanh";
    case EnvelopeKind::atan: return "atan";
  }
  return "identity";
}

EnvelopeKind envelope_kind_from_name(std::string_view name, std::string_view where) {
  for (auto k : {EnvelopeKind::identity, EnvelopeKind::affine, EnvelopeKind::tanh, EnvelopeKind::atan})
    if (envelope_name(k) == name) return k;
  throw Error(detail::format("{}: unknown envelope \"{}\" (expected identity, affine, tanh or atan)", where, name));
}

std::size_t envelope_num_coefficients(EnvelopeKind kind) noexcept {
  switch (kind) {
    case EnvelopeKind::identity: return 0;
    case EnvelopeKind::affine: return 2;
    case EnvelopeKind::tanh:
    case EnvelopeKind::atan: return 4;
  }
  return 0;
}

void Envelope::validate(std::string_view where) const {
  const std::size_t m = envelope_num_coefficients(kind);
  for (std::size_t i = 0; i < m; ++i)
    if (!std::isfinite(c[i]))
      throw Error(detail::format("{}: envelope coefficient c{} is not finite", where, i));
  if (kind == EnvelopeKind::affine && !(c[0] > 0))
    throw Error(detail::format("{}: affine envelope needs c0 > 0 (strictly increasing), got {}", where, c[0]));
  if (kind == EnvelopeKind::tanh || kind == EnvelopeKind::atan) {
    if (!(c[0] > 0))
      throw Error(detail::format("{}: {} envelope needs c0 > 0, got {}", where, envelope_name(kind), c[0]));
    if (!(c[1] > 0))
      throw Error(detail::format("{}: {} envelope needs c1 > 0, got {}", where, envelope_name(kind), c[1]));
  }
}

double Envelope::derivative(double x) const noexcept {
  switch (kind) {
    case EnvelopeKind::identity: return 1.0;
    case EnvelopeKind::affine: return c[0];
    case EnvelopeKind::tanh: {
      const double t = detail::tanh_fast(c[1] * x + c[2]);
      return c[0] * c[1] * (1.0 - t * t);
    }
    case EnvelopeKind::atan: {
      const double z = c[1] * x + c[2];
      return c[0] * c[1] / (1.0 + z * z);
    }
  }
  return 1.0;
}

double Envelope::range_lo() const noexcept {
  switch (kind) {
    case EnvelopeKind::tanh: return c[3] - c[0];
    case EnvelopeKind::atan: return c[3] - c[0] * std::numbers::pi / 2;
    default: return -kInf;
  }
}

double Envelope::range_hi() const noexcept {
  switch (kind) {
    case EnvelopeKind::tanh: return c[3] + c[0];
    case EnvelopeKind::atan: return c[3] + c[0] * std::numbers::pi / 2;
    default: return kInf;
  }
}

double Envelope::inverse(double u) const noexcept {
  if (std::isnan(u)) return u;
  if (u <= range_lo()) return -kInf;
  if (u >= range_hi()) return kInf;
  return FastEnvelope(*this).inverse(u);  // the same arithmetic as Inverse::step
}

double Envelope::inverse_checked(double u, std::string_view where) const {
  if (!in_range(u))
    throw Error(detail::format("{}: value {} is outside the range ({}, {}) of the {} envelope", where, u,
                            range_lo(), range_hi(), envelope_name(kind)));
  return inverse(u);
}

}  // namespace hysteron
