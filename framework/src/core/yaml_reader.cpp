#include "kinolab/core/yaml_reader.hpp"

#include <yaml-cpp/depthguard.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "kinolab/core/files.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {
namespace {

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return "\"" + node.Scalar() + "\"";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a mapping";
  return "nothing";
}

}  // namespace

YamlReader::YamlReader(YAML::Node node, std::shared_ptr<const std::string> source, std::string path)
    : node_(std::move(node)),
      source_(std::move(source)),
      path_(std::move(path)),
      used_(std::make_shared<std::set<std::string>>()) {}

namespace {

/// At most this many nodes repeated through aliases: aliases may share a block
/// (experiments/mpl_benchmark.yaml does), but nested ones ("billion laughs") would make every
/// reader of the file walk an exponential tree. Nodes written out in the file cost nothing
/// (a file's own size bounds them).
constexpr std::size_t kMaxExpandedNodes = 1000000;

/// The walk of checkKeys(): the alias budget and the nodes met so far (by their place in the
/// text: an alias's expansion is the anchored node again, at the anchor's place).
struct KeyWalk {
  std::string source;
  std::size_t budget = kMaxExpandedNodes;
  std::set<int> seen;
  int repeating = 0;  ///< > 0 inside a node met before: every node there is an expansion
};

/// Every mapping key is a plain value, and no mapping has the same key twice (an error at
/// the second one: YAML readers disagree on which value wins, yaml-cpp the first, PyYAML
/// the last); aliases repeat at most kMaxExpandedNodes nodes (`walk.budget` counts down).
void checkKeys(const YAML::Node& node, KeyWalk& walk) {
  const int position = node.Mark().pos;
  const bool again = position >= 0 && !walk.seen.insert(position).second;
  walk.repeating += again ? 1 : 0;
  if (walk.repeating > 0 && walk.budget-- == 0) {
    const YAML::Mark mark = node.Mark();
    throw ConfigError(walk.source + ":" + std::to_string(mark.line + 1) + ":" +
                      std::to_string(mark.column + 1) + ": the file expands to more than " +
                      std::to_string(kMaxExpandedNodes) +
                      " YAML nodes through its aliases (*name): expected aliases that are not "
                      "nested in what they repeat; write the repeated parts out");
  }
  if (node.IsSequence()) {
    for (const YAML::Node& item : node) checkKeys(item, walk);
  } else if (node.IsMap()) {
    std::map<std::string, YAML::Mark> seen;
    for (const auto& entry : node) {
      const YAML::Mark mark = entry.first.Mark();
      const std::string at =
          walk.source + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
      if (!entry.first.IsScalar()) {
        throw ConfigError(at + ": a mapping key must be a plain value, not a list or mapping");
      }
      const auto [found, fresh] = seen.emplace(entry.first.Scalar(), mark);
      if (!fresh) {
        throw ConfigError(at + ": duplicate key '" + entry.first.Scalar() + "' (first at line " +
                          std::to_string(found->second.line + 1) + ")");
      }
      checkKeys(entry.second, walk);
    }
  }
  walk.repeating -= again ? 1 : 0;
}

}  // namespace

