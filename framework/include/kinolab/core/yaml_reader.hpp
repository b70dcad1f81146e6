#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kinolab/core/error.hpp"

namespace kinolab {

/// Strict, located access to a YAML document. Every error names the file, the line and the
/// key path (`forest.yaml:12:7: generators[1].radius: expected ...`), and a mapping whose
/// keys were not all read can be rejected with `finish()`, so a misspelt key is never a
/// silent default.
class YamlReader {
 public:
  /// Loads a file; a missing file is a FileError, malformed YAML a ConfigError.
  static YamlReader loadFile(const std::string& path);
  /// Parses text; `source` names it in messages.
  static YamlReader loadString(const std::string& text, const std::string& source);
  /// Reads an already parsed (e.g. merged or edited) document; `source` names it in messages.
  static YamlReader fromNode(YAML::Node node, const std::string& source);
  /// The node underneath (for documents that are edited before they are read).
  const YAML::Node& node() const { return node_; }

  /// "file:line:column: key.path" for messages.
  std::string where() const;
  [[noreturn]] void fail(const std::string& message) const;

  bool isMap() const { return node_.IsMap(); }
  bool isSequence() const { return node_.IsSequence(); }

  /// A required child of a mapping.
  YamlReader operator[](std::string_view key) const;
  std::optional<YamlReader> optional(std::string_view key) const;
  /// The items of a sequence (error when this is not one).
  std::vector<YamlReader> items() const;
  /// Every key and value of a mapping, in file order, each marked as read (an absent or
  /// empty node has none).
  std::vector<std::pair<std::string, YamlReader>> entries() const;

  /// This scalar converted to T; the message says what was expected.
  template <typename T>
  T as() const;

  template <typename T>
  T get(std::string_view key) const {
    return (*this)[key].as<T>();
  }
  template <typename T>
  T get(std::string_view key, const T& fallback) const {
    auto child = optional(key);
    return child ? child->as<T>() : fallback;
  }
  /// A number in [low, high]; `fallback` when the key is absent.
  double getNumber(std::string_view key, std::optional<double> fallback, double low,
                   double high) const;
  /// An integer in [low, high]; `fallback` when the key is absent.
  long long getInteger(std::string_view key, std::optional<long long> fallback, long long low,
                       long long high) const;
  /// A list of three numbers.
  std::array<double, 3> getVector3(std::string_view key) const;
  /// `[low, high]` with low <= high, both in [min, max]; a single number means [x, x].
  std::array<double, 2> getInterval(std::string_view key,
                                    std::optional<std::array<double, 2>> fallback, double min,
                                    double max) const;

  /// Rejects every key of this mapping that was never read, naming the closest known key.
  void finish() const;

 private:
  YamlReader(YAML::Node node, std::shared_ptr<const std::string> source, std::string path);
  std::string childPath(std::string_view key) const;

  YAML::Node node_;
  std::shared_ptr<const std::string> source_;
  std::string path_;
  std::shared_ptr<std::set<std::string>> used_;
};

template <>
double YamlReader::as<double>() const;
template <>
long long YamlReader::as<long long>() const;
template <>
bool YamlReader::as<bool>() const;
template <>
std::string YamlReader::as<std::string>() const;

}  // namespace kinolab
