// The experiment module as a library: sweep expansion, `extends:`, seeds and run hashes,
// shard partition, `reproduces:` validation, the merge refusals and the free-query sampler.
#include "kinolab/experiment/experiment.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <utility>
#include <vector>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/experiment/results_store.hpp"
#include "kinolab/experiment/shard.hpp"
#include "kinolab/world/free_components.hpp"
#include "kinolab/world/world.hpp"
#include "kinolab/world/world_spec.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;

class ExperimentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::loadTestPlugins();
    directory_ = fs::temp_directory_path() /
                 ("kinolab_experiment_test_" + std::to_string(getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(directory_);
    fs::create_directories(directory_);
    fs::copy_file(fs::path(KINOLAB_SOURCE_DIR) / "tests/support/small_forest.yaml",
                  directory_ / "small_forest.yaml");
  }
  void TearDown() override { fs::remove_all(directory_); }

  /// Writes `name` with a small experiment around `planners` plus `extra`.
  std::string write(const std::string& name, const std::string& body) const {
    const fs::path path = directory_ / name;
    std::ofstream(path) << body;
    return path.string();
  }
  std::string experiment(const std::string& name, const std::string& extra, int queries = 3) const {
    return write(name, "kind: planning\nname: " + name +
                           "\nseed: 7\nworlds:\n  - {id: small, spec: small_forest.yaml}\n"
                           "queries:\n  random: {count: " +
                           std::to_string(queries) +
                           ", min_distance: 3, max_distance: 8}\n"
                           "planners:\n"
                           "  - {id: eager, type: eager_mp_astar, params: {heuristic_weight: 2}}\n"
                           "  - {id: lazy, type: lazy_mp_astar, params: {heuristic_weight: 2}}\n" +
                           extra);
  }

  fs::path directory_;
};

TEST_F(ExperimentTest, GridZipAndListSweepsExpandToTheirProductOfVariants) {
  const Experiment e = Experiment::fromFile(experiment("sweep.yaml", R"(sweep:
  grid:
    planners.eager.params.heuristic_weight: [1.5, 2, 3]
  zip:
    planners.lazy.params.lower_bound: [endpoint, lipschitz]
    budget.time: [5, 8]
repetitions: 2
)"));
  ASSERT_EQ(e.variants.size(), 6u);  // 3 grid values x 2 zipped pairs
  std::set<std::string> labels;
  for (const ExperimentVariant& variant : e.variants) labels.insert(variant.label);
  EXPECT_EQ(labels.size(), 6u);
  EXPECT_EQ(e.variants.front().repetitions, 2);
  // A zipped pair moves together.
  for (const ExperimentVariant& variant : e.variants) {
    const bool lipschitz = variant.planners[1].parameters.text("lower_bound") == "lipschitz";
    EXPECT_EQ(variant.budget.time, lipschitz ? 8.0 : 5.0) << variant.label;
  }
  // A run a sweep axis does not change runs once: lazy's runs do not depend on eager's
  // heuristic weight (2 distinct lazy configurations, not 6), eager's change with it and
  // with the budget (6); each x 3 queries x 2 repetitions.
  EXPECT_EQ(e.runs().size(), 2u * 6u + 6u * 6u);
}

TEST_F(ExperimentTest, LargeSweepsExpandAndOversizedOnesAreRefusedUpFront) {
  std::string weights;
  std::string radii;
  for (int i = 0; i < 100; ++i) {
    if (i > 0) {
      weights += ", ";
      radii += ", ";
    }
    weights += std::to_string(1.0 + 0.01 * i);
    radii += std::to_string(0.5 + 0.001 * i);
  }
  const std::string grid = "sweep:\n  grid:\n    planners.eager.params.heuristic_weight: [" +
                           weights + "]\n    planners.eager.params.goal_radius: [" + radii + "]\n";
  const Experiment e = Experiment::fromFile(experiment("large.yaml", grid, 1));
  ASSERT_EQ(e.variants.size(), 10000u);
  // Each variant has its own values, and the document is set back after each one.
  EXPECT_EQ(e.variants[0].planners[0].parameters.real("heuristic_weight"), 1.0);
  EXPECT_EQ(e.variants[9999].planners[0].parameters.real("goal_radius"), 0.599);
  EXPECT_EQ(e.variants[9999].planners[1].parameters.real("goal_radius"), 0.5);  // lazy: untouched
  EXPECT_EQ(e.runs().size(), 10000u + 1u);  // eager's 10,000 runs and lazy's one

  const auto refused = [&](const std::string& extra, int queries, const std::string& message) {
    try {
      Experiment::fromFile(experiment("oversized.yaml", extra, queries));
      ADD_FAILURE() << message;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(message), std::string::npos) << error.what();
    }
  };
  std::string many;
  for (int i = 0; i < 400; ++i) {
    if (i > 0) many += ", ";
    many += std::to_string(i + 1);
  }
  refused(
      "sweep:\n  grid:\n    budget.time: [" + many + "]\n    budget.memory_mb: [" + many + "]\n", 3,
      "a sweep has at most 100000");
  // 10^6 queries x 2 planners x 100 repetitions: counted, never expanded.
  refused("repetitions: 100\n", 1000000, "more than 10000000 runs");
}

