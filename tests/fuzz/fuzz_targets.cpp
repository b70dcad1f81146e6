#include "fuzz_targets.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab::fuzz {
namespace {

namespace fs = std::filesystem;

/// A private folder for this process's files (loaders read paths, not bytes).
const fs::path& scratch() {
  static const fs::path directory = [] {
    const fs::path path = fs::temp_directory_path() / ("kinolab_fuzz_" + std::to_string(getpid()));
    fs::create_directories(path);
    // A small world beside the experiment files, for `spec: world.yaml`.
    std::ofstream(path / "world.yaml") << "resolution: 0.5\nbounds: {min: [0, 0, 0], max: [4, "
                                          "4, 2]}\ngenerators: [{type: forest, density: 0.1}]\n";
    return path;
  }();
  return directory;
}

std::string write(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const fs::path path = scratch() / name;
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path.string();
}

/// Runs `load`, accepting a kinolab::Error as the refusal of bad input.
template <typename Load>
void refusedOrLoaded(Load&& load) {
  try {
    load();
  } catch (const Error&) {
  }
}

void experimentFile(const std::uint8_t* data, std::size_t size) {
  registerBuiltinPlugins();
  const std::string path = write("experiment.yaml", data, size);
  refusedOrLoaded([&] {
    const Experiment experiment = Experiment::fromFile(path);
    (void)experiment.runs();
  });
}

void worldSpec(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  refusedOrLoaded([&] {
    const WorldSpec spec = WorldSpec::fromText(text, "fuzz.yaml", scratch().string());
    // Small worlds are built too (grid and ESDF); large ones only validated.
    const Eigen::Vector3d voxels = (spec.bounds.max - spec.bounds.min) / spec.resolution;
    if (voxels.prod() < 2e5) (void)World::build(spec);
  });
}

void octomapFile(const std::uint8_t* data, std::size_t size) {
  const std::string path = write("map.bt", data, size);
  refusedOrLoaded([&] {
    const WorldSpec spec = WorldSpec::fromText(
        "resolution: 0.25\ngenerators:\n  - {type: octomap, file: " + path + "}\n", "fuzz.yaml",
        scratch().string());
    const Eigen::Vector3d voxels = (spec.bounds.max - spec.bounds.min) / spec.resolution;
    if (voxels.prod() < 2e6) (void)World::buildGrid(spec);
  });
}

void resultsDatabase(const std::uint8_t* data, std::size_t size) {
  const std::string input = write("shard.sqlite", data, size);
  const std::string output = (scratch() / "merged.sqlite").string();
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(output + suffix);
  refusedOrLoaded([&] { ResultsStore::merge(output, {input}, true); });
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(input + suffix);
}

}  // namespace

const std::vector<Target>& targets() {
  static const std::vector<Target> all = {{"experiment", experimentFile},
                                          {"world_spec", worldSpec},
                                          {"octomap", octomapFile},
                                          {"results_db", resultsDatabase}};
  return all;
}

}  // namespace kinolab::fuzz