YamlReader YamlReader::loadFile(const std::string& path) {
  if (!isRegularFile(path)) {
    throw FileError(path + ": no such file");
  }
  std::ifstream file(path, std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  if (!file && !file.eof()) throw FileError(path + ": cannot read file");
  return loadString(text.str(), path);
}

YamlReader YamlReader::loadString(const std::string& text, const std::string& source) {
  // Text that YAML parsers read differently is refused, not guessed at: bytes that are not
  // UTF-8, NUL and other control characters (tabs and line ends aside).
  for (std::size_t i = 0, line = 1, column = 1; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    const std::size_t length = byte < 0x80         ? 1
                               : (byte >> 5) == 6  ? 2
                               : (byte >> 4) == 14 ? 3
                               : (byte >> 3) == 30 ? 4
                                                   : 0;
    bool valid = length > 0 && i + length <= text.size();
    for (std::size_t k = 1; valid && k < length; ++k) {
      valid = (static_cast<unsigned char>(text[i + k]) >> 6) == 2;
    }
    if (valid && length == 1 && byte < 0x20 && byte != '\n' && byte != '\r' && byte != '\t') {
      valid = false;
    }
    if (!valid) {
      throw ConfigError(source + ":" + std::to_string(line) + ":" + std::to_string(column) +
                        ": byte 0x" + "0123456789abcdef"[byte >> 4] +
                        "0123456789abcdef"[byte & 15] +
                        " is not allowed: expected UTF-8 text without control characters");
    }
    if (byte == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
    i += length;
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::DeepRecursion& error) {
    throw ConfigError(source + ":" + std::to_string(error.mark.line + 1) + ":" +
                      std::to_string(error.mark.column + 1) + ": the YAML nests more than " +
                      std::to_string(error.depth() - 1) +
                      " lists or mappings deep, more than the reader follows: expected a "
                      "flatter file");
  } catch (const YAML::ParserException& error) {
    throw ConfigError(source + ":" + std::to_string(error.mark.line + 1) + ":" +
                      std::to_string(error.mark.column + 1) + ": malformed YAML: " + error.msg);
  }
  KeyWalk walk;
  walk.source = source;
  checkKeys(root, walk);
  return YamlReader(root, std::make_shared<const std::string>(source), "");
}

YamlReader YamlReader::fromNode(YAML::Node node, const std::string& source) {
  return YamlReader(std::move(node), std::make_shared<const std::string>(source), "");
}

std::string YamlReader::where() const {
  std::string text = *source_;
  const YAML::Mark mark = node_.Mark();
  if (mark.line >= 0) {
    text += ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
  }
  return text + ": " + (path_.empty() ? std::string("(top level)") : path_);
}

void YamlReader::fail(const std::string& message) const {
  throw ConfigError(where() + ": " + message);
}

std::string YamlReader::childPath(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

std::optional<YamlReader> YamlReader::optional(std::string_view key) const {
  if (!node_.IsMap()) {
    if (node_.IsNull() || !node_.IsDefined()) return std::nullopt;
    fail("expected a mapping of keys to values, got " + describe(node_));
  }
  used_->insert(std::string(key));
  const YAML::Node child = node_[std::string(key)];
  if (!child.IsDefined()) return std::nullopt;
  return YamlReader(child, source_, childPath(key));
}

YamlReader YamlReader::operator[](std::string_view key) const {
  auto child = optional(key);
  if (!child) fail("missing required key '" + std::string(key) + "'");
  return *child;
}

std::vector<YamlReader> YamlReader::items() const {
  if (!node_.IsSequence()) fail("expected a list, got " + describe(node_));
  std::vector<YamlReader> result;
  for (std::size_t i = 0; i < node_.size(); ++i) {
    result.push_back(YamlReader(node_[i], source_, path_ + "[" + std::to_string(i) + "]"));
  }
  return result;
}

std::vector<std::pair<std::string, YamlReader>> YamlReader::entries() const {
  if (node_.IsNull() || !node_.IsDefined()) return {};
  if (!node_.IsMap()) fail("expected a mapping of keys to values, got " + describe(node_));
  std::vector<std::pair<std::string, YamlReader>> result;
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    used_->insert(key);
    result.emplace_back(key, YamlReader(entry.second, source_, childPath(key)));
  }
  return result;
}

template <>
double YamlReader::as<double>() const {
  if (node_.IsScalar()) {
    try {
      const double value = node_.as<double>();
      if (std::isfinite(value)) return value;
    } catch (const YAML::Exception&) {
    }
  }
  fail("expected a finite number, got " + describe(node_));
}

template <>
long long YamlReader::as<long long>() const {
  if (node_.IsScalar()) {
    try {
      return node_.as<long long>();
    } catch (const YAML::Exception&) {
    }
  }
  fail("expected an integer, got " + describe(node_));
}

template <>
bool YamlReader::as<bool>() const {
  if (node_.IsScalar()) {
    try {
      return node_.as<bool>();
    } catch (const YAML::Exception&) {
    }
  }
  fail("expected true or false, got " + describe(node_));
}

template <>
std::string YamlReader::as<std::string>() const {
  if (!node_.IsScalar()) fail("expected a string, got " + describe(node_));
  return node_.Scalar();
}

double YamlReader::getNumber(std::string_view key, std::optional<double> fallback, double low,
                             double high) const {
  auto child = optional(key);
  if (!child) {
    if (!fallback) fail("missing required key '" + std::string(key) + "'");
    return *fallback;
  }
  const double value = child->as<double>();
  if (value < low || value > high) {
    child->fail("expected a number in [" + formatNumber(low) + ", " + formatNumber(high) +
                "], got " + formatNumber(value));
  }
  return value;
}

long long YamlReader::getInteger(std::string_view key, std::optional<long long> fallback,
                                 long long low, long long high) const {
  auto child = optional(key);
  if (!child) {
    if (!fallback) fail("missing required key '" + std::string(key) + "'");
    return *fallback;
  }
  const long long value = child->as<long long>();
  if (value < low || value > high) {
    child->fail("expected an integer in [" + std::to_string(low) + ", " + std::to_string(high) +
                "], got " + std::to_string(value));
  }
  return value;
}

std::array<double, 3> YamlReader::getVector3(std::string_view key) const {
  const YamlReader child = (*this)[key];
  if (!child.node_.IsSequence() || child.node_.size() != 3) {
    child.fail("expected a list of 3 numbers [x, y, z], got " + describe(child.node_));
  }
  const auto values = child.items();
  return {values[0].as<double>(), values[1].as<double>(), values[2].as<double>()};
}

std::array<double, 2> YamlReader::getInterval(std::string_view key,
                                              std::optional<std::array<double, 2>> fallback,
                                              double min, double max) const {
  auto child = optional(key);
  if (!child) {
    if (!fallback) fail("missing required key '" + std::string(key) + "'");
    return *fallback;
  }
  std::array<double, 2> interval{};
  if (child->node_.IsScalar()) {
    interval[0] = interval[1] = child->as<double>();
  } else if (child->node_.IsSequence() && child->node_.size() == 2) {
    const auto values = child->items();
    interval = {values[0].as<double>(), values[1].as<double>()};
  } else {
    child->fail("expected [low, high] or a single number, got " + describe(child->node_));
  }
  if (interval[0] > interval[1] || interval[0] < min || interval[1] > max) {
    child->fail("expected [low, high] with " + formatNumber(min) +
                " <= low <= high <= " + formatNumber(max) + ", got [" + formatNumber(interval[0]) +
                ", " + formatNumber(interval[1]) + "]");
  }
  return interval;
}

void YamlReader::finish() const {
  if (!node_.IsMap()) return;
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    if (used_->count(key)) continue;
    const std::vector<std::string> known(used_->begin(), used_->end());
    std::string message = "unknown key '" + key + "'" + didYouMean(key, known);
    if (!known.empty()) message += "; known keys: " + join(known, " ");
    YamlReader(entry.first, source_, childPath(key)).fail(message);
  }
}

}  // namespace kinolab
