#include "kinolab/world/world_cache.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "kinolab/core/error.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {
namespace {

class WorldCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One folder per test and process: ctest runs these tests in parallel processes.
    directory_ = std::filesystem::temp_directory_path() /
                 ("kinolab_cache_test_" + std::to_string(getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(directory_);
    spec_ =
        WorldSpec::fromYaml(YamlReader::loadString("name: small\nseed: 3\nresolution: 0.2\n"
                                                   "bounds: {min: [0, 0, 0], max: [8, 6, 3]}\n"
                                                   "generators: [{type: forest, density: 0.2}]\n",
                                                   "small.yaml"),
                            ".");
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  void expectSameWorld(const World& a, const World& b) {
    EXPECT_EQ(a.grid().dims(), b.grid().dims());
    EXPECT_EQ(a.grid().origin(), b.grid().origin());
    EXPECT_EQ(a.grid().occupancy(), b.grid().occupancy());
    EXPECT_EQ(a.esdf().values(), b.esdf().values());
  }

  std::filesystem::path directory_;
  WorldSpec spec_;
};

TEST_F(WorldCacheTest, SecondUseLoadsWhatTheFirstBuilt) {
  const WorldCache cache(directory_.string());
  const WorldLoad first = cache.loadOrBuild(spec_);
  EXPECT_EQ(first.source, WorldSource::kBuilt);
  EXPECT_TRUE(std::filesystem::exists(first.cache_file));
  const WorldLoad second = cache.loadOrBuild(spec_);
  EXPECT_EQ(second.source, WorldSource::kCache);
  expectSameWorld(*first.world, *second.world);
  expectSameWorld(*first.world, *World::build(spec_));
  EXPECT_EQ(second.world->name(), "small");
}

TEST_F(WorldCacheTest, CorruptTruncatedOrForeignFilesAreRebuiltNeverTrusted) {
  const WorldCache cache(directory_.string());
  const WorldLoad original = cache.loadOrBuild(spec_);
  const std::string file = original.cache_file;
  const auto size = std::filesystem::file_size(file);

  auto corrupt = [&](const std::function<void(std::string&)>& damage, const std::string& reason) {
    std::string bytes;
    {
      std::ifstream in(file, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    damage(bytes);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
    const WorldLoad load = cache.loadOrBuild(spec_);
    EXPECT_EQ(load.source, WorldSource::kRebuiltCorruptCache) << reason;
    EXPECT_NE(load.note.find(reason), std::string::npos) << load.note;
    expectSameWorld(*original.world, *load.world);
    // The rebuilt file replaced the bad one.
    EXPECT_EQ(std::filesystem::file_size(file), size);
    EXPECT_EQ(cache.loadOrBuild(spec_).source, WorldSource::kCache);
  };
  corrupt([](std::string& b) { b[b.size() / 2] ^= 0x10; }, "checksum");
  corrupt([](std::string& b) { b.resize(b.size() - 100); }, "truncated");
  corrupt([](std::string& b) { b.resize(40); }, "truncated");
  corrupt([](std::string& b) { b[0] = 'X'; }, "not a kinolab world file");
  corrupt([](std::string& b) { b[16] ^= 1; }, "another spec");
}

TEST_F(WorldCacheTest, DifferentSpecsUseDifferentFiles) {
  const WorldCache cache(directory_.string());
  WorldSpec other = spec_;
  other.seed = 4;
  EXPECT_NE(cache.fileFor(spec_), cache.fileFor(other));
}

}  // namespace
}  // namespace kinolab
