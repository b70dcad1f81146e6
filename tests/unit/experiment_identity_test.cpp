// The identity of stored experiments and cached worlds, pinned: the canonical texts that key
// the world cache and make the run hashes, and the run hashes of every shipped experiment, as
// the hand-written readers and writers computed them before the experiment file's fields were
// declared in field lists. A resumed or merged experiment finds its stored runs by these
// hashes and a world its cache file by its spec's hash: a change here orphans them. Change an
// expectation only for a deliberate change of identity (a planner's or generator's new
// parameter is one), and say so in the commit.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kinolab/core/hash.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = KINOLAB_SOURCE_DIR;

/// The first line of a world's canonical text: what the spec's own fields write (the
/// generators' lines follow; the world's hash covers them).
std::string firstLine(const std::string& text) { return text.substr(0, text.find('\n')); }

/// One digest of every run's hash, in order, and the configuration's hash.
std::string runsDigest(const Experiment& experiment) {
  std::string text = experiment.config_hash;
  for (const RunSpec& run : experiment.runs()) text += " " + run.hash;
  return toHex(hashString(text));
}

class ExperimentIdentityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::loadTestPlugins();
    directory_ = fs::temp_directory_path() /
                 ("kinolab_identity_test_" + std::to_string(getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(directory_);
    fs::create_directories(directory_);
  }
  void TearDown() override { fs::remove_all(directory_); }

  Experiment read(const std::string& body) const {
    const fs::path path = directory_ / "identity.yaml";
    std::ofstream(path) << body;
    return Experiment::fromFile(path.string());
  }

  fs::path directory_;
};

const char* const kWorld = R"(
    spec: {name: tiny, seed: 3, resolution: 0.1, bounds: {min: [0, 0, 0], max: [10, 8, 3]},
           generators: [{type: forest, density: 0.1, trunk_radius: [0.15, 0.25]}]}
)";

