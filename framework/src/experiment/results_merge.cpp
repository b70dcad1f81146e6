// Merging shard databases into one (ResultsStore::merge): one experiment's shards of one
// split, checked before a byte is written.
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/shard.hpp"

namespace kinolab {

namespace {

/// What the shard databases of a merge are: one experiment's shards of one split.
struct ShardSet {
  int count = 0;                        ///< the split: shards i/count
  std::set<int> indices;                ///< the shards given
  std::vector<std::string> incomplete;  ///< those with fewer runs than planned
  long long planned = 0;                ///< runs planned over the shards given
};

/// Checks every input is a shard of the same experiment and split, each given once, complete
/// unless `partial`; every mistake is an error naming the input.
ShardSet checkShards(const std::vector<std::string>& inputs, bool partial) {
  ShardSet set;
  std::string config_hash;
  for (const std::string& input : inputs) {
    if (!isRegularFile(input)) throw FileError(input + ": no such database");
    ResultsStore shard(input);
    const auto hash = shard.meta("config_hash");
    const auto which = shard.meta("shard");
    const auto planned = shard.metaInteger("runs_planned");
    if (!hash || !which || !planned) {
      throw FileError(input + ": not a kinolab results database (no config hash or shard)");
    }
    if (shard.schemaVersion() != kResultsSchemaVersion) {
      throw ConfigError("merge: " + input + " holds results of schema version " +
                        std::to_string(shard.schemaVersion().value_or(0)) +
                        "; this kinolab merges version " + std::to_string(kResultsSchemaVersion));
    }
    shard.requireCurrentColumns();
    if (config_hash.empty()) config_hash = *hash;
    if (*hash != config_hash) {
      throw ConfigError("merge: " + input + " holds another experiment (config hash " + *hash +
                        ", the first input has " + config_hash + ")");
    }
    const Shard parsed = Shard::parse(*which, input + ": shard");
    if (set.count == 0) set.count = parsed.count;
    if (parsed.count != set.count) {
      throw ConfigError("merge: " + input + " is shard " + *which +
                        " but the first input is one of " + std::to_string(set.count));
    }
    if (!set.indices.insert(parsed.index).second) {
      throw ConfigError("merge: shard " + *which + " is given twice (" + input + ")");
    }
    const long long stored = shard.plannedRunCount();  // runs it no longer plans do not count
    set.planned += *planned;
    if (stored < *planned) set.incomplete.push_back(parsed.text());
    if (!partial && stored < *planned) {
      throw ConfigError(
          "merge: " + input + " (shard " + *which + ") is incomplete: " + std::to_string(stored) +
          " of " + std::to_string(*planned) +
          " runs; finish it with kinolab run --resume --shard " + *which + ", or pass --partial");
    }
  }
  if (!partial && set.indices.size() != static_cast<std::size_t>(set.count)) {
    throw ConfigError("merge: " + std::to_string(set.indices.size()) + " of " +
                      std::to_string(set.count) + " shards given; pass every shard, or --partial");
  }
  return set;
}

}  // namespace

void ResultsStore::merge(const std::string& output, const std::vector<std::string>& inputs,
                         bool partial) {
  if (inputs.empty()) throw ConfigError("merge: no shard databases given");
  // One writer per results directory: two merges (or a merge and a run) into one directory
  // would mix their databases.
  const std::filesystem::path parent = std::filesystem::absolute(output).parent_path();
  const DirectoryLock lock(parent.string(), "kinolab merge into " + output);
  std::error_code error;
  if (std::filesystem::exists(output, error) || error) {
    throw FileError(output + ": exists already; merge writes a new database");
  }
  const ShardSet shards = checkShards(inputs, partial);
  try {
    ResultsStore merged(output);
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      // One shard at a time: SQLite attaches a few databases at most, and not in a transaction.
      std::string quoted;
      for (const char c : inputs[i]) quoted += c == '\'' ? std::string("''") : std::string(1, c);
      merged.execute("ATTACH DATABASE '" + quoted + "' AS shard");
      merged.execute("BEGIN IMMEDIATE");
      for (const char* table : {"runs", "statistics", "progress", "metrics", "worlds",
                                "trajectories", "trees", "flights", "planned"}) {
        merged.execute(std::string("INSERT OR IGNORE INTO ") + table + " SELECT * FROM shard." +
                       table);
      }
      if (i == 0) merged.execute("INSERT INTO meta SELECT * FROM shard.meta");
      merged.execute("COMMIT");
      merged.execute("DETACH DATABASE shard");
    }
    // A partial merge says so: it is not a complete result, and no run resumes into it.
    std::vector<std::string> missing;
    for (int index = 1; index <= shards.count; ++index) {
      if (!shards.indices.count(index)) missing.push_back(Shard{index, shards.count}.text());
    }
    std::string from =
        std::to_string(inputs.size()) + " of " + std::to_string(shards.count) + " shards";
    if (!missing.empty()) from += "; missing " + join(missing, ", ");
    if (!shards.incomplete.empty()) from += "; incomplete " + join(shards.incomplete, ", ");
    const bool complete = missing.empty() && shards.incomplete.empty();
    merged.setMeta({{"shard", complete ? "1/1" : "partial"},
                    {"runs_planned", std::to_string(shards.planned)},
                    {"merged_from", from}});
  } catch (...) {
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(output + suffix);
    throw;
  }
}

}  // namespace kinolab
