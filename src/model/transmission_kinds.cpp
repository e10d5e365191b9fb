// The transmission kinds by name: the built-in kinds' names, and the kinds a
// program registers (register_transmission_kind) with the central differences
// a registered kind's derivatives default to.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/model/model.hpp"
#include "hapticcal/model/transmission.hpp"

namespace hapticcal {

const char* to_string(TransmissionKind kind) {
  static const char* const kNames[] = {"none",  "capstan",  "parallelogram", "polynomial",
                                       "chain", "harmonic", "extension"};
  return kNames[static_cast<int>(kind)];
}

// The registered kinds (register_transmission_kind).
namespace {

std::vector<const TransmissionDefinition*>& extension_kinds() {
  static std::vector<const TransmissionDefinition*> kinds;
  return kinds;
}

// A step of central differences in x.
double step_at(double x) { return 1e-6 * std::max(1.0, std::abs(x)); }

}  // namespace

double TransmissionDefinition::derivative(const double* p, double q) const {
  const double h = step_at(q);
  return (error(p, q + h) - error(p, q - h)) / (2 * h);
}

void TransmissionDefinition::parameter_jacobian(const double* p, double q, double* J) const {
  const size_t n = parameter_names().size();
  std::vector<double> moved(p, p + n);
  for (size_t k = 0; k < n; ++k) {
    const double h = step_at(p[k]);
    moved[k] = p[k] + h;
    const double plus = error(moved.data(), q);
    moved[k] = p[k] - h;
    const double minus = error(moved.data(), q);
    moved[k] = p[k];
    J[k] = (plus - minus) / (2 * h);
  }
}

void register_transmission_kind(const TransmissionDefinition* definition) {
  const auto word = [](const std::string& w) {
    return !w.empty() && std::all_of(w.begin(), w.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    });
  };
  const std::string name(definition->name());
  if (!word(name) || transmission_kind_named(name) || name == "extension" ||
      find_transmission_kind(name)) {
    throw std::invalid_argument(
        fmt::format("transmission kind '{}': not a word, or a name a kind already has", name));
  }
  // Step 1 names a parameter "<joint>.<name>": not a geometry slot's name.
  const auto taken = [](const std::string& p) {
    for (Geometry g : {Geometry::kDh, Geometry::kOrigin}) {
      const std::vector<std::string>& names = block_names(g);
      if (std::find(names.begin(), names.end(), p) != names.end()) return true;
    }
    return p == "type";
  };
  for (const std::string& p : definition->parameter_names()) {
    if (!word(p) || taken(p)) {
      throw std::invalid_argument(fmt::format(
          "transmission kind '{}': parameter '{}' is not a word, or is 'type' or a geometry "
          "parameter's name",
          name, p));
    }
  }
  extension_kinds().push_back(definition);
}

const TransmissionDefinition* find_transmission_kind(std::string_view name) {
  for (const TransmissionDefinition* d : extension_kinds()) {
    if (d->name() == name) return d;
  }
  return nullptr;
}

std::vector<std::string> registered_transmission_kinds() {
  std::vector<std::string> names;
  for (const TransmissionDefinition* d : extension_kinds()) names.emplace_back(d->name());
  return names;
}

std::string Transmission::type_name() const {
  if (const auto* e = std::get_if<Extension>(&model_); e && e->definition)
    return std::string(e->definition->name());
  return to_string(kind());
}

std::optional<TransmissionKind> transmission_kind_named(const std::string& name) {
  for (TransmissionKind k :
       {TransmissionKind::kNone, TransmissionKind::kCapstan, TransmissionKind::kParallelogram,
        TransmissionKind::kPolynomial, TransmissionKind::kChain, TransmissionKind::kHarmonic}) {
    if (name == to_string(k)) return k;
  }
  return std::nullopt;
}

}  // namespace hapticcal
