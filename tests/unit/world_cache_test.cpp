#include "kinolab/world/world_cache.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/value_array.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/arrays.hpp"

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
    ASSERT_EQ(a.grid().layout(), b.grid().layout());
    if (a.grid().layout() == GridLayout::kDense) {
      EXPECT_EQ(asVector(a.grid().occupancy()), asVector(b.grid().occupancy()));
      EXPECT_EQ(asVector(a.esdf().values()), asVector(b.esdf().values()));
      return;
    }
    EXPECT_EQ(asVector(a.grid().brickStates()), asVector(b.grid().brickStates()));
    EXPECT_EQ(asVector(a.grid().brickMasks()), asVector(b.grid().brickMasks()));
    EXPECT_EQ(a.esdf().truncation(), b.esdf().truncation());
    EXPECT_EQ(a.esdf().allocatedBricks(), b.esdf().allocatedBricks());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.grid().size(); ++i) {
      differ += a.esdf().voxelDistance(i) != b.esdf().voxelDistance(i);
    }
    EXPECT_EQ(differ, 0u);
  }

  /// The small world of spec_, sparse (bricks and a truncated field).
  WorldSpec sparseSpec() const {
    return WorldSpec::fromYaml(
        YamlReader::loadString("name: small_sparse\nseed: 3\nresolution: 0.1\nlayout: sparse\n"
                               "truncation: 0.5\nbounds: {min: [0, 0, 0], max: [8, 6, 3]}\n"
                               "generators: [{type: forest, density: 0.2}, "
                               "{type: box_list, boxes: [{min: [1, 1, 0], max: [3, 3, 2]}]}]\n",
                               "small_sparse.yaml"),
        ".");
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

TEST_F(WorldCacheTest, ASparseWorldIsCachedAndLoadedAsBuilt) {
  const WorldCache cache(directory_.string());
  const WorldSpec spec = sparseSpec();
  const WorldLoad first = cache.loadOrBuild(spec);
  EXPECT_EQ(first.source, WorldSource::kBuilt);
  ASSERT_EQ(first.world->grid().layout(), GridLayout::kBricked);
  EXPECT_GT(first.world->esdf().allocatedBricks(), 10u);
  const WorldLoad second = cache.loadOrBuild(spec);
  EXPECT_EQ(second.source, WorldSource::kCache) << second.note;
  expectSameWorld(*first.world, *second.world);
  // The same answers to the queries the planners and the checker ask.
  Rng rng(5);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p(rng.uniform(0.0, 8.0), rng.uniform(0.0, 6.0), rng.uniform(0.0, 3.0));
    EXPECT_EQ(first.world->esdf().distance(p), second.world->esdf().distance(p));
    EXPECT_EQ(first.world->esdf().exactDistance(p, 2.0),
              second.world->esdf().exactDistance(p, 2.0));
    EXPECT_EQ(first.world->grid().occupied(first.world->grid().index(
                  ((p - first.world->grid().origin()) / 0.1).cast<int>())),
              second.world->grid().occupied(second.world->grid().index(
                  ((p - second.world->grid().origin()) / 0.1).cast<int>())));
  }
  // Damaged, it is rebuilt.
  {
    std::fstream file(first.cache_file, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(std::filesystem::file_size(first.cache_file) / 2));
    file.put('\x5a');
  }
  const WorldLoad third = cache.loadOrBuild(spec);
  EXPECT_EQ(third.source, WorldSource::kRebuiltCorruptCache);
  expectSameWorld(*first.world, *third.world);
}

