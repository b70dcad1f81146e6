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
  EXPECT_EQ(runsDigest(e), "c8a178001f2cb45b");
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
  EXPECT_EQ(runsDigest(e), "48da99af4373f6c8");
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
  EXPECT_EQ(runsDigest(e), "3a72613176694cc1");
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
    if (YamlReader::loadFile(path).node()["kind"].as<std::string>("planning") == "sampling_study") {
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
            "experiments/ablations/edge_samples.yaml 47c070e94590f9ec\n"
            "experiments/ablations/esdf_resolution.yaml 0929f76089f1794d\n"
            "experiments/ablations/heuristic_weight.yaml 17b5c02ab163dd2b\n"
            "experiments/ablations/lazy_duplicate_rule.yaml f779d5639c8e3ed3\n"
            "experiments/ablations/lazy_lower_bound.yaml db5a2db5765499d2\n"
            "experiments/ablations/sampler.yaml d916a9235069ef1d\n"
            "experiments/back_ends.yaml 1de6694964fc94dd\n"
            "experiments/city_500m.yaml 802beb9199e3187a\n"
            "experiments/field.yaml b45e596f2b0f2b3f\n"
            "experiments/flight_back_ends.yaml b25b8671828355ac\n"
            "experiments/flight_benchmark.yaml 8688c8facfbde137\n"
            "experiments/flight_densest_cell.yaml 3b9e76758c99cef2\n"
            "experiments/flight_forest.yaml 49dfd821ed72e50d\n"
            "experiments/flight_forest_2ms.yaml cb817437e414745d\n"
            "experiments/flight_geb079.yaml dd3c003b6db4a42f\n"
            "experiments/flight_real_map.yaml b9e7fd079f0bf14f\n"
            "experiments/flight_speeds.yaml 03bd0518c1748115\n"
            "experiments/flight_speeds_tgk.yaml 30dcb0bb4056957e\n"
            "experiments/heuristics/city.yaml f37d01290c87627e\n"
            "experiments/heuristics/geb079_fine.yaml f62c3d45b747cc9f\n"
            "experiments/heuristics/maps.yaml 957fb0989da9276c\n"
            "experiments/heuristics/mpl.yaml 9e9fd193bfe86bb3\n"
            "experiments/hybrid_astar.yaml 340835975a75349a\n"
            "experiments/lazy_families.yaml 39585ebd6d9eaa24\n"
            "experiments/lazy_family.yaml b62695a50f92ff48\n"
            "experiments/lazy_regime/controls.yaml ac1b31f7373149e6\n"
            "experiments/lazy_regime/density.yaml 190e3c3c8dd00c02\n"
            "experiments/lazy_regime/edge_cost.yaml dfa644341a301dbe\n"
            "experiments/lazy_regime/edge_cost_density.yaml 9f5910acc634b329\n"
            "experiments/lazy_regime/epsilon.yaml cc3372badd467481\n"
            "experiments/lazy_regime/esdf_resolution.yaml c712454823558af0\n"
            "experiments/lazy_regime/order.yaml 77bad5b8d08be6f4\n"
            "experiments/mpl_benchmark.yaml 947db40d8a9b2e88\n"
            "experiments/paper_table2_planners.yaml a49ef8d572272484\n"
            "experiments/quick.yaml 84500d6c959218b1\n"
            "experiments/sampler_planning.yaml df2a6d740f7f7f02\n");
}

}  // namespace
}  // namespace kinolab
