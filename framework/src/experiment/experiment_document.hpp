#pragma once
// The experiment file as a document, before it is read: `extends:` chains merged, sweep
// points expanded and set at their paths (experiment_document.cpp; used by experiment.cpp).

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "kinolab/core/yaml_reader.hpp"

namespace kinolab::experiment_document {

/// At most this many sweep variants and runs in one experiment: refused up front, so that a
/// small file cannot ask for unbounded work (documented in docs/experiments.md).
constexpr std::size_t kMaxVariants = 100000;
constexpr std::size_t kMaxRuns = 10000000;

/// What setPath() changed in a document, so that it can be undone: the mapping, the key,
/// and the node that was there (none when the key was added).
struct PathChange {
  YAML::Node mapping;
  std::string key;
  std::optional<YAML::Node> original;
};

struct SweepPoint {
  std::vector<std::pair<std::string, YAML::Node>> values;  // path, value
  std::vector<YamlReader> where;                           // for messages
  /// How each value reads in the variant's label: "path=value", or a list item's `label`
  /// on its first value and nothing on the others.
  std::vector<std::string> shown;
};

/// The file with its `extends:` chain merged in (the key itself removed); `chain` holds the
/// files seen, to refuse a cycle. `directories` gets, per top-level key, the folder of the
/// file that set it last (the one whose value stands, for a list or a scalar): the relative
/// paths in a key's value are that file's.
YAML::Node loadWithBase(const std::string& path, std::vector<std::string>& chain,
                        std::map<std::string, std::string>& directories);
/// Sets `value` at a dotted path: mapping keys by name (a missing last key is added), list
/// items by their `id` or their index. Every change is appended to `changes`.
void setPath(YAML::Node root, const std::string& path, const YAML::Node& value,
             const YamlReader& where, std::vector<PathChange>& changes);
/// Undoes setPath()'s changes, the last first.
void undo(std::vector<PathChange>& changes);
/// grid (cartesian product) x zip (parallel lists) x list (explicit points).
std::vector<SweepPoint> expandSweep(const YamlReader& sweep);
/// A scalar's text, or a collection in YAML flow style.
std::string scalarText(const YAML::Node& node);
/// A name that reaches file names, figure paths, sweep paths and Slurm job names: letters,
/// digits, '_', '-' and '.', 1 to 64 characters, not starting with '.' or '-'.
std::string readName(const YamlReader& node);

}  // namespace kinolab::experiment_document