TEST_F(ExperimentIdentityTest, EveryQueryRuleBudgetAndTimingKeepsItsText) {
  const Experiment e = read(std::string(R"(kind: planning
name: identity
seed: 11
worlds:
  - id: tiny)") + kWorld + R"(queries:
  fixed: [{start: [1, 1, 1.5], goal: [9, 7, 1.25]}]
  random: {count: 2, min_distance: 3, max_distance: 8.5, clearance: 0.4, height: [1.1, 2.3],
           lattice: {step: 0.5, offset: 0.05}}
  across: {count: 2, axis: y, margin: 1.5, clearance: 0.3, height: 1.7}
planners:
  - {id: eager, type: eager_mp_astar, params: {heuristic_weight: 2}}
repetitions: 2
budget: {time: 2.5, memory_mb: 2048, iterations: 1000}
timing: {warmup: 0, repeats: 2}
store: {trajectories: true, trees: 3}
)");
  const ExperimentVariant& variant = e.variants.at(0);
  EXPECT_EQ(firstLine(variant.worlds.at(0).spec.canonicalText()),
            "kinolab-world generators=4 seed=3 resolution=0x1.999999999999ap-4 "
            "min=0x0p+0,0x0p+0,0x0p+0 max=0x1.4p+3,0x1p+3,0x1.8p+1");
  EXPECT_EQ(toHex(variant.worlds.at(0).spec.hash()), "e8b022982489abc2");
  std::string queries;
  for (int q = 0; q < variant.queries.count(); ++q) queries += variant.queries.queryText(q) + "\n";
  EXPECT_EQ(queries,
            "fixed (1, 1, 1.5) (9, 7, 1.25)\n"
            "random #0 3 8.5 0.4 1.1 2.3 lattice 0.5 0.05\n"
            "random #1 3 8.5 0.4 1.1 2.3 lattice 0.5 0.05\n"
            "across #0 1 1.5 0.3 1.7 1.7 after random 2 3 8.5 0.4 1.1 2.3 lattice 0.5 0.05\n"
            "across #1 1 1.5 0.3 1.7 1.7 after random 2 3 8.5 0.4 1.1 2.3 lattice 0.5 0.05\n");
  EXPECT_EQ(e.config_hash, "617a865abea4f959");
  EXPECT_EQ(runsDigest(e), "69d5a778d7e7ae89");
}

TEST_F(ExperimentIdentityTest, DefaultsKeepTheirText) {
  const Experiment e = read(std::string(R"(kind: planning
name: defaults
worlds:
  - id: tiny)") + kWorld + R"(queries:
  random: {count: 1}
  across: {count: 1}
planners:
  - {id: lazy, type: lazy_mp_astar}
)");
  std::string queries;
  const QuerySpec& spec = e.variants.at(0).queries;
  for (int q = 0; q < spec.count(); ++q) queries += spec.queryText(q) + "\n";
  EXPECT_EQ(queries,
            "random #0 5 1e+06 0.6 1 2\n"
            "across #0 0 1 0.6 1 2 after random 1 5 1e+06 0.6 1 2\n");
  EXPECT_EQ(runsDigest(e), "cf69d1e18219aaf9");
}

TEST_F(ExperimentIdentityTest, AFlightsBudgetKeepsItsText) {
  const Experiment e = read(std::string(R"(kind: flight
name: flights
seed: 5
worlds:
  - id: tiny)") + kWorld + R"(queries:
  random: {count: 1, min_distance: 4}
planners:
  - {id: eager, type: eager_mp_astar}
budget: {time: 30}
flight: {window: 8}
)");
  EXPECT_EQ(runsDigest(e), "0a2b04379780a320");
}

TEST(WorldSpecIdentityTest, DenseAndSparseSpecsKeepTheirText) {
  test::loadTestPlugins();
  const std::string base =
      "seed: 9\nresolution: 0.25\nbounds: {min: [-1, 0, 0], max: [20, 10.5, 4]}\n"
      "generators: [{type: forest, density: 0.05}]\n";
  const auto text = [](const std::string& yaml) {
    return firstLine(
        WorldSpec::fromYaml(YamlReader::loadString(yaml, "spec.yaml"), ".").canonicalText());
  };
  const std::string dense =
      "kinolab-world generators=4 seed=9 resolution=0x1p-2 min=-0x1p+0,0x0p+0,0x0p+0 "
      "max=0x1.4p+4,0x1.5p+3,0x1p+2";
  EXPECT_EQ(text("name: a\n" + base), dense);  // the name is not part of it
  EXPECT_EQ(text(base + "layout: dense\n"), dense);
  EXPECT_EQ(text(base + "layout: sparse\n"), dense + " layout=sparse truncation=0x1p+1");
  EXPECT_EQ(text(base + "layout: sparse\ntruncation: 1.5\n"),
            dense + " layout=sparse truncation=0x1.8p+0");
}

TEST(WorldSpecIdentityTest, ShippedWorldsKeepTheirCacheKeys) {
  test::loadTestPlugins();
  std::string keys;
  for (const char* name : {"forest", "complex", "walls", "boxes", "empty", "geb079", "city"}) {
    const WorldSpec spec = WorldSpec::fromFile(kSourceDir + "/configs/worlds/" + name + ".yaml");
    keys += std::string(name) + " " + toHex(spec.hash()) + "\n";
  }
  EXPECT_EQ(keys,
            "forest 801f0392f6e9d567\n"
            "complex b10b7a2858fb94af\n"
            "walls 0f7dd856d69881d6\n"
            "boxes 12c4b43370df91d0\n"
            "empty 8379dc7040ce6640\n"
            "geb079 e10d23d4878df31b\n"
            "city c8cbf16c9542dfd2\n");
}

TEST(ExperimentFilesIdentityTest, ShippedExperimentsKeepTheirRunHashes) {
  test::loadTestPlugins();
  std::string digests;
  for (const auto& entry : fs::recursive_directory_iterator(kSourceDir + "/experiments")) {
    const std::string path = entry.path().string();
    if (entry.path().extension() != ".yaml" || entry.path().filename() == "base.yaml") continue;
    if (YamlReader::loadFile(path).node()["kind"].as<std::string>("planning") ==
        "sampling_study") {
      continue;
    }
    digests += fs::relative(path, kSourceDir).string() + " " +
               runsDigest(Experiment::fromFile(path)) + "\n";
  }
  // Directory order is not sorted: compare line sets.
  std::vector<std::string> lines;
  std::istringstream stream(digests);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  std::sort(lines.begin(), lines.end());
  std::string sorted;
  for (const std::string& line : lines) sorted += line + "\n";
  EXPECT_EQ(sorted,
            "experiments/ablations/edge_samples.yaml 6fe37c686fced621\n"
            "experiments/ablations/esdf_resolution.yaml 2d55a8358788ec86\n"
            "experiments/ablations/heuristic_weight.yaml e18c6b3f57034c30\n"
            "experiments/ablations/lazy_duplicate_rule.yaml c932647ba725df09\n"
            "experiments/ablations/lazy_lower_bound.yaml 3956bfab88fb1fc0\n"
            "experiments/ablations/sampler.yaml 5b97b9a98f408f1e\n"
            "experiments/back_ends.yaml 610fc6e374f8e9ce\n"
            "experiments/city_500m.yaml 0f4b2a9cc7722753\n"
            "experiments/field.yaml ecdea6f5d326f1e9\n"
            "experiments/flight_back_ends.yaml ec4e979b1061d382\n"
            "experiments/flight_benchmark.yaml f3d85b4f1f19d9f5\n"
            "experiments/flight_densest_cell.yaml 28e3bd0c96c92b01\n"
            "experiments/flight_forest.yaml 96f5b38d7236a5ef\n"
            "experiments/flight_forest_2ms.yaml 50d54b8675ee9b59\n"
            "experiments/flight_geb079.yaml 30b801b7a3ad9803\n"
            "experiments/flight_speeds.yaml 1aa493c35ef9dd09\n"
            "experiments/flight_speeds_tgk.yaml 22136760a2e68909\n"
            "experiments/heuristics/city.yaml 8b491ceb0326d216\n"
            "experiments/heuristics/geb079_fine.yaml 261616b0276bdd9b\n"
            "experiments/heuristics/maps.yaml c14c6ecef7689e5e\n"
            "experiments/heuristics/mpl.yaml 7c45ed2673ce4a15\n"
            "experiments/hybrid_astar.yaml b7be599ae44e32b6\n"
            "experiments/lazy_families.yaml 0a5189356a573001\n"
            "experiments/lazy_family.yaml 00f867bf3f0cbb7e\n"
            "experiments/lazy_regime/controls.yaml 557cb8469133964c\n"
            "experiments/lazy_regime/density.yaml 6d06493f2f6ef0b5\n"
            "experiments/lazy_regime/edge_cost.yaml eb9ba3255c90a754\n"
            "experiments/lazy_regime/edge_cost_density.yaml de0db4e496354066\n"
            "experiments/lazy_regime/epsilon.yaml a1159f74bb6cb7f9\n"
            "experiments/lazy_regime/esdf_resolution.yaml 965cb376dc37aed5\n"
            "experiments/lazy_regime/order.yaml 03f3a72fda8c9480\n"
            "experiments/mpl_benchmark.yaml 04c1599ec8f93399\n"
            "experiments/paper_table2_planners.yaml 2031b2e1ae30efca\n"
            "experiments/quick.yaml 667d0a8b5cf14271\n"
            "experiments/sampler_planning.yaml bc9b3f9c017e4144\n");
}

}  // namespace
}  // namespace kinolab