TEST_F(ExperimentTest, ExtendsMergesMappingsAndTheChildWins) {
  write("base.yaml",
        "kind: planning\nname: base\nseed: 7\n"
        "worlds:\n  - {id: small, spec: small_forest.yaml}\n"
        "queries:\n  random: {count: 2, min_distance: 3, max_distance: 8}\n"
        "planners:\n  - {id: eager, type: eager_mp_astar}\n"
        "budget: {time: 3, memory_mb: 512}\n");
  const Experiment e = Experiment::fromFile(
      write("child.yaml", "extends: base.yaml\nname: child\nbudget: {time: 9}\n"));
  EXPECT_EQ(e.name, "child");
  EXPECT_EQ(e.variants.front().budget.time, 9.0);
  EXPECT_EQ(e.variants.front().budget.memory_mb, 512);  // kept from the base
  EXPECT_EQ(e.runs().size(), 2u);
  // A base in another folder: its relative paths are its own folder's, the child's its own.
  fs::create_directories(directory_ / "bases");
  write("bases/shared.yaml",
        "kind: planning\nname: shared\nworlds:\n  - {id: small, spec: ../small_forest.yaml}\n"
        "queries:\n  random: {count: 2, min_distance: 3, max_distance: 8}\n"
        "planners:\n  - {id: eager, type: eager_mp_astar}\n");
  const Experiment elsewhere =
      Experiment::fromFile(write("from_elsewhere.yaml", "extends: bases/shared.yaml\n"));
  EXPECT_EQ(elsewhere.variants.front().worlds.front().spec.name, "small_forest");
  const Experiment overriding =
      Experiment::fromFile(write("overriding.yaml",
                                 "extends: bases/shared.yaml\nname: overriding\n"
                                 "worlds:\n  - {id: mine, spec: small_forest.yaml}\n"));
  EXPECT_EQ(overriding.variants.front().worlds.front().id, "mine");
  write("loop_a.yaml", "extends: loop_b.yaml\n");
  write("loop_b.yaml", "extends: loop_a.yaml\n");
  EXPECT_THROW(Experiment::fromFile((directory_ / "loop_a.yaml").string()), ConfigError);
}

TEST_F(ExperimentTest, SeedsArePairedAcrossPlannersAndHashesAreStableAndDistinct) {
  const Experiment e = Experiment::fromFile(experiment("seeds.yaml", "repetitions: 2\n"));
  const std::vector<RunSpec> runs = e.runs();
  ASSERT_EQ(runs.size(), 3u * 2u * 2u);
  std::set<std::string> hashes;
  for (const RunSpec& run : runs) hashes.insert(run.hash);
  EXPECT_EQ(hashes.size(), runs.size());
  for (const RunSpec& a : runs) {
    for (const RunSpec& b : runs) {
      const bool same_case = a.query == b.query && a.repetition == b.repetition;
      // Every planner sees the same case with the same seed; other cases get other seeds.
      EXPECT_EQ(a.seed == b.seed, same_case);
    }
  }
  // The same file gives the same hashes; another master seed gives other ones.
  const Experiment again = Experiment::fromFile(experiment("seeds.yaml", "repetitions: 2\n"));
  EXPECT_EQ(again.config_hash, e.config_hash);
  EXPECT_EQ(again.runs().front().hash, runs.front().hash);
  std::string text;
  std::getline(std::ifstream(directory_ / "seeds.yaml"), text, '\0');
  text.replace(text.find("seed: 7"), 7, "seed: 8");
  const Experiment reseeded = Experiment::fromFile(write("seeds.yaml", text));
  EXPECT_NE(reseeded.runs().front().hash, runs.front().hash);
  EXPECT_NE(reseeded.config_hash, e.config_hash);
}

