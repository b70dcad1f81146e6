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
  EXPECT_EQ(runsDigest(e), "399b2ebbdddbe782");
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
  EXPECT_EQ(runsDigest(e), "36326c8a709ede95");
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
  EXPECT_EQ(runsDigest(e), "cca46063b8f4c5e5");
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
            "experiments/ablations/edge_samples.yaml 35fa8eedc53dfd3e\n"
            "experiments/ablations/esdf_resolution.yaml 2c3bef7bfc57fca6\n"
            "experiments/ablations/heuristic_weight.yaml 8994fad6125b8d74\n"
            "experiments/ablations/lazy_duplicate_rule.yaml c7d1d6459edd8f5f\n"
            "experiments/ablations/lazy_lower_bound.yaml 7681b15ffbe328b0\n"
            "experiments/ablations/sampler.yaml 599d0f7fef4a2078\n"
            "experiments/back_ends.yaml cc622d10e79cb40b\n"
            "experiments/city_500m.yaml 5364a9c1c7b08cda\n"
            "experiments/field.yaml e32ad8a1712796aa\n"
            "experiments/flight_back_ends.yaml a48cdc8aa8abecb9\n"
            "experiments/flight_benchmark.yaml f2a0890b79c93d36\n"
            "experiments/flight_densest_cell.yaml d24ef1cd756385af\n"
            "experiments/flight_forest.yaml 5c01f99c8983afdb\n"
            "experiments/flight_forest_2ms.yaml f93195d4e1e43f90\n"
            "experiments/flight_geb079.yaml 3d16592ad2179f4a\n"
            "experiments/flight_speeds.yaml 50e4f8a93bd379d8\n"
            "experiments/flight_speeds_tgk.yaml 22136760a2e68909\n"
            "experiments/heuristics/city.yaml dd81dac676e14d7b\n"
            "experiments/heuristics/geb079_fine.yaml 2666d606be13ca47\n"
            "experiments/heuristics/maps.yaml 8a7cf80f62bcf0b0\n"
            "experiments/heuristics/mpl.yaml 8b90956f76afcd71\n"
            "experiments/hybrid_astar.yaml 03f9c87064401a50\n"
            "experiments/lazy_families.yaml fdcd7793d0c703a6\n"
            "experiments/lazy_family.yaml 90d9255cd571f94f\n"
            "experiments/lazy_regime/controls.yaml d792b6ad3c3d1ddf\n"
            "experiments/lazy_regime/density.yaml b803ff28e2d3105b\n"
            "experiments/lazy_regime/edge_cost.yaml 46b59d31f890d4bd\n"
            "experiments/lazy_regime/edge_cost_density.yaml 5868e0acf7daedb8\n"
            "experiments/lazy_regime/epsilon.yaml 1b54a726b7f29de0\n"
            "experiments/lazy_regime/esdf_resolution.yaml 6c80b6edebdd7949\n"
            "experiments/lazy_regime/order.yaml ed9f420b95189f98\n"
            "experiments/mpl_benchmark.yaml 955e0a69a9bd6325\n"
            "experiments/paper_table2_planners.yaml 3518140a89585065\n"
            "experiments/quick.yaml 816409c3db534e94\n"
            "experiments/sampler_planning.yaml a2738d76d24cf0ab\n");
}

}  // namespace
}  // namespace kinolab
