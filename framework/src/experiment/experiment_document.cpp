#include "experiment_document.hpp"

#include <algorithm>
#include <filesystem>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab::experiment_document {
namespace {

namespace fs = std::filesystem;

/// Mappings merge key by key (the child wins); lists and scalars are replaced whole. Nodes
/// are shared, not copied, so that every value keeps its file position for messages.
YAML::Node merge(YAML::Node base, const YAML::Node& child) {
  if (!base.IsMap() || !child.IsMap()) return child;
  for (const auto& entry : child) {
    const std::string key = entry.first.Scalar();
    YAML::Node existing = base[key];
    if (existing.IsDefined() && existing.IsMap() && entry.second.IsMap()) {
      merge(existing, entry.second);
    } else {
      base[key] = entry.second;
    }
  }
  return base;
}

}  // namespace

/// The file with its `extends:` chain merged in (the key itself removed).
YAML::Node loadWithBase(const std::string& path, std::vector<std::string>& chain,
                        std::map<std::string, std::string>& directories) {
  std::error_code error;
  const std::string canonical = fs::weakly_canonical(path, error).string();
  if (error) throw FileError(path + ": " + error.message());
  if (std::find(chain.begin(), chain.end(), canonical) != chain.end()) {
    throw ConfigError(path + ": extends itself through " + join(chain, " -> "));
  }
  chain.push_back(canonical);
  const YamlReader file = YamlReader::loadFile(path);
  YAML::Node node = file.node();
  if (!node.IsMap()) file.fail("expected a mapping (an experiment), got something else");
  const std::string directory = fs::path(path).parent_path().string();
  // This file's keys are its folder's (after its base's: the child wins). Nodes are
  // references: assigning one node to another would change the first's content.
  const auto own = [&] {
    for (const auto& entry : node) directories[entry.first.Scalar()] = directory;
  };
  if (const auto base = file.optional("extends")) {
    const std::string base_path =
        (fs::path(directory) / base->as<std::string>()).lexically_normal().string();
    if (!isRegularFile(base_path)) base->fail("no such file: " + base_path);
    node.remove("extends");
    const YAML::Node merged = merge(loadWithBase(base_path, chain, directories), node);
    own();
    return merged;
  }
  own();
  return node;
}

/// Sets `value` at a dotted path: mapping keys by name (a missing last key is added), list
/// items by their `id` or their index. Every change is appended to `changes`. The value node
/// must belong to the same document: nodes of another document would merge its whole memory
/// into this one on every call.
void setPath(YAML::Node root, const std::string& path, const YAML::Node& value,
             const YamlReader& at, std::vector<PathChange>& changes) {
  std::vector<std::string> parts;
  std::size_t begin = 0;
  for (std::size_t dot = path.find('.'); begin <= path.size(); dot = path.find('.', begin)) {
    if (dot == std::string::npos) dot = path.size();
    parts.push_back(path.substr(begin, dot - begin));
    begin = dot + 1;
  }
  YAML::Node node = root;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string& part = parts[i];
    const bool last = i + 1 == parts.size();
    if (node.IsSequence()) {
      YAML::Node found;
      bool matched = false;
      for (std::size_t k = 0; k < node.size() && !matched; ++k) {
        const YAML::Node item = node[k];
        matched = (item.IsMap() && item["id"] && item["id"].Scalar() == part) ||
                  std::to_string(k) == part;
        if (matched) found.reset(item);
      }
      if (!matched) at.fail("sweep path '" + path + "': no list item '" + part + "'");
      if (last) {
        at.fail("sweep path '" + path + "' names a whole list item; name one of its keys");
      }
      node.reset(found);
    } else if (node.IsMap()) {
      const bool exists = node[part].IsDefined();
      if (!last && exists) {
        node.reset(node[part]);
        continue;
      }
      // Replaced by removing and adding the key, so that the original node stays intact for
      // the undo (assigning to it would change it in place).
      changes.push_back(
          {node, part, exists ? std::optional<YAML::Node>(node[part]) : std::nullopt});
      node.remove(part);
      // A missing mapping is created; validation then rejects a key that does not exist.
      node[part] = last ? value : YAML::Node(YAML::NodeType::Map);
      if (last) return;
      node.reset(node[part]);
    } else {
      at.fail("sweep path '" + path + "': '" + part + "' is below a value");
    }
  }
}

/// Undoes setPath()'s changes, the last first.
void undo(std::vector<PathChange>& changes) {
  for (auto change = changes.rbegin(); change != changes.rend(); ++change) {
    change->mapping.remove(change->key);
    if (change->original) change->mapping[change->key] = *change->original;
  }
  changes.clear();
}