TEST_F(ExperimentTest, ShardsPartitionTheRunsAndParseOnce) {
  const Experiment e = Experiment::fromFile(experiment("shards.yaml", "repetitions: 3\n", 5));
  const std::vector<RunSpec> runs = e.runs();
  for (const int count : {1, 2, 3, 7, 40}) {
    std::multiset<std::string> seen;
    for (int index = 1; index <= count; ++index) {
      const std::vector<RunSpec> part = Shard{index, count}.select(runs);
      EXPECT_LE(part.size(), runs.size() / count + 1);
      for (const RunSpec& run : part) seen.insert(run.hash);
    }
    EXPECT_EQ(seen.size(), runs.size()) << count;
    std::set<std::string> unique(seen.begin(), seen.end());
    EXPECT_EQ(unique.size(), runs.size()) << count;  // disjoint
  }
  EXPECT_EQ(Shard::parse("2/8"), (Shard{2, 8}));
  EXPECT_EQ(Shard::parse("2/8").text(), "2/8");
  for (const char* bad : {"", "2", "0/3", "4/3", "1/0", "a/2", "1/2x", "-1/2", "1//2"}) {
    EXPECT_THROW(Shard::parse(bad), ConfigError) << bad;
  }
}

TEST_F(ExperimentTest, ReproducesNamesAKnownPaperAndThePlannersOfItsRows) {
  const Experiment e = Experiment::fromFile(
      experiment("paper.yaml",
                 "reproduces: {paper: lazy_mp_astar_paper, rows: {eager: MP-A*, lazy: Lazy}}\n"));
  EXPECT_EQ(e.reproduces_paper, "lazy_mp_astar_paper");
  ASSERT_EQ(e.reproduces_rows.size(), 2u);
  EXPECT_EQ(e.reproduces_rows[1], (std::pair<std::string, std::string>{"lazy", "Lazy"}));
  const auto fails = [&](const std::string& extra, const std::string& message) {
    try {
      Experiment::fromFile(experiment("bad.yaml", extra));
      ADD_FAILURE() << "accepted: " << extra;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(message), std::string::npos) << error.what();
    }
  };
  fails("reproduces: {paper: lazy_paper, rows: {}}\n", "unknown paper 'lazy_paper'");
  fails("reproduces: {paper: lazy_mp_astar_paper, rows: {eager: Eager}}\n", "not a row");
  fails("reproduces: {paper: lazy_mp_astar_paper, rows: {tgk: TGK}}\n", "no planner has the id");
  fails("reproduces: {paper: lazy_mp_astar_paper, rows: {}, colour: red}\n", "colour");
  // The paper's setting names variants: `true` is every one (here the one, unswept).
  const Experiment all = Experiment::fromFile(experiment(
      "setting.yaml", "reproduces: {paper: lazy_mp_astar_paper, rows: {}, setting: true}\n"));
  EXPECT_EQ(all.reproduces_setting, std::vector<std::string>{""});
  EXPECT_TRUE(e.reproduces_setting.empty());
  fails("reproduces: {paper: lazy_mp_astar_paper, rows: {}, setting: [horizon]}\n",
        "'horizon' is not a variant of this experiment");
}

