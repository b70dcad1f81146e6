// Plugins loaded on use (kinolab_add_plugin(... ON_USE)): declared from their module's
// manifest, the module loaded only when one of them is made.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kinolab/core/plugin.hpp"
#include "kinolab/planner/back_end.hpp"
#include "kinolab/planner/planner.hpp"
#include "support/errors.hpp"

namespace kinolab {
namespace {

const std::string kModuleDir = KINOLAB_MODULE_DIR;

/// Whether the library at `path` is loaded in this process (dlopen without loading it).
bool isLoaded(const std::string& path) {
  void* handle = dlopen(path.c_str(), RTLD_LAZY | RTLD_NOLOAD);
  if (handle) dlclose(handle);  // (drops the reference NOLOAD took, not the library)
  return handle != nullptr;
}

std::string readText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

/// Expects `work` to throw an `Error` whose message holds every one of `parts`.
template <typename Error, typename Work>
void expectThrowContains(const Work& work, const std::vector<std::string>& parts) {
  const std::string message = test::errorOf<Error>(work);
  EXPECT_FALSE(message.empty()) << "nothing thrown";
  for (const std::string& part : parts) {
    EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
  }
}

/// A fresh scratch directory for one test.
std::string scratch(const std::string& name) {
  const auto directory = std::filesystem::temp_directory_path() /
                         ("kinolab_plugin_module_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory.string();
}

TEST(PluginModule, APlannerOfAModuleIsKnownWithoutItsModuleWhichLoadsWhenOneIsMade) {
  const std::string module = kModuleDir + "/kinolab_module_rrtstar_ceres.so";
  ASSERT_TRUE(std::filesystem::exists(module));
  // In a fresh process (this binary run again for this test alone): another test of this
  // process may have made the planner already, loading its module.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const auto require = [](bool holds, const char* what) {
          if (holds) return;
          std::fprintf(stderr, "failed: %s\n", what);
          std::exit(1);
        };
        require(!isLoaded(module), "registered at start, not loaded");
        // A module's manifest is read when a plugin of its kinds not built in is first asked
        // for, or all plugins of such a kind: not at start, not for a built-in planner.
        const std::size_t modules = detail::pendingModules();
        require(modules == 2, "manifests not read at start");
        require(pluginRegistry<Planner>().contains("lazy_mp_astar"), "a built-in planner");
        require(detail::pendingModules() == modules, "manifests not read for a built-in planner");
        const PluginInfo& info = pluginRegistry<Planner>().info("rrtstar_ceres");
        require(detail::pendingModules() == modules - 1, "the planners' module's manifest alone");
        require(info.origin == "built-in (rrtstar_ceres)", "origin");
        require(info.parameters.find("range") != nullptr, "the parameter range declared");
        require(!info.statistics.all().empty(), "statistics declared");
        require(pluginLibraryVersions().count("ompl") == 1, "provenance from the manifest");
        require(detail::pendingModules() == 0, "every manifest read for the provenance");
        // Declarations resolve without the module too.
        const ParameterSet parameters = pluginRegistry<Planner>().resolve("rrtstar_ceres", {});
        require(!isLoaded(module), "resolved without loading");
        const auto planner = pluginRegistry<Planner>().createResolved("rrtstar_ceres", parameters);
        require(planner != nullptr, "made");
        require(isLoaded(module), "loaded once made");
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(PluginModule, EveryShippedManifestDeclaresWhatItsModuleRegisters) {
  const std::string directory = scratch("fresh");
  int modules = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kModuleDir)) {
    if (entry.path().extension() != ".so") continue;
    ++modules;
    const std::string shipped = std::filesystem::path(entry.path()).replace_extension(".json");
    const std::string fresh = directory + "/" + entry.path().stem().string() + ".json";
    writePluginManifest(declarePluginLibrary(entry.path().string()), fresh);
    EXPECT_EQ(readText(fresh), readText(shipped)) << entry.path();
    EXPECT_EQ(readText(pluginManifestKindsPath(fresh)), readText(pluginManifestKindsPath(shipped)))
        << entry.path();
    EXPECT_FALSE(readPluginManifestKinds(shipped).empty()) << shipped;
    EXPECT_FALSE(readPluginManifest(shipped).plugins.empty()) << shipped;
  }
  EXPECT_EQ(modules, 2);  // rrtstar_ceres (OMPL) and bspline_back_end (Ceres)
}

TEST(PluginModule, AManifestReadsBackEveryKindOfDeclaration) {
  ParameterSpecs members;
  members.real("radius", 0.5, 0.0, INFINITY, "a member");
  PluginDeclarations declared;
  PluginInfo info;
  info.key = "everything";
  info.description = "every kind of parameter";
  info.parameters.boolean("flag", true, "a flag")
      .integer("count", -3, -10, 10, "an integer")
      .real("gain", 0.1, -INFINITY, INFINITY, "a real")
      .choice("mode", "b", {"a", "b"}, "a choice")
      .text("label", "x y", "text")
      .reals("point", {1.0, 2.5, 1e-300}, -5.0, 5.0, 3, "reals")
      .interval("span", {0.25, 0.75}, 0.0, 1.0, "an interval")
      .path("file", "a path")
      .required()
      .group("canopy", members, "a group")
      .groupList("boxes", members, "a group list")
      .plugin("sampler", "sampler", "uniform", "a plugin");
  info.statistics.counter("expansions", "states expanded")
      .real("cost", "", "the cost")
      .lower()
      .comparable()
      .series("best", "", "best so far")
      .clock("time_ms", "a time");
  declared.plugins.emplace_back("planner", info);
  declared.libraries.emplace_back("lib", "1.2.3");
  const std::string directory = scratch("round_trip");
  writePluginManifest(declared, directory + "/a.json");
  const PluginDeclarations read = readPluginManifest(directory + "/a.json");
  writePluginManifest(read, directory + "/b.json");
  EXPECT_EQ(readText(directory + "/a.json"), readText(directory + "/b.json"));
  ASSERT_EQ(read.plugins.size(), 1U);
  const ParameterSpecs& specs = read.plugins[0].second.parameters;
  ASSERT_EQ(specs.all().size(), info.parameters.all().size());
  EXPECT_EQ(std::get<std::vector<double>>(specs.find("point")->default_value)[2], 1e-300);
  EXPECT_EQ(specs.find("gain")->minimum, -INFINITY);
  EXPECT_TRUE(specs.find("file")->required);
  EXPECT_EQ(specs.find("boxes")->members->find("radius")->maximum, INFINITY);
  EXPECT_EQ(specs.find("sampler")->kind, "sampler");
  const MetricSpec* cost = read.plugins[0].second.statistics.find("cost");
  ASSERT_NE(cost, nullptr);
  EXPECT_EQ(cost->direction, MetricDirection::kLower);
  EXPECT_TRUE(cost->comparable);
  EXPECT_TRUE(read.plugins[0].second.statistics.find("best")->series);
  EXPECT_EQ(read.libraries, declared.libraries);
}

TEST(PluginModule, ABrokenManifestIsAPluginErrorNamingItsFile) {
  const std::string directory = scratch("broken");
  const std::string shipped = readText(kModuleDir + "/kinolab_module_bspline_back_end.json");
  ASSERT_NE(shipped.find("\"format\":1"), std::string::npos);
  const auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = shipped;
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "cannot be read"},
      {shipped.substr(0, shipped.size() / 2), "parse error"},
      {replaced("\"format\":1", "\"format\":9"), "format 9, expected 1"},
      {replaced("\"minimum\":\"", "\"minimum\":\"x"), "is not a number"},
      {replaced("\"type\":", "\"type\":7"), "unknown"},
      {replaced("\"key\"", "\"kee\""), "key"},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string path = directory + "/case" + std::to_string(i) + ".json";
    if (i > 0) std::ofstream(path) << cases[i].first;
    SCOPED_TRACE(path);
    expectThrowContains<PluginError>([&] { readPluginManifest(path); },
                                     {path, cases[i].second, "rebuild or reinstall kinolab"});
  }
}

