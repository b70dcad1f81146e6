// kinolab slurm's script generation and layout, as a library (the command is a thin shell
// over it; tests/slurm/ runs it against a real local cluster).
#include "kinolab/experiment/slurm.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <utility>
#include <vector>

#include "kinolab/core/error.hpp"
#include "support/test_plugins.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;

class SlurmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::loadTestPlugins();
    directory_ = fs::temp_directory_path() / ("kinolab_slurm_test_" + std::to_string(getpid()));
    fs::create_directories(directory_);
    fs::copy_file(fs::path(KINOLAB_SOURCE_DIR) / "tests/support/small_forest.yaml",
                  directory_ / "small_forest.yaml", fs::copy_options::overwrite_existing);
    path_ = (directory_ / "exp.yaml").string();
    std::ofstream(path_) << "kind: planning\nname: exp\nseed: 1\n"
                            "worlds:\n  - {id: small, spec: small_forest.yaml}\n"
                            "queries:\n  random: {count: 5, min_distance: 3, max_distance: 8}\n"
                            "planners:\n  - {id: eager, type: eager_mp_astar}\n";
  }
  void TearDown() override { fs::remove_all(directory_); }

  fs::path directory_;
  std::string path_;
};

TEST_F(SlurmTest, ScriptsRunEveryShardAndMergeTheirDatabases) {
  const Experiment experiment = Experiment::fromFile(path_);
  SlurmRequest request;
  request.shards = 3;
  request.partition = "batch";
  request.time = "01:30:00";
  request.cpus_per_task = 4;
  request.memory = "8G";
  const SlurmLayout layout{"/shared/table2"};
  const SlurmScripts scripts =
      slurmScripts(experiment, path_, layout, request, "/opt/kinolab/bin/kinolab", "/cache");
  EXPECT_NE(scripts.array.find("#SBATCH --array=1-3\n"), std::string::npos);
  EXPECT_NE(scripts.array.find("#SBATCH --partition=batch\n"), std::string::npos);
  EXPECT_NE(scripts.array.find("#SBATCH --time=01:30:00\n"), std::string::npos);
  EXPECT_NE(scripts.array.find("#SBATCH --cpus-per-task=4\n"), std::string::npos);
  EXPECT_NE(scripts.array.find("#SBATCH --mem=8G\n"), std::string::npos);
  EXPECT_NE(scripts.array.find("(5 runs) as 3 shards"), std::string::npos);
  // The shard directory is the layout's.
  EXPECT_NE(scripts.array.find("--out '/shared/table2/shards'/\"$SLURM_ARRAY_TASK_ID\" "
                               "--shard \"$SLURM_ARRAY_TASK_ID/3\" --resume"),
            std::string::npos)
      << scripts.array;
  for (int shard = 1; shard <= 3; ++shard) {
    EXPECT_NE(scripts.merge.find(shellQuote(layout.shardDatabase(shard))), std::string::npos);
  }
  EXPECT_EQ(layout.shardDatabase(2), "/shared/table2/shards/2/results.sqlite");
  EXPECT_NE(scripts.merge.find(" merge '/shared/table2/results.sqlite'"), std::string::npos);
}

TEST_F(SlurmTest, InjectionAttemptsAreRefusedOrQuotedAndTheScriptsCreateNothing) {
  const Experiment experiment = Experiment::fromFile(path_);
  const fs::path canary = directory_ / "canary";
  // Directive values cannot be quoted in #SBATCH lines: they are refused.
  for (const auto& [option, value] : std::vector<std::pair<std::string, std::string>>{
           {"--mem", "8G\ntouch " + canary.string()},
           {"--mem", "8G; touch x"},
           {"--partition", "batch\ntouch " + canary.string()},
           {"--partition", "a b"},
           {"--time", "01:00:00\ntouch x"}}) {
    SlurmRequest request;
    if (option == "--mem") request.memory = value;
    if (option == "--partition") request.partition = value;
    if (option == "--time") request.time = value;
    try {
      slurmScripts(experiment, path_, SlurmLayout{"/out"}, request, "kinolab", "/cache");
      ADD_FAILURE() << option << " " << value;
    } catch (const ConfigError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(option), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << "a newline reached the message";
    }
  }
  EXPECT_THROW(slurmScripts(experiment, path_, SlurmLayout{"/out\n#SBATCH --x"}, SlurmRequest{},
                            "kinolab", "/cache"),
               ConfigError);
  // Paths in the script bodies are quoted: run by bash with `echo` as kinolab, they are
  // arguments, never commands.
  const std::string hostile = "$(touch " + canary.string() + ")'`touch " + canary.string() + "`";
  SlurmRequest request;
  request.shards = 2;
  const SlurmLayout layout{(directory_ / "out").string()};
  const SlurmScripts scripts = slurmScripts(experiment, hostile, layout, request, "echo", hostile);
  for (const std::string* script : {&scripts.array, &scripts.merge}) {
    const fs::path file = directory_ / "script.sh";
    std::ofstream(file) << *script;
    const std::string command = "SLURM_ARRAY_TASK_ID=1 bash " + file.string() + " > /dev/null";
    EXPECT_EQ(std::system(command.c_str()), 0) << *script;
  }
  EXPECT_FALSE(fs::exists(canary));
}

TEST_F(SlurmTest, BadRequestsAreRefusedNamingTheOption) {
  const Experiment experiment = Experiment::fromFile(path_);
  const auto refused = [&](SlurmRequest request, const std::string& option) {
    try {
      slurmScripts(experiment, path_, SlurmLayout{"/out"}, request, "kinolab", "/cache");
      ADD_FAILURE() << option;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(option), std::string::npos) << error.what();
    }
  };
  SlurmRequest no_shards;
  no_shards.shards = 0;
  refused(no_shards, "--shards");
  // More shards than runs (a billion: once written without end) is refused with the count.
  SlurmRequest too_many;
  too_many.shards = 1000000000;
  refused(too_many,
          "--shards 1000000000: expected at most " + std::to_string(experiment.runs().size()));
  SlurmRequest no_cpus;
  no_cpus.cpus_per_task = 0;
  refused(no_cpus, "--cpus-per-task");
  for (const char* time : {"2h", "01:60:00", "1:2", "01:00:00x"}) {
    SlurmRequest request;
    request.time = time;
    refused(request, "--time");
  }
}

TEST(SlurmJobs, TheJobsFileRoundTripsAndMalformedOnesAreRefused) {
  const SlurmJobs jobs{"123", "124", 16};
  const SlurmJobs read = SlurmJobs::parse(jobs.text(), "slurm_jobs.txt");
  EXPECT_EQ(read.array_job, "123");
  EXPECT_EQ(read.merge_job, "124");
  EXPECT_EQ(read.shards, 16);
  EXPECT_THROW(SlurmJobs::parse("array 1\nshards 2\n", "f"), FileError);
  EXPECT_THROW(SlurmJobs::parse("array 1\nmerge 2\nshards 0\n", "f"), FileError);
  EXPECT_THROW(SlurmJobs::parse("array 1\nmerge 2\nshards 2\nrm -rf 3\n", "f"), FileError);
  EXPECT_THROW(SlurmJobs::parse("array 1;touch\nmerge 2\nshards 2\n", "f"), FileError);
}

}  // namespace
}  // namespace kinolab
