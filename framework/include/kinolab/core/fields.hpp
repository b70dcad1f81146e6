#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <sstream>
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
///
/// The files kinolab reads (the experiment file, world specs, sampling studies) declare their
/// mappings the same way, with a few more kinds: text, an interval, a point, a nested mapping
/// (`group`, a struct with fields() of its own, or a std::optional of one: present when
/// given) and a list of mappings. Those are read from YAML (ReadYaml, yaml_fields.hpp),
/// written as the canonical text of an identity (Canonical) and declared for the docs
/// (Declare); Read and Write (ParameterSet) take the plugin parameter kinds only.
///
///   struct Budget {
///     double time = 10.0;
///     long long memory_mb = 4096;
///     template <typename Fields>
///     void fields(Fields& f) {
///       f.real("time", time, 0.001, 1e6, "planning time per plan, s");
///       f.integer("memory_mb", memory_mb, 16, 1 << 24, "memory of the worker, MB");
///     }
///   };
///
/// Every kind takes a last, optional Flags argument (`{.required = true}`).
namespace fields {

template <typename Enum>
using Names = std::vector<std::pair<std::string, Enum>>;

/// What a field is beyond its value and range.
struct Flags {
  /// The key must be given: the field has no default (its initialiser only fills the struct).
  bool required = false;
  /// Written in the canonical text (Canonical): false for what does not change a result (a
  /// name) or is counted apart (how many random queries follow the one whose rule it is).
  bool identity = true;
};

/// Declares every field with the value it holds as its default (a required field's value
/// only fills the declaration: it is brought into range).
class Declare {
 public:
  template <typename Real>
  void real(const std::string& name, const Real& value, double minimum, double maximum,
            std::string doc, double unit = 1.0, Flags flags = {}) {
    const double kept = declared(static_cast<double>(value), unit);
    specs.real(name, flags.required ? std::clamp(kept, minimum, maximum) : kept, minimum, maximum,
               std::move(doc));
    mark(flags);
  }
  template <typename Real>
  void real(const std::string& name, const Real& value, double minimum, double maximum,
            std::string doc, Flags flags) {
    real(name, value, minimum, maximum, std::move(doc), 1.0, flags);
  }
  template <typename Int>
  void integer(const std::string& name, const Int& value, long long minimum, long long maximum,
               std::string doc, Flags flags = {}) {
    const auto kept = static_cast<long long>(value);
    specs.integer(name, flags.required ? std::clamp(kept, minimum, maximum) : kept, minimum,
                  maximum, std::move(doc));
    mark(flags);
  }
  /// A count in [0, maximum], or true (every one: kept as -1) or false (none: 0).
  template <typename Int>
  void countOrAll(const std::string& name, const Int& value, long long maximum, std::string doc,
                  Flags flags = {}) {
    integer(name, std::max<long long>(value, 0), 0, maximum,
            std::move(doc) + " (true: all, false: none)", flags);
  }
  void boolean(const std::string& name, const bool& value, std::string doc, Flags flags = {}) {
    specs.boolean(name, value, std::move(doc));
    mark(flags);
  }
  template <typename Enum>
  void choice(const std::string& name, const Enum& value, const Names<Enum>& names,
              std::string doc, Flags flags = {}) {
    std::vector<std::string> keys;
    std::string chosen;
    for (const auto& [key, item] : names) {
      keys.push_back(key);
      if (item == value) chosen = key;
    }
    specs.choice(name, chosen, std::move(keys), std::move(doc));
    mark(flags);
  }
  void text(const std::string& name, const std::string& value, std::string doc,
            Flags flags = {}) {
    specs.text(name, value, std::move(doc));
    mark(flags);
  }
  void interval(const std::string& name, const std::array<double, 2>& value, double minimum,
                double maximum, std::string doc, Flags flags = {}) {
    specs.interval(name, value, minimum, maximum, std::move(doc));
    mark(flags);
  }
  void point(const std::string& name, const Eigen::Vector3d& value, std::string doc,
             Flags flags = {}) {
    const double infinity = std::numeric_limits<double>::infinity();
    specs.reals(name, {value.x(), value.y(), value.z()}, -infinity, infinity, 3, std::move(doc));
    mark(flags);
  }
  template <typename Settings>
  void group(const std::string& name, Settings& value, std::string doc, Flags flags = {}) {
    Declare members;
    value.fields(members);
    specs.group(name, std::move(members.specs), std::move(doc));
    mark(flags);
  }
  template <typename Settings>
  void group(const std::string& name, std::optional<Settings>& value, std::string doc,
             Flags flags = {}) {
    Settings shown = value.value_or(Settings());
    group(name, shown, std::move(doc), flags);
  }
  template <typename Settings>
  void list(const std::string& name, std::vector<Settings>&, std::string doc, Flags flags = {}) {
    Declare members;
    Settings item;
    item.fields(members);
    specs.groupList(name, std::move(members.specs), std::move(doc));
    mark(flags);
  }

  ParameterSpecs specs;