TEST_F(ExperimentTest, NamesAndIdsUseADocumentedCharacterSet) {
  const std::string good = experiment("names.yaml", "");
  std::string text;
  std::getline(std::ifstream(good), text, '\0');
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"name: names.yaml", "name: \"bad\\ntouch canary\""},
           {"name: names.yaml", "name: \"a b\""},
           {"name: names.yaml", "name: \"-rf\""},
           {"id: small", "id: \"small/../../x\""},
           {"id: eager", "id: \"e$(x)\""}}) {
    std::string changed = text;
    changed.replace(changed.find(from), from.size(), to);
    try {
      Experiment::fromFile(write("bad_names.yaml", changed));
      ADD_FAILURE() << to;
    } catch (const ConfigError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find("is not a valid name"), std::string::npos) << message;
      EXPECT_NE(message.find("bad_names.yaml:"), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
}

TEST_F(ExperimentTest, MergeRefusesMixedRepeatedIncompleteAndOldShards) {
  const auto shard = [&](const std::string& name, const std::string& which,
                         const std::string& config_hash, int planned, int stored,
                         const std::string& version = std::to_string(kResultsSchemaVersion)) {
    const std::string path = (directory_ / (name + ".sqlite")).string();
    ResultsStore store(path);
    store.declareMetrics("result", "", resultMetrics());
    store.setMeta({{"config_hash", config_hash},
                   {"shard", which},
                   {"runs_planned", std::to_string(planned)},
                   {"schema_version", version}});
    std::vector<std::string> hashes;
    for (int i = 0; i < planned; ++i) hashes.push_back(name + std::to_string(i));
    store.setPlanned(hashes);  // as the runner records them
    for (int i = 0; i < stored; ++i) {
      RunRecord record;
      record.run_hash = hashes[static_cast<std::size_t>(i)];
      record.metrics = {{"status", std::string("exact")}, {"success", 1.0}};
      store.insert(record);
    }
    return path;
  };
  const std::string a = shard("a", "1/2", "h", 2, 2);
  const std::string b = shard("b", "2/2", "h", 1, 1);
  const std::string out = (directory_ / "merged.sqlite").string();
  ResultsStore::merge(out, {a, b}, false);
  EXPECT_EQ(ResultsStore(out).runCount(), 3);
  EXPECT_EQ(ResultsStore(out).meta("shard"), "1/1");
  {  // The declarations travel with the runs.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(out.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* count = nullptr;
    sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM metrics", -1, &count, nullptr);
    ASSERT_EQ(sqlite3_step(count), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(count, 0), static_cast<int>(resultMetrics().all().size()));
    sqlite3_finalize(count);
    sqlite3_close(db);
  }

  const auto refuses = [&](const std::vector<std::string>& inputs, const std::string& message) {
    const std::string target = (directory_ / "refused.sqlite").string();
    try {
      ResultsStore::merge(target, inputs, false);
      ADD_FAILURE() << "merged: " << message;
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(message), std::string::npos) << error.what();
    }
    EXPECT_FALSE(fs::exists(target));  // nothing half-written is left
  };
  refuses({a, shard("other", "2/2", "other_hash", 1, 1)}, "holds another experiment");
  refuses({a, a}, "given twice");
  refuses({a, shard("three", "2/3", "h", 1, 1)}, "but the first input is one of 2");
  refuses({a}, "1 of 2 shards given");
  refuses({a, shard("short", "2/2", "h", 3, 1)}, "is incomplete: 1 of 3");
  refuses({a, shard("old", "2/2", "h", 1, 1, "1")}, "schema version 1");
  // A damaged meta table is named, table and key (before: "unexpected error: stoi").
  refuses({a, shard("damaged", "2/2", "h", 1, 1, "abc")},
          "table meta, key 'schema_version': expected a whole number, got 'abc'");
  {  // A directory another process (here: another lock) writes to is refused.
    const DirectoryLock held((directory_ / "busy").string(), "a test");
    EXPECT_THROW(ResultsStore::merge((directory_ / "busy" / "m.sqlite").string(), {a, b}, false),
                 FileError);
    EXPECT_FALSE(fs::exists(directory_ / "busy" / "m.sqlite"));
  }
  // Merge never overwrites: `out` is there already, and keeps its runs.
  EXPECT_THROW(ResultsStore::merge(out, {a, b}, false), FileError);
  EXPECT_EQ(ResultsStore(out).runCount(), 3);
  // --partial accepts a missing shard.
  const std::string partial = (directory_ / "partial.sqlite").string();
  ResultsStore::merge(partial, {a}, true);
  EXPECT_EQ(ResultsStore(partial).runCount(), 2);
  // ... and the result says it is partial (it does not look complete).
  EXPECT_EQ(ResultsStore(partial).meta("shard"), "partial");
  EXPECT_EQ(ResultsStore(partial).meta("merged_from"), "1 of 2 shards; missing 2/2");
  EXPECT_EQ(ResultsStore(out).meta("merged_from"), "2 of 2 shards");
}

