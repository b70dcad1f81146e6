#include "kinolab/experiment/shard.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <set>

#include "kinolab/core/error.hpp"

namespace kinolab {
namespace {

bool parseWhole(std::string_view text, int& value) {
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc() && end == text.data() + text.size() && !text.empty();
}

}  // namespace

Shard Shard::parse(std::string_view text, std::string_view where) {
  const std::size_t slash = text.find('/');
  Shard shard;
  if (slash == std::string_view::npos || !parseWhole(text.substr(0, slash), shard.index) ||
      !parseWhole(text.substr(slash + 1), shard.count)) {
    throw ConfigError(std::string(where) + " '" + std::string(text) + "': expected i/N, e.g. 2/8");
  }
  if (shard.count < 1 || shard.index < 1 || shard.index > shard.count) {
    throw ConfigError(std::string(where) + " '" + std::string(text) +
                      "': expected i/N with 1 <= i <= N");
  }
  return shard;
}

std::vector<RunSpec> Shard::select(const std::vector<RunSpec>& runs) const {
  std::vector<std::string> hashes;
  hashes.reserve(runs.size());
  for (const RunSpec& run : runs) hashes.push_back(run.hash);
  std::sort(hashes.begin(), hashes.end());
  std::set<std::string> mine;
  for (std::size_t i = static_cast<std::size_t>(index - 1); i < hashes.size();
       i += static_cast<std::size_t>(count)) {
    mine.insert(hashes[i]);
  }
  std::vector<RunSpec> shard;
  for (const RunSpec& run : runs) {
    if (mine.count(run.hash)) shard.push_back(run);
  }
  return shard;
}

std::string Shard::parentDirectory(const std::string& out) {
  return (std::filesystem::path(out) / "shards").string();
}

std::string Shard::directory(const std::string& out, int index) {
  return (std::filesystem::path(parentDirectory(out)) / std::to_string(index)).string();
}

}  // namespace kinolab