 private:
  void mark(Flags flags) {
    if (flags.required) specs.required();
  }
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
            double unit = 1.0, Flags = {}) {
    value = static_cast<Real>(parameters_.real(name) * unit);
  }
  template <typename Real>
  void real(const std::string& name, Real& value, double minimum, double maximum,
            const std::string& doc, Flags flags) {
    real(name, value, minimum, maximum, doc, 1.0, flags);
  }
  template <typename Int>
  void integer(const std::string& name, Int& value, long long, long long, const std::string&,
               Flags = {}) {
    value = static_cast<Int>(parameters_.integer(name));
  }
  void boolean(const std::string& name, bool& value, const std::string&, Flags = {}) {
    value = parameters_.boolean(name);
  }
  template <typename Enum>
  void choice(const std::string& name, Enum& value, const Names<Enum>& names, const std::string&,
              Flags = {}) {
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
            double unit = 1.0, Flags = {}) {
    add(name, formatNumber(static_cast<double>(value) / unit));
  }
  template <typename Real>
  void real(const std::string& name, const Real& value, double minimum, double maximum,
            const std::string& doc, Flags flags) {
    real(name, value, minimum, maximum, doc, 1.0, flags);
  }
  template <typename Int>
  void integer(const std::string& name, const Int& value, long long, long long,
               const std::string&, Flags = {}) {
    add(name, std::to_string(static_cast<long long>(value)));
  }
  void boolean(const std::string& name, const bool& value, const std::string&, Flags = {}) {
    add(name, value ? "true" : "false");
  }
  template <typename Enum>
  void choice(const std::string& name, const Enum& value, const Names<Enum>& names,
              const std::string&, Flags = {}) {
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

/// How Canonical writes: `name=value` or values alone, what separates the fields, and reals as
/// the shortest decimal that reads back or in hexadecimal (std::hexfloat); both are exact.
struct CanonicalStyle {
  bool names = false;
  std::string separator = " ";
  bool hex = false;
};

/// Writes the fields that make an identity (Flags::identity) as text, in declaration order: a
/// world's cache key (`seed=7 resolution=0x1.999999999999ap-4`, names and hexadecimal) or a
/// run's budget (`10/4096/0`, values alone). With names a point is `x,y,z`, an interval
/// `low,high`, a choice its name and a group's members stand for themselves; without, a point
/// is `(x, y, z)`, an interval's ends two values, a choice its kept value (the enum's number)
/// and a group's members follow its name. An absent optional group writes nothing. These
/// texts are hashed into run and world identities: keep them byte for byte.
class Canonical {
 public:
  explicit Canonical(CanonicalStyle style = {}) : style_(std::move(style)) {}

  template <typename Real>
  void real(const std::string& name, const Real& value, double, double, const std::string&,
            double = 1.0, Flags flags = {}) {
    if (flags.identity) add(name, number(static_cast<double>(value)));
  }
  template <typename Real>
  void real(const std::string& name, const Real& value, double, double, const std::string&,
            Flags flags) {
    if (flags.identity) add(name, number(static_cast<double>(value)));
  }
  template <typename Int>
  void integer(const std::string& name, const Int& value, long long, long long,
               const std::string&, Flags flags = {}) {
    if (flags.identity) add(name, std::to_string(value));
  }
  template <typename Int>
  void countOrAll(const std::string& name, const Int& value, long long, const std::string&,
                  Flags flags = {}) {
    if (flags.identity) add(name, std::to_string(value));
  }
  void boolean(const std::string& name, const bool& value, const std::string&, Flags flags = {}) {
    if (flags.identity) add(name, value ? "true" : "false");
  }
  template <typename Enum>
  void choice(const std::string& name, const Enum& value, const Names<Enum>& names,
              const std::string&, Flags flags = {}) {
    if (!flags.identity) return;
    if (!style_.names) {
      add(name, std::to_string(static_cast<long long>(value)));
      return;
    }
    for (const auto& [key, item] : names) {
      if (item == value) add(name, key);
    }
  }
  void text(const std::string& name, const std::string& value, const std::string&,
            Flags flags = {}) {
    if (flags.identity) add(name, value);
  }
  void interval(const std::string& name, const std::array<double, 2>& value, double, double,
                const std::string&, Flags flags = {}) {
    if (!flags.identity) return;
    if (style_.names) {
      add(name, number(value[0]) + "," + number(value[1]));
    } else {
      items_.push_back(number(value[0]));
      items_.push_back(number(value[1]));
    }
  }
  void point(const std::string& name, const Eigen::Vector3d& value, const std::string&,
             Flags flags = {}) {
    if (!flags.identity) return;
    std::string text = style_.names ? "" : "(";
    for (int axis = 0; axis < 3; ++axis) {
      if (axis > 0) text += style_.names ? "," : ", ";
      text += number(value[axis]);
    }
    if (!style_.names) text += ')';
    add(name, std::move(text));
  }
  template <typename Settings>
  void group(const std::string& name, Settings& value, const std::string&, Flags flags = {}) {
    if (!flags.identity) return;
    Canonical members(style_);
    value.fields(members);
    if (!style_.names) items_.push_back(name);
    items_.insert(items_.end(), members.items_.begin(), members.items_.end());
  }
  template <typename Settings>
  void group(const std::string& name, std::optional<Settings>& value, const std::string& doc,
             Flags flags = {}) {
    if (value) group(name, *value, doc, flags);
  }
  template <typename Settings>
  void list(const std::string& name, std::vector<Settings>& value, const std::string& doc,
            Flags flags = {}) {
    for (Settings& item : value) group(name, item, doc, flags);
  }

  /// The fields written so far, separated by the style's separator.
  std::string text() const { return join(items_, style_.separator); }

 private:
  void add(const std::string& name, std::string value) {
    items_.push_back(style_.names ? name + "=" + value : std::move(value));
  }
  std::string number(double value) const {
    if (!style_.hex) return formatNumber(value);
    std::ostringstream out;
    out << std::hexfloat << value;
    return out.str();
  }

  CanonicalStyle style_;
  std::vector<std::string> items_;
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

/// The canonical text of the fields of `settings` that make its identity (fields::Canonical).
/// The writer only reads; fields() is one non-const template for every visitor.
template <typename Settings>
std::string canonicalFields(const Settings& settings, fields::CanonicalStyle style = {}) {
  fields::Canonical canonical(std::move(style));
  const_cast<Settings&>(settings).fields(canonical);
  return canonical.text();
}

}  // namespace kinolab
