#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "kinolab/experiment/experiment.hpp"

namespace kinolab {

/// Shard `index` of `count` (1-based) of an experiment: parsed once from "i/N" (`--shard`,
/// a database's `shard` meta), written back with text().
struct Shard {
  int index = 1;
  int count = 1;

  /// "i/N" with 1 <= i <= N; anything else is a ConfigError naming `where` and the text.
  static Shard parse(std::string_view text, std::string_view where = "--shard");
  std::string text() const { return std::to_string(index) + "/" + std::to_string(count); }
  bool operator==(const Shard&) const = default;

  /// The runs whose position in the hash order is index - 1 modulo count: deterministic and
  /// disjoint, and the shards of one count together are every run exactly once.
  std::vector<RunSpec> select(const std::vector<RunSpec>& runs) const;

  /// Where `kinolab slurm` puts the shards' results under its output directory: OUT/shards,
  /// and shard `index`'s in OUT/shards/<index>.
  static std::string parentDirectory(const std::string& out);
  static std::string directory(const std::string& out, int index);
};

}  // namespace kinolab