TEST(PluginModule, AKindsFileThatLeavesOutADeclaredKindIsAPluginErrorWhenRead) {
  const std::string directory = scratch("kinds");
  PluginDeclarations declared;
  PluginInfo hidden;
  hidden.key = "hidden_planner";
  declared.plugins.emplace_back("planner", hidden);
  writePluginManifest(declared, directory + "/hidden.json");
  EXPECT_EQ(readPluginManifestKinds(directory + "/hidden.json"),
            std::vector<std::string>{"planner"});
  std::ofstream(pluginManifestKindsPath(directory + "/hidden.json")) << "back_end\n";
  // In a fresh process: a failed declaration is reported again by every later need.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        registerPluginModule(directory + "/hidden.so", directory + "/hidden.json", "test");
        try {
          (void)pluginRegistry<BackEnd>().list();
        } catch (const PluginError& error) {
          std::fprintf(stderr, "%s\n", error.what());
          try {
            (void)pluginRegistry<Planner>().list();
          } catch (const PluginError&) {
            std::exit(3);  // reported again
          }
          std::exit(4);
        }
        std::exit(0);
      },
      ::testing::ExitedWithCode(3),
      "declares planner 'hidden_planner'.*hidden.kinds.*does not list");
}

TEST(PluginModule, APluginWhoseModuleIsMissingOrSilentIsAPluginErrorWhenMade) {
  const std::string directory = scratch("missing");
  PluginDeclarations declared;
  PluginInfo ghost;
  ghost.key = "ghost_planner";
  ghost.description = "declared, never registered";
  declared.plugins.emplace_back("planner", ghost);
  writePluginManifest(declared, directory + "/ghost.json");
  registerPluginModule(directory + "/missing.so", directory + "/ghost.json", "test (ghost)");
  EXPECT_EQ(pluginRegistry<Planner>().info("ghost_planner").origin, "test (ghost)");
  expectThrowContains<PluginError>([] { pluginRegistry<Planner>().create("ghost_planner", {}); },
                                   {"missing.so", "no such file"});
  // A module that loads but does not register the plugin its manifest declares.
  ghost.key = "silent_planner";
  declared.plugins = {{"planner", ghost}};
  writePluginManifest(declared, directory + "/silent.json");
  registerPluginModule(kModuleDir + "/kinolab_module_bspline_back_end.so",
                       directory + "/silent.json", "test (silent)");
  expectThrowContains<PluginError>([] { pluginRegistry<Planner>().create("silent_planner", {}); },
                                   {"silent_planner", "no longer registers it", "rebuild kinolab"});
}

}  // namespace
}  // namespace kinolab