/// A fresh temporary directory `name` with an empty out/ and victim.txt holding "precious":
/// the file a link planted in out/ would have kinolab write into.
fs::path directoryWithVictim(const std::string& name) {
  const fs::path directory = fs::temp_directory_path() / (name + std::to_string(getpid()));
  fs::remove_all(directory);
  fs::create_directories(directory / "out");
  std::ofstream(directory / "victim.txt") << "precious";
  return directory;
}

TEST(DirectoryLock, AChildOfTheHolderDoesNotKeepTheLockOnceTheHolderLetsGo) {
  // The runner forks its workers while it holds its output directory: a worker still alive
  // after its runner was killed must not keep the resumed run out ("in use by another
  // process": a SIGKILL test failed so on a loaded machine).
  const fs::path directory =
      fs::temp_directory_path() / ("kinolab_lock_fork_" + std::to_string(getpid()));
  fs::remove_all(directory);
  int ready[2];
  int gate[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(gate), 0);
  pid_t child = -1;
  {
    const DirectoryLock held(directory.string(), "a test");
    child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {  // started (past fork), then alive until the parent has locked again
      char byte = 0;
      const bool told = write(ready[1], "r", 1) == 1;
      _exit(told && read(gate[0], &byte, 1) == 1 ? 0 : 1);
    }
    char byte = 0;
    ASSERT_EQ(read(ready[0], &byte, 1), 1);
  }
  EXPECT_NO_THROW(DirectoryLock(directory.string(), "the next run"));
  EXPECT_EQ(write(gate[1], "x", 1), 1);
  int status = 0;
  EXPECT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  for (const int fd : {ready[0], ready[1], gate[0], gate[1]}) close(fd);
  fs::remove_all(directory);
}

TEST(DirectoryLock, ALockFileThatIsALinkIsRefusedAndWhatItNamesIsUntouched) {
  const fs::path directory = directoryWithVictim("kinolab_lock_link_");
  const fs::path victim = directory / "victim.txt";
  fs::create_symlink(victim, directory / "out" / ".kinolab.lock");
  try {
    const DirectoryLock lock((directory / "out").string(), "a test");
    ADD_FAILURE() << "a linked lock file was accepted";
  } catch (const FileError& error) {
    EXPECT_NE(std::string(error.what()).find("symbolic link"), std::string::npos) << error.what();
  }
  std::ifstream in(victim);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "precious");
  fs::remove(directory / "out" / ".kinolab.lock");
  fs::create_directory(directory / "out" / ".kinolab.lock");  // nor a directory
  EXPECT_THROW(DirectoryLock((directory / "out").string(), "a test"), FileError);
  // The results database is not opened through a link either: an empty file it names would
  // become a database (SQLite takes an empty file for a new one).
  const fs::path empty = directory / "empty.txt";
  std::ofstream{empty};
  fs::create_symlink(empty, directory / "out" / "results.sqlite");
  EXPECT_THROW(ResultsStore((directory / "out" / "results.sqlite").string()), FileError);
  EXPECT_EQ(fs::file_size(empty), 0u);
  fs::remove_all(directory);
}

