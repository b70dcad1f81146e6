#pragma once
// Reading a field list (fields.hpp) from a YAML mapping. Beside yaml_reader.hpp, it needs
// yaml-cpp, a private dependency: it serves the framework's own files and is not installed.

#include <optional>
#include <string>
#include <vector>

#include "kinolab/core/fields.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_reader.hpp"

namespace kinolab {
namespace fields {

/// Reads every field from a YAML mapping: a key given is checked against the field's kind and
/// range (a ConfigError naming the file, line, key path and what was expected), an absent key
/// leaves the field's value (its struct's default) or, for a required field, is an error. A
/// nested group or list item must hold nothing but its declared keys (YamlReader::finish());
/// the outer mapping is left for the caller to finish, after the keys it reads by hand.
class ReadYaml {
 public:
  explicit ReadYaml(const YamlReader& mapping) : mapping_(mapping) {}

  template <typename Real>
  void real(const std::string& name, Real& value, double minimum, double maximum,
            const std::string&, double unit = 1.0, Flags flags = {}) {
    if (!present(name, flags)) return;
    value = static_cast<Real>(mapping_.getNumber(name, std::nullopt, minimum, maximum) * unit);
  }
  template <typename Real>
  void real(const std::string& name, Real& value, double minimum, double maximum,
            const std::string& doc, Flags flags) {
    real(name, value, minimum, maximum, doc, 1.0, flags);
  }
  template <typename Int>
  void integer(const std::string& name, Int& value, long long minimum, long long maximum,
               const std::string&, Flags flags = {}) {
    if (!present(name, flags)) return;
    value = static_cast<Int>(mapping_.getInteger(name, std::nullopt, minimum, maximum));
  }
  template <typename Int>
  void countOrAll(const std::string& name, Int& value, long long maximum, const std::string&,
                  Flags flags = {}) {
    if (!present(name, flags)) return;
    const YamlReader node = mapping_[name];
    const std::string text = node.as<std::string>();
    if (text == "true" || text == "false") {
      value = text == "true" ? -1 : 0;
      return;
    }
    value = static_cast<Int>(mapping_.getInteger(name, std::nullopt, 0, maximum));
  }
  void boolean(const std::string& name, bool& value, const std::string&, Flags flags = {}) {
    if (present(name, flags)) value = mapping_[name].as<bool>();
  }
  template <typename Enum>
  void choice(const std::string& name, Enum& value, const Names<Enum>& names, const std::string&,
              Flags flags = {}) {
    if (!present(name, flags)) return;
    const YamlReader node = mapping_[name];
    const std::string text = node.as<std::string>();
    std::vector<std::string> keys;
    for (const auto& [key, item] : names) {
      if (key == text) {
        value = item;
        return;
      }
      keys.push_back(key);
    }
    std::string expected = keys.back();
    if (keys.size() > 1) {
      keys.pop_back();
      expected = join(keys, ", ") + " or " + expected;
      keys.push_back(names.back().first);
    }
    node.fail("unknown " + name + " '" + text + "'" + didYouMean(text, keys) + "; expected " +
              expected);
  }
  void text(const std::string& name, std::string& value, const std::string&, Flags flags = {}) {
    if (present(name, flags)) value = mapping_[name].as<std::string>();
  }
  void interval(const std::string& name, std::array<double, 2>& value, double minimum,
                double maximum, const std::string&, Flags flags = {}) {
    if (present(name, flags)) value = mapping_.getInterval(name, std::nullopt, minimum, maximum);
  }
  void point(const std::string& name, Eigen::Vector3d& value, const std::string&,
             Flags flags = {}) {
    if (!present(name, flags)) return;
    const std::array<double, 3> read = mapping_.getVector3(name);
    value = {read[0], read[1], read[2]};
  }
  template <typename Settings>
  void group(const std::string& name, Settings& value, const std::string&, Flags flags = {}) {
    if (present(name, flags)) readNested(mapping_[name], value);
  }
  template <typename Settings>
  void group(const std::string& name, std::optional<Settings>& value, const std::string&,
             Flags flags = {}) {
    if (present(name, flags)) readNested(mapping_[name], value.emplace());
  }
  template <typename Settings>
  void list(const std::string& name, std::vector<Settings>& value, const std::string&,
            Flags flags = {}) {
    if (!present(name, flags)) return;
    value.clear();
    for (const YamlReader& item : mapping_[name].items()) readNested(item, value.emplace_back());
  }

 private:
  bool present(const std::string& name, Flags flags) const {
    if (mapping_.optional(name)) return true;
    if (flags.required) mapping_.fail("missing required key '" + name + "'");
    return false;
  }
  template <typename Settings>
  static void readNested(const YamlReader& mapping, Settings& value) {
    ReadYaml nested(mapping);
    value.fields(nested);
    mapping.finish();
  }

  YamlReader mapping_;
};

}  // namespace fields

/// Reads the fields of `settings` from the YAML `mapping` (fields::ReadYaml); keys absent keep
/// the values `settings` holds. The caller finishes `mapping` once it has read its own keys.
template <typename Settings>
void readYamlFields(const YamlReader& mapping, Settings& settings) {
  fields::ReadYaml read(mapping);
  settings.fields(read);
}

}  // namespace kinolab
