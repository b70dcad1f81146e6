#pragma once

#include <CLI/CLI.hpp>

namespace kinolab::apps {

/// Each subcommand adds itself (options, help and the action to run) to the main app.
void addListCommand(CLI::App& app);
void addPlanCommand(CLI::App& app);
void addReportCommand(CLI::App& app);
void addRunCommand(CLI::App& app);
void addSlurmCommand(CLI::App& app);
void addSamplingStudyCommand(CLI::App& app);
void addWorldCommand(CLI::App& app);

}  // namespace kinolab::apps