TEST(OutputFile, ALinkOrAPipeWhereKinolabWritesIsRefusedAndWhatItNamesIsUntouched) {
  const fs::path directory = directoryWithVictim("kinolab_output_link_");
  const fs::path victim = directory / "victim.txt";
  const auto text = [](const fs::path& path) {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const fs::path csv = directory / "out" / "summary.csv";
  fs::create_symlink(victim, csv);
  EXPECT_THROW(OutputFile{csv.string()}, FileError);
  // Written atomically, a link at the name is replaced by the file, never written through ...
  writeFileAtomically(csv.string(), "a,b\n");
  EXPECT_FALSE(fs::is_symlink(csv));
  EXPECT_EQ(text(csv), "a,b\n");
  // ... and a link at its temporary name is refused.
  fs::create_symlink(victim, directory / "out" / "summary.csv.tmp");
  try {
    writeFileAtomically(csv.string(), "c,d\n");
    ADD_FAILURE() << "written through a link";
  } catch (const FileError& error) {
    EXPECT_NE(std::string(error.what()).find("summary.csv.tmp: the output file is a symbolic link"),
              std::string::npos)
        << error.what();
  }
  EXPECT_EQ(text(victim), "precious");
  EXPECT_EQ(text(csv), "a,b\n");
  // A pipe is refused at once, not waited on.
  const fs::path pipe = directory / "out" / "pipe.csv";
  ASSERT_EQ(mkfifo(pipe.c_str(), 0600), 0);
  try {
    const OutputFile piped(pipe.string());
    ADD_FAILURE() << "a pipe was opened";
  } catch (const FileError& error) {
    EXPECT_NE(std::string(error.what()).find("pipe.csv: not a regular file"), std::string::npos)
        << error.what();
  }
  fs::remove_all(directory);
}

TEST(QuerySampler, PairsAreFreeInTheRegionAtTheirDistancesAndImpossibleOnesAreRefused) {
  const auto world = World::build(WorldSpec::fromFile(
      (fs::path(KINOLAB_SOURCE_DIR) / "tests/support/small_forest.yaml").string()));
  const Box region{{1.0, 1.0, 1.0}, {9.0, 9.0, 2.0}};
  Rng rng(3);
  const auto queries = sampleFreeQueries(*world, {region, 0.5, 4.0, 7.0}, 40, rng, "small");
  ASSERT_EQ(queries.size(), 40u);
  for (const PlanningQuery& query : queries) {
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(query.start.col(0)), query.goal}) {
      EXPECT_TRUE(region.contains(p));
      EXPECT_GE(world->distance(p), 0.5);
    }
    const double distance = (query.goal - query.start.col(0)).norm();
    EXPECT_GE(distance, 4.0);
    EXPECT_LE(distance, 7.0);
    EXPECT_TRUE(query.start.rightCols(3).isZero());  // at rest
  }
  Rng again(3);
  EXPECT_EQ(sampleFreeQueries(*world, {region, 0.5, 4.0, 7.0}, 40, again, "small")[17].goal,
            queries[17].goal);
  try {
    sampleFreeQueries(*world, {region, 0.5, 50.0, 60.0}, 1, rng, "small", 1000);
    ADD_FAILURE() << "a pair 50 m apart in a 10 m world";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("world 'small'"), std::string::npos);
  }
  EXPECT_THROW(sampleFreePosition(*world, region, 100.0, rng, "a start", "small", 1000),
               ConfigError);
}

TEST(QuerySampler, ALatticePutsXAndYOnItsPointsAndARegionWithoutOneIsRefused) {
  const auto world = World::build(WorldSpec::fromFile(
      (fs::path(KINOLAB_SOURCE_DIR) / "tests/support/small_forest.yaml").string()));
  const Box region{{1.0, 1.0, 1.55}, {9.0, 9.0, 1.55}};
  Rng rng(5);
  const auto queries =
      sampleFreeQueries(*world, {region, 0.5, 3.0, 8.0, 0.5, 0.05}, 30, rng, "small");
  for (const PlanningQuery& query : queries) {
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(query.start.col(0)), query.goal}) {
      EXPECT_TRUE(region.contains(p)) << p.transpose();
      EXPECT_TRUE(world->isFree(p, 0.5));
      for (int axis = 0; axis < 2; ++axis) {
        const double k = (p[axis] - 0.05) / 0.5;
        EXPECT_NEAR(k, std::round(k), 1e-9) << p.transpose();
      }
      EXPECT_DOUBLE_EQ(p.z(), 1.55);
    }
  }
  // No lattice point between x = 1.1 and 1.5 (they are at 1.05 and 1.55).
  const Box slit{{1.1, 1.0, 1.55}, {1.5, 9.0, 1.55}};
  EXPECT_THROW(sampleFreeQueries(*world, {slit, 0.5, 0.0, 8.0, 0.5, 0.05}, 1, rng, "small"),
               ConfigError);
}

// Two rooms 6 x 3 x 2 m side by side, split by a wall at x = 3 (0.2 m thick) that is sealed,
// or has a door 1 m wide and the rooms' height.
std::shared_ptr<const World> twoRooms(bool door) {
  VoxelGrid grid(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(6.0, 3.0, 2.0)}, 0.1);
  for (int y = 0; y < 30; ++y) {
    for (int z = 0; z < 20; ++z) {
      const bool in_door = door && y >= 10 && y < 20;
      for (int x = 29; x < 31 && !in_door; ++x) grid.setOccupied(VoxelIndex(x, y, z), true);
    }
  }
  Esdf field(grid);
  return std::make_shared<const World>("rooms", 0, std::move(grid), std::move(field));
}

