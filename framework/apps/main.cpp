// The `kinolab` command: one binary, one subcommand per job.
#include <filesystem>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/version.hpp"

namespace {

/// The first word that is not an option, when it names no command: a message with the
/// nearest command's name. Empty otherwise.
std::string unknownCommand(const CLI::App& app, int argc, char** argv) {
  std::string word;
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--plugin") {
      ++i;  // its value
      continue;
    }
    if (argument.rfind('-', 0) == 0) continue;
    word = argument;
    break;
  }
  if (word.empty()) return "";
  std::vector<std::string> names;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (command->get_name() == word) return "";
    names.push_back(command->get_name());
  }
  std::string message = "unknown command '" + word + "'";
  if (const std::string nearest = kinolab::closestMatch(word, names); !nearest.empty()) {
    message += "; did you mean '" + nearest + "'?";
  }
  return message + " (kinolab --help lists the commands)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kinolab: kinodynamic UAV motion planning experiments", "kinolab"};
  app.set_version_flag("--version", std::string("kinolab ") + kinolab::kVersion);
  app.require_subcommand(1);
  // Options of the main command may also follow the subcommand (`kinolab list --plugin X`).
  app.fallthrough();
  app.add_option("--plugin",
                 "Load a plugin library (repeatable, before or after the command; a library "
                 "is loaded once however its path is spelt); see `kinolab list`")
      ->type_name("PATH")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->each([](const std::string& path) { kinolab::loadPluginLibrary(path); });
  app.footer("Run 'kinolab COMMAND --help' for the options of one command.");
  // One prefix for every error, the command line's included.
  app.failure_message([](const CLI::App*, const CLI::Error& error) {
    return std::string("kinolab: error: ") + error.what() +
           "\nRun with --help for more information.\n";
  });
  kinolab::apps::addExportCommand(app);
  kinolab::apps::addFlyCommand(app);
  kinolab::apps::addListCommand(app);
  kinolab::apps::addPlanCommand(app);
  kinolab::apps::addReportCommand(app);
  kinolab::apps::addRunCommand(app);
  kinolab::apps::addSlurmCommand(app);
  kinolab::apps::addSamplingStudyCommand(app);
  kinolab::apps::addTestPluginCommand(app);
  kinolab::apps::addWorldCommand(app);
  try {
    kinolab::registerBuiltinPlugins();
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& error) {
    return error.get_exit_code();
  } catch (const CLI::ParseError& error) {
    // --help and --version exit 0; a malformed or out-of-range option is bad input: 1.
    if (error.get_exit_code() != 0) {
      if (const std::string unknown = unknownCommand(app, argc, argv); !unknown.empty()) {
        std::cerr << "kinolab: error: " << unknown << '\n';
        return 1;
      }
    }
    return app.exit(error) == 0 ? 0 : 1;
  } catch (const kinolab::Error& error) {
    std::cerr << "kinolab: error: " << error.what() << '\n';
    return 1;
  } catch (const std::filesystem::filesystem_error& error) {
    // A path the system refuses (too long, through a file, not permitted): the user's input.
    std::cerr << "kinolab: error: " << error.what() << '\n';
    return 1;
  } catch (const std::bad_alloc&) {
    // Sizes from input are checked before they are allocated, and the large works name
    // themselves (whileDoing, an OutOfMemory above); this is memory running out elsewhere.
    std::cerr << "kinolab: error: " << kinolab::outOfMemoryMessage("") << '\n';
    return 1;
  } catch (const std::exception& error) {
    std::cerr << "kinolab: unexpected error: " << error.what() << '\n';
    return 3;
  } catch (...) {
    // Plugin code is guarded where it is called (rethrowFromPlugin); this is the last net.
    std::cerr << "kinolab: unexpected error: an exception that is not a std::exception\n";
    return 3;
  }
  return 0;
}
