#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {

/// A settings struct's parameters, declared once, in the struct, as Drake's Serialize() does:
/// one field list serves the declaration (name, the struct's own default, range, doc), the
/// reading of resolved values and the writing back as assignments.
///
///   struct Lidar {
///     double range = 5.0;
///     int beams = 360;
///     template <typename Fields>
///     void fields(Fields& f) {
///       f.real("range", range, 0.1, 100.0, "sensor range, m");
///       f.integer("beams", beams, 1, 100000, "beams per revolution");
///     }
///   };
///
///   registrar.add<Sensor>("lidar", "...", declareFields<Lidar>(), [](const ParameterSet& p) {
///     return std::make_unique<Lidar>(readFields<Lidar>(p));
///   });
///
/// A field may be declared in other units than it is kept in (`unit`: degrees declared, radians
/// kept: kept = declared * unit), and a choice maps names to an enum's values.
namespace fields {

template <typename Enum>
using Names = std::vector<std::pair<std::string, Enum>>;

/// Declares every field with the value it holds as its default.
class Declare {
 public:
  template <typename Real>
  void real(const std::string& name, const Real& value, double minimum, double maximum,
            std::string doc, double unit = 1.0) {
    specs.real(name, declared(static_cast<double>(value), unit), minimum, maximum, std::move(doc));
  }
  template <typename Int>
  void integer(const std::string& name, const Int& value, long long minimum, long long maximum,
               std::string doc) {
    specs.integer(name, static_cast<long long>(value), minimum, maximum, std::move(doc));
  }
  void boolean(const std::string& name, const bool& value, std::string doc) {
    specs.boolean(name, value, std::move(doc));
  }
  template <typename Enum>
  void choice(const std::string& name, const Enum& value, const Names<Enum>& names,
              std::string doc) {
    std::vector<std::string> keys;
    std::string chosen;
    for (const auto& [key, item] : names) {
      keys.push_back(key);
      if (item == value) chosen = key;
    }
    specs.choice(name, chosen, std::move(keys), std::move(doc));
  }

  ParameterSpecs specs;

 private:
  /// A kept value in declared units; a converted one rounded to 12 digits (pi / 3 rad is
  /// declared as 60 degrees, not 59.999999999999993).
  static double declared(double value, double unit) {
    if (unit == 1.0 || value == 0.0) return value;
    char text[32];
    std::snprintf(text, sizeof text, "%.12g", value / unit);
    return std::strtod(text, nullptr);
  }
};

/// Reads every field from resolved parameters (ParameterSpecs::resolve of Declare's specs).
class Read {
 public:
  explicit Read(const ParameterSet& parameters) : parameters_(parameters) {}

  template <typename Real>
  void real(const std::string& name, Real& value, double, double, const std::string&,
            double unit = 1.0) {
    value = static_cast<Real>(parameters_.real(name) * unit);
  }
  template <typename Int>
  void integer(const std::string& name, Int& value, long long, long long, const std::string&) {
    value = static_cast<Int>(parameters_.integer(name));
  }
  void boolean(const std::string& name, bool& value, const std::string&) {
    value = parameters_.boolean(name);
  }
  template <typename Enum>
  void choice(const std::string& name, Enum& value, const Names<Enum>& names, const std::string&) {
    for (const auto& [key, item] : names) {
      if (key == parameters_.text(name)) value = item;
    }
  }

 private:
  const ParameterSet& parameters_;
};

/// Writes every field back as an assignment NAME=VALUE (in declared units).
class Write {
 public:
  explicit Write(std::string where) : where_(std::move(where)) {}

  template <typename Real>
  void real(const std::string& name, const Real& value, double, double, const std::string&,
            double unit = 1.0) {
    add(name, formatNumber(static_cast<double>(value) / unit));
  }
  template <typename Int>
  void integer(const std::string& name, const Int& value, long long, long long,
               const std::string&) {
    add(name, std::to_string(static_cast<long long>(value)));
  }
  void boolean(const std::string& name, const bool& value, const std::string&) {
    add(name, value ? "true" : "false");
  }
  template <typename Enum>
  void choice(const std::string& name, const Enum& value, const Names<Enum>& names,
              const std::string&) {
    for (const auto& [key, item] : names) {
      if (item == value) add(name, key);
    }
  }

  std::vector<ParameterAssignment> assignments;

 private:
  void add(const std::string& name, std::string value) {
    assignments.push_back({name, std::move(value), where_});
  }
  std::string where_;
};

}  // namespace fields

/// The declaration of Settings' fields, its defaults those of `defaults`.
template <typename Settings>
ParameterSpecs declareFields(Settings defaults = Settings()) {
  fields::Declare declare;
  defaults.fields(declare);
  return std::move(declare.specs);
}

/// Settings with every field read from `parameters` (resolved against declareFields()), the
/// rest of `base` kept.
template <typename Settings>
Settings readFields(const ParameterSet& parameters, Settings base = Settings()) {
  fields::Read read(parameters);
  base.fields(read);
  return base;
}

/// `settings` as assignments (`where` in each), which resolve back to the same values.
template <typename Settings>
std::vector<ParameterAssignment> writeFields(Settings settings, const std::string& where) {
  fields::Write write(where);
  settings.fields(write);
  return std::move(write.assignments);
}

}  // namespace kinolab