TEST(QuerySampler, ConnectedPairsShareAPieceOfFreeSpaceAndNoneAcrossASealedWallIsRefused) {
  const auto sealed = twoRooms(false);
  const auto open = twoRooms(true);
  const Eigen::Vector3d left(1.5, 1.5, 1.0);
  const Eigen::Vector3d right(4.5, 1.5, 1.0);
  const FreeComponents sealed_parts(*sealed, 0.4);
  const FreeComponents open_parts(*open, 0.4);
  EXPECT_EQ(sealed_parts.count(), 2);
  EXPECT_FALSE(sealed_parts.joined(left, right));
  EXPECT_TRUE(sealed_parts.joined(left, Eigen::Vector3d(0.6, 2.4, 1.4)));
  EXPECT_EQ(open_parts.count(), 1);
  EXPECT_TRUE(open_parts.joined(left, right));
  // No room for the body against the wall, outside the map, and through a door too narrow.
  EXPECT_EQ(sealed_parts.componentOf(Eigen::Vector3d(2.7, 1.5, 1.0)), -1);
  EXPECT_EQ(sealed_parts.componentOf(Eigen::Vector3d(7.0, 1.5, 1.0)), -1);
  EXPECT_FALSE(FreeComponents(*open, 0.6).joined(left, right));

  // Pairs drawn in both rooms: each in one room when they must be connected, some across the
  // wall when not.
  const Box region{{0.3, 0.3, 0.5}, {5.7, 2.7, 1.5}};
  Rng rng(4);
  int across = 0;
  for (const PlanningQuery& query : sampleFreeQueries(*sealed, {region, 0.3, 1.0}, 40, rng, "r")) {
    across += (query.start(0, 0) - 3.0) * (query.goal.x() - 3.0) < 0.0;
  }
  EXPECT_GT(across, 5);
  FreeQueryRegion connected{region, 0.3, 1.0};
  connected.connected_radius = 0.4;
  for (const PlanningQuery& query : sampleFreeQueries(*sealed, connected, 40, rng, "r")) {
    EXPECT_GT((query.start(0, 0) - 3.0) * (query.goal.x() - 3.0), 0.0) << query.goal.transpose();
    EXPECT_TRUE(sealed_parts.joined(query.start.col(0), query.goal));
  }
  // 4 m apart: only across the wall (a room's region is at most 3.5 m across), so through the
  // door or not at all.
  connected.min_distance = 4.0;
  const auto through = sampleFreeQueries(*open, connected, 10, rng, "r");
  EXPECT_EQ(through.size(), 10u);
  try {
    sampleFreeQueries(*sealed, connected, 1, rng, "rooms", 2000);
    ADD_FAILURE() << "a connected pair 4 m apart across a sealed wall";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("world 'rooms'"), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("queries.random.connected"), std::string::npos)
        << error.what();
  }
}

TEST_F(ExperimentTest, AnyPluginParameterOfAPlannerMayBeWrittenAsABlock) {
  // `NAME: {type: KEY, params: {...}}` in a planner's entry is `params: {NAME: KEY, NAME.P:
  // ...}` for any plugin parameter, the sampler no different from the heuristic.
  const Experiment e = Experiment::fromFile(write("blocks.yaml", R"(kind: planning
name: blocks
worlds: [{id: small, spec: small_forest.yaml}]
queries: {random: {count: 1, min_distance: 3}}
planners:
  - id: a
    type: eager_mp_astar
    sampler: {type: normal, params: {sigma: 0.4}}
    heuristic: {type: geodesic, params: {time_optimal: off}}
)"));
  const ExperimentPlanner& planner = e.variants.front().planners.front();
  EXPECT_EQ(planner.parameters.text("sampler"), "normal");
  EXPECT_EQ(planner.parameters.nested("sampler").real("sigma"), 0.4);
  EXPECT_EQ(planner.parameters.text("heuristic"), "geodesic");
  EXPECT_EQ(planner.sampler(), "normal");
  // A block for a parameter that is not a plugin, or that the planner lacks, is refused.
  EXPECT_THROW(Experiment::fromFile(write("tau.yaml", R"(kind: planning
name: tau
worlds: [{id: small, spec: small_forest.yaml}]
queries: {random: {count: 1, min_distance: 3}}
planners: [{id: a, type: eager_mp_astar, tau: {type: x}}]
)")),
               ConfigError);
}

}  // namespace
}  // namespace kinolab