TEST_F(WorldCacheTest, AWorldOfAnyVoxelCountIsLoadedFromTheCache) {
  // 25 x 25 x 25 voxels: the values end off the 64-byte alignment of the arrays.
  const WorldCache cache(directory_.string());
  for (const std::string layout : {"dense", "sparse\ntruncation: 0.4"}) {
    SCOPED_TRACE(layout);
    const WorldSpec spec = WorldSpec::fromYaml(
        YamlReader::loadString("name: odd\nseed: 2\nresolution: 0.1\nlayout: " + layout +
                                   "\nbounds: {min: [0, 0, 0], max: [2.5, 2.5, 2.5]}\n"
                                   "generators: [{type: forest, density: 0.3}]\n",
                               "odd.yaml"),
        ".");
    const WorldLoad built = cache.loadOrBuild(spec);
    ASSERT_EQ(built.world->grid().size(), 15625u);
    const WorldLoad loaded = cache.loadOrBuild(spec);
    EXPECT_EQ(loaded.source, WorldSource::kCache) << loaded.note;
    expectSameWorld(*built.world, *loaded.world);
  }
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

TEST_F(WorldCacheTest, ASettledFileIsVouchedForByItsStampUntilItChangesInPlace) {
  const WorldCache cache(directory_.string());
  const WorldLoad built = cache.loadOrBuild(spec_);
  const std::string file = built.cache_file;
  const std::string stamp = file + ".verified";
  // Once the file has not changed for half a second, a load that computes its checksum stamps
  // it, and the next loads skip the checksum.
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  EXPECT_EQ(cache.loadOrBuild(spec_).source, WorldSource::kCache);
  ASSERT_TRUE(std::filesystem::exists(stamp));
  const WorldLoad vouched = cache.loadOrBuild(spec_);
  EXPECT_EQ(vouched.source, WorldSource::kCache);
  EXPECT_FALSE(vouched.checksum_read);
  expectSameWorld(*built.world, *vouched.world);
  // A damaged stamp vouches for nothing.
  const auto stamped = [&] {
    std::ifstream in(stamp, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }();
  std::ofstream(stamp, std::ios::binary | std::ios::trunc) << stamped.substr(1);
  EXPECT_TRUE(cache.loadOrBuild(spec_).checksum_read);
  std::ofstream(stamp, std::ios::binary | std::ios::trunc) << stamped;
  EXPECT_FALSE(cache.loadOrBuild(spec_).checksum_read);
  // A byte changed in place, the same size, its modification time put back: its change time
  // moved, so the checksum is computed and the file rebuilt.
  const auto modified = std::filesystem::last_write_time(file);
  {
    std::fstream io(file, std::ios::binary | std::ios::in | std::ios::out);
    io.seekg(static_cast<std::streamoff>(std::filesystem::file_size(file) / 2));
    const char byte = static_cast<char>(io.get() ^ 0x10);
    io.seekp(static_cast<std::streamoff>(std::filesystem::file_size(file) / 2));
    io.put(byte);
  }
  std::filesystem::last_write_time(file, modified);
  const WorldLoad changed = cache.loadOrBuild(spec_);
  EXPECT_EQ(changed.source, WorldSource::kRebuiltCorruptCache);
  EXPECT_NE(changed.note.find("checksum"), std::string::npos) << changed.note;
  expectSameWorld(*built.world, *changed.world);
}

TEST_F(WorldCacheTest, DifferentSpecsUseDifferentFiles) {
  const WorldCache cache(directory_.string());
  WorldSpec other = spec_;
  other.seed = 4;
  EXPECT_NE(cache.fileFor(spec_), cache.fileFor(other));
}

TEST_F(WorldCacheTest, ALoadedWorldReadsTheFileWhereItLiesAndCopiesOnlyWhatIsWritten) {
  const WorldCache cache(directory_.string());
  const WorldLoad built = cache.loadOrBuild(spec_);
  const WorldLoad loaded = cache.loadOrBuild(spec_);
  ASSERT_EQ(loaded.source, WorldSource::kCache);
  // The field's floats lie aligned in the mapped file (format 4), and take no memory of their
  // own beyond the file's pages.
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(loaded.world->esdf().values().data()) % alignof(float),
            0u);
  EXPECT_EQ(loaded.world->esdf().memoryBytes(), loaded.world->grid().size() * sizeof(float));

  // A copy written to is the copy's: the loaded world, the file and the next load are unchanged.
  VoxelGrid copy = loaded.world->grid();
  const bool first = copy.occupied(std::size_t{0});
  copy.setOccupied(std::size_t{0}, !first);
  EXPECT_NE(copy.occupied(std::size_t{0}), first);
  EXPECT_EQ(loaded.world->grid().occupied(std::size_t{0}), first);
  std::vector<float> values = Esdf(loaded.world->esdf()).release();
  values[0] += 1.0f;
  EXPECT_NE(values[0], loaded.world->esdf().values()[0]);
  const WorldLoad again = cache.loadOrBuild(spec_);
  EXPECT_EQ(again.source, WorldSource::kCache);
  expectSameWorld(*built.world, *again.world);
  expectSameWorld(*built.world, *loaded.world);
}

TEST(ValueArray, CopiesAViewOnlyWhenItIsWrittenAndKeepsItsKeeperAliveTheWholeTime) {
  auto storage = std::make_shared<std::vector<int>>(std::vector<int>{1, 2, 3});
  std::weak_ptr<std::vector<int>> alive = storage;
  ValueArray<int> view(storage, storage->data(), storage->size());
  storage.reset();
  ASSERT_FALSE(alive.expired());  // the view keeps it
  EXPECT_TRUE(view.viewed());
  ValueArray<int> shared = view;  // a copy of a view is a view of the same values
  EXPECT_EQ(shared.data(), view.data());
  shared.mutableData()[1] = 20;  // written: copied first
  EXPECT_FALSE(shared.viewed());
  EXPECT_EQ(asVector(shared.span()), (std::vector<int>{1, 20, 3}));
  EXPECT_EQ(asVector(view.span()), (std::vector<int>{1, 2, 3}));
  std::vector<int> taken = std::move(view).release();
  EXPECT_EQ(taken, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(view.empty());
  shared = ValueArray<int>();
  EXPECT_TRUE(alive.expired());  // no view left: the keeper is gone

  ValueArray<int> owned(std::vector<int>{4, 5});
  ValueArray<int> copied = owned;  // an owned copy has values of its own
  copied.mutableData()[0] = 40;
  EXPECT_EQ(owned[0], 4);
  ValueArray<int> moved = std::move(copied);
  EXPECT_EQ(moved[0], 40);
  EXPECT_TRUE(copied.empty());
}

TEST(ValueArray, AnArrayMovedOrCopiedOntoItselfKeepsItsValues) {
  ValueArray<int> owned(std::vector<int>{6, 7});
  ValueArray<int>& alias = owned;  // (through a reference: the compiler warns on a plain self-move)
  owned = std::move(alias);
  EXPECT_EQ(asVector(owned.span()), (std::vector<int>{6, 7}));
  owned = alias;
  EXPECT_EQ(asVector(owned.span()), (std::vector<int>{6, 7}));
  auto storage = std::make_shared<std::vector<int>>(std::vector<int>{8});
  ValueArray<int> view(storage, storage->data(), storage->size());
  ValueArray<int>& view_alias = view;
  view = std::move(view_alias);
  EXPECT_TRUE(view.viewed());
  EXPECT_EQ(asVector(view.span()), (std::vector<int>{8}));
}

}  // namespace
}  // namespace kinolab
