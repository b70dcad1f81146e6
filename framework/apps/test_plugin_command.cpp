// `kinolab test-plugin LIB.so`: runs the conformance suites (the program kinolab-conformance,
// installed beside kinolab) on every plugin a library registers, each test in a child
// process of its own, so that a plugin that crashes or hangs is a reported failure, not the
// end of the report.
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/process.hpp"

namespace kinolab::apps {
namespace {

struct TestPluginOptions {
  std::string library;
  std::vector<std::string> gtest_arguments;
  int timeout = 300;  ///< s per test
};

/// The conformance program: $KINOLAB_CONFORMANCE, else kinolab-conformance beside this
/// executable (both in a build tree and in an installation).
std::string conformanceProgram() {
  if (const char* set = std::getenv("KINOLAB_CONFORMANCE"); set && *set) return set;
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  const auto program = self.parent_path() / "kinolab-conformance";
  if (error || !std::filesystem::is_regular_file(program, error)) {
    throw FileError("no conformance program beside " + self.string() +
                    " (kinolab-conformance is built with the tests: KINOLAB_BUILD_TESTS=ON; "
                    "or set KINOLAB_CONFORMANCE to its path)");
  }
  return program.string();
}

/// Every plugin the library at `origin` registered: its key and "kind 'key'" (one key may
/// name plugins of several kinds).
std::vector<std::pair<std::string, std::string>> keysFrom(const std::string& origin) {
  std::vector<std::pair<std::string, std::string>> keys;
  for (const PluginRegistryBase* registry : pluginRegistries()) {
    for (const PluginInfo* info : registry->list()) {
      if (info->origin == origin) {
        keys.emplace_back(info->key, registry->kind() + " '" + info->key + "'");
      }
    }
  }
  return keys;
}

/// The tests `program` would run under `filter` and then `extra` (a filter there replaces
/// ours), as `Suite.Test/param` names.
std::vector<std::string> listedTests(const std::string& program, const std::string& filter,
                                     const std::vector<std::string>& extra) {
  std::vector<std::string> arguments{program, "--gtest_list_tests", "--gtest_filter=" + filter};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  const CommandOutput listed = runCommand(arguments);
  if (listed.status != 0) {
    throw Error(program + " could not list its tests (exit " + std::to_string(listed.status) +
                "):\n" + listed.output);
  }
  std::vector<std::string> tests;
  std::istringstream lines(listed.output);
  std::string suite;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty()) continue;
    if (line.front() != ' ') {
      suite = line.substr(0, line.find(' '));
    } else {
      const auto begin = line.find_first_not_of(' ');
      tests.push_back(suite + line.substr(begin, line.find(' ', begin) - begin));
    }
  }
  return tests;
}

/// One test in a child of its own: "" when it passed, else what happened and its output.
std::string runOne(const std::string& program, const std::string& test,
                   const TestPluginOptions& options) {
  std::vector<std::string> arguments{program};
  arguments.insert(arguments.end(), options.gtest_arguments.begin(), options.gtest_arguments.end());
  arguments.push_back("--gtest_filter=" + test);  // last: this one test
  const CommandOutput run = runCommand(arguments, options.timeout);
  if (run.status == 0 && run.signal == 0) return "";
  std::string what =
      run.status == 124 ? "hung: killed after " + std::to_string(options.timeout) + " s (--timeout)"
      : run.signal != 0
          ? "crashed: signal " + std::to_string(run.signal) + " (" + strsignal(run.signal) + ")"
          : "failed (exit " + std::to_string(run.status) + ")";
  // Its output indented under the verdict, so that the report's own lines stand out.
  std::string indented;
  std::istringstream lines(run.output);
  for (std::string line; std::getline(lines, line);) indented += "    | " + line + "\n";
  return what + "\n" + indented;
}

/// Runs the conformance suites on the library's plugins, each test in a child process; the
/// exit status: 0 when every test passed, 1 otherwise.
int runTestPlugin(const TestPluginOptions& options) {
  loadPluginLibrary(options.library);
  const std::string origin = std::filesystem::canonical(options.library).string();
  const auto keys = keysFrom(origin);
  if (keys.empty()) throw PluginError(origin + " registers no plugin: nothing to test");
  std::string filter;
  for (const auto& [key, name] : keys) filter += (filter.empty() ? "" : ":") + ("*/" + key);
  const std::string program = conformanceProgram();
  ::setenv("KINOLAB_TEST_PLUGINS", origin.c_str(), 1);
  // Say which plugins no suite covers: a kind without a conformance suite, or a world
  // generator that needs a value to build (the generator suite builds at the defaults).
  std::set<std::string> covered;
  for (const std::string& test : listedTests(program, filter, {})) {
    covered.insert(test.substr(test.rfind('/') + 1));
  }
  for (const auto& [key, name] : keys) {
    std::cout << (covered.count(key) ? "testing " : "no conformance suite covers ") << name << '\n';
  }
  if (covered.empty()) throw PluginError("no conformance suite covers a plugin of " + origin);
  // The tests to run: the options after -- may narrow them (a --gtest_filter there replaces
  // the library's).
  const std::vector<std::string> tests = listedTests(program, filter, options.gtest_arguments);
  if (tests.empty()) {
    throw PluginError("no conformance test selected for the plugins of " + origin +
                      " (a --gtest_filter after -- that selects none?)");
  }
  int failed = 0;
  for (const std::string& test : tests) {
    std::cout << "[ RUN      ] " << test << std::endl;
    const std::string problem = runOne(program, test, options);
    if (problem.empty()) {
      std::cout << "[       OK ] " << test << std::endl;
      continue;
    }
    ++failed;
    std::cout << "[  FAILED  ] " << test << ": " << problem << std::flush;
  }
  std::cout << tests.size() << " tests: " << tests.size() - static_cast<std::size_t>(failed)
            << " passed, " << failed << " FAILED" << std::endl;
  return failed == 0 ? 0 : 1;
}

}  // namespace

void addTestPluginCommand(CLI::App& app) {
  auto options = std::make_shared<TestPluginOptions>();
  CLI::App* command = app.add_subcommand(
      "test-plugin",
      "Run the conformance suites on every plugin a library registers (planners, samplers, "
      "heuristics, lower bounds, search spaces, sensors, vehicle maps, world generators); "
      "exits non-zero when one fails");
  command->add_option("library", options->library, "The plugin library (.so)")->required();
  command
      ->add_option("--timeout", options->timeout,
                   "Seconds a test may take before it counts as hung")
      ->check(CLI::Range(1, 86400))
      ->capture_default_str();
  command
      ->add_option("gtest_arguments", options->gtest_arguments,
                   "After --: options for the conformance program (e.g. --gtest_repeat=3)")
      ->type_name("ARG");
  command->footer(
      "Example: kinolab test-plugin build/libmy_planner.so -- --gtest_repeat=3\n"
      "Each test runs in a child process: a plugin that crashes or hangs fails its test and the "
      "rest still run. The suites and what they assert: docs/extending/README.md.");
  command->callback([options]() {
    if (const int status = runTestPlugin(*options); status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace kinolab::apps