namespace {

/// `zip:` axes, walked in parallel: one option per index.
std::vector<SweepPoint> zipOptions(const YamlReader& zip) {
  std::vector<SweepPoint> rows;
  std::size_t length = 0;
  for (const auto& [path, values] : zip.entries()) {
    const std::vector<YamlReader> items = values.items();
    if (rows.empty()) {
      length = items.size();
      rows.resize(length);
      if (length == 0) values.fail("a zip axis needs at least one value");
    } else if (items.size() != length) {
      values.fail("zip axes must have equal lengths: " + std::to_string(items.size()) +
                  " values here, " + std::to_string(length) + " in the first axis");
    }
    for (std::size_t i = 0; i < items.size(); ++i) {
      rows[i].values.emplace_back(path, items[i].node());
      rows[i].where.push_back(items[i]);
      rows[i].shown.push_back(path + "=" + scalarText(items[i].node()));
    }
  }
  return rows;
}

/// `list:` items, each one option (a `label` names it).
std::vector<SweepPoint> listOptions(const YamlReader& list) {
  std::vector<SweepPoint> options;
  std::set<std::string> labels;  // a label names one point: results group by it
  for (const YamlReader& item : list.items()) {
    SweepPoint option;
    std::string label;
    for (const auto& [path, value] : item.entries()) {
      if (path == "label") {
        label = readName(value);
        if (!labels.insert(label).second)
          value.fail("another list item has the label '" + label + "'");
        continue;
      }
      option.values.emplace_back(path, value.node());
      option.where.push_back(value);
      option.shown.push_back(path + "=" + scalarText(value.node()));
    }
    if (option.values.empty()) item.fail("a sweep list item needs at least one path: value");
    if (!label.empty()) {
      // The item reads as its label: on its first value, nothing on the others.
      option.shown.assign(option.values.size(), "");
      option.shown.front() = label;
    }
    options.push_back(std::move(option));
  }
  return options;
}

}  // namespace

/// grid (cartesian product) x zip (parallel lists) x list (explicit points).
std::vector<SweepPoint> expandSweep(const YamlReader& sweep) {
  std::vector<SweepPoint> points(1);
  const auto product = [&](const std::vector<SweepPoint>& options) {
    // Refused before anything is expanded: the variant count is the product of the axes.
    if (points.size() * options.size() > kMaxVariants) {
      sweep.fail(std::to_string(points.size()) + " x " + std::to_string(options.size()) +
                 " variants or more; a sweep has at most " + std::to_string(kMaxVariants) +
                 " (split it into several experiments)");
    }
    std::vector<SweepPoint> next;
    next.reserve(points.size() * options.size());
    for (const SweepPoint& point : points) {
      for (const SweepPoint& option : options) {
        SweepPoint combined = point;
        combined.values.insert(combined.values.end(), option.values.begin(), option.values.end());
        combined.where.insert(combined.where.end(), option.where.begin(), option.where.end());
        combined.shown.insert(combined.shown.end(), option.shown.begin(), option.shown.end());
        next.push_back(std::move(combined));
      }
    }
    points = std::move(next);
  };
  if (const auto grid = sweep.optional("grid")) {
    for (const auto& [path, values] : grid->entries()) {
      std::vector<SweepPoint> options;
      for (const YamlReader& value : values.items()) {
        options.push_back(
            {{{path, value.node()}}, {value}, {path + "=" + scalarText(value.node())}});
      }
      if (options.empty()) values.fail("a grid axis needs at least one value");
      product(options);
    }
  }
  if (const auto zip = sweep.optional("zip")) {
    const std::vector<SweepPoint> rows = zipOptions(*zip);
    if (!rows.empty()) product(rows);
  }
  if (const auto list = sweep.optional("list")) {
    const std::vector<SweepPoint> options = listOptions(*list);
    if (options.empty()) list->fail("a sweep list needs at least one item");
    product(options);
  }
  sweep.finish();
  return points;
}

std::string scalarText(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

/// A name that reaches file names, figure paths, sweep paths and Slurm job names: letters,
/// digits, '_', '-' and '.', 1 to 64 characters, not starting with '.' or '-'.
std::string readName(const YamlReader& node) {
  const std::string name = node.as<std::string>();
  const bool valid = !name.empty() && name.size() <= 64 && name.front() != '.' &&
                     name.front() != '-' && std::all_of(name.begin(), name.end(), [](char c) {
                       return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                              (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
                     });
  if (!valid) {
    node.fail("'" + printable(name) +
              "' is not a valid name: use 1 to 64 letters, digits, '_', '-' or '.', not "
              "starting with '.' or '-'");
  }
  return name;
}

}  // namespace kinolab::experiment_document
