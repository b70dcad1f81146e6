// `kinolab sampling-study CONFIG.yaml`: the paper's Table I (alpha, L) for every sampler.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "commands.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/experiment/sampling_study.hpp"

namespace kinolab::apps {
namespace {

struct SamplingStudyOptions {
  std::string config_path;
  std::string out_dir;
};

std::string orDash(const std::optional<double>& value, const char* format) {
  if (!value) return "-";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), format, *value);
  return buffer;
}

void runSamplingStudyCommand(const SamplingStudyOptions& options) {
  const SamplingStudyConfig config = SamplingStudyConfig::fromFile(options.config_path);
  const auto rows = runSamplingStudy(config);
  const auto summaries = summarizeSamplingStudy(config, rows);
  const int states = (config.states.rest ? 1 : 0) + config.states.moving;

  std::printf(
      "sampling study '%s': order %d, tau %.3g s, threshold %.3g m, %d states (%s%d moving, "
      "%.2g-%.2g m/s)\n\n",
      config.name.c_str(), config.dynamics.order, config.dynamics.duration, config.threshold, states,
      config.states.rest ? "rest + " : "", config.states.moving, config.states.speed[0], config.states.speed[1]);
  std::printf("%-16s %-8s %6s  %-15s %-17s %9s %10s  %7s %7s\n", "sampler", "type", "M",
              "alpha (sd)", "L m (sd)", "breaking", "alpha_feas", "paper a", "paper L");
  for (const auto& s : summaries) {
    std::printf("%-16s %-8s %6d  %5.1f%% (%4.1f)   %.4f (%.4f)   %8.1f%% %9.1f%%  %7s %7s\n",
                s.sampler.c_str(), s.type.c_str(), s.controls, 100 * s.alpha, 100 * s.alpha_sd,
                s.mean_nearest, s.mean_nearest_sd, 100 * s.limit_breaking_share,
                100 * s.alpha_feasible,
                orDash(s.paper_alpha ? std::optional(100 * *s.paper_alpha) : std::nullopt, "%.0f%%")
                    .c_str(),
                orDash(s.paper_l, "%.3f").c_str());
  }
  std::printf(
      "\nalpha: share of samples whose primitive endpoint has no other within the threshold;\n"
      "L: mean nearest-neighbour distance of endpoints; breaking: primitives over a limit;\n"
      "alpha_feas: the same test among the primitives within the limits, over all M.\n");

  const std::filesystem::path out = options.out_dir.empty()
                                        ? std::filesystem::path("out/sampling_study") / config.name
                                        : std::filesystem::path(options.out_dir);
  std::filesystem::create_directories(out);
  std::string per_state =
      "sampler,state,speed,controls,useful,alpha,mean_nearest,limit_breaking,useful_feasible\n";
  for (const auto& r : rows) {
    per_state += r.sampler + "," + std::to_string(r.state) + "," + formatNumber(r.speed) + "," +
                 std::to_string(r.controls) + "," + std::to_string(r.useful) + "," +
                 formatNumber(r.alpha) + "," +
                 (std::isnan(r.mean_nearest) ? "" : formatNumber(r.mean_nearest)) + "," +
                 std::to_string(r.limit_breaking) + "," + std::to_string(r.useful_feasible) + "\n";
  }
  std::string summary =
      "sampler,type,controls,alpha,alpha_sd,mean_nearest,mean_nearest_sd,limit_breaking_share,"
      "alpha_feasible,paper_alpha,paper_mean_nearest\n";
  for (const auto& s : summaries) {
    summary += s.sampler + "," + s.type + "," + std::to_string(s.controls) + "," +
               formatNumber(s.alpha) + "," + formatNumber(s.alpha_sd) + "," +
               formatNumber(s.mean_nearest) + "," + formatNumber(s.mean_nearest_sd) + "," +
               formatNumber(s.limit_breaking_share) + "," + formatNumber(s.alpha_feasible) + "," +
               (s.paper_alpha ? formatNumber(*s.paper_alpha) : "") + "," +
               (s.paper_l ? formatNumber(*s.paper_l) : "") + "\n";
  }
  writeFileAtomically((out / "sampling_study.csv").string(), per_state);
  writeFileAtomically((out / "summary.csv").string(), summary);
  std::printf("wrote %s/{sampling_study.csv, summary.csv}\n", out.string().c_str());
  const std::vector<SamplingReadingRow> readings = runSamplingReadings(config);
  if (!readings.empty()) {
    std::string csv =
        "sampler,controls,distance,propagation,pooling,threshold,alpha,mean_nearest\n";
    for (const auto& r : readings) {
      csv += r.sampler + "," + std::to_string(r.controls) + "," +
             (r.with_velocity ? "position_velocity" : "position") + "," +
             (r.propagation == Propagation::kEuler ? "euler" : "exact") + "," +
             (r.pooled ? "pooled" : "per_state") + "," + formatNumber(r.threshold) + "," +
             formatNumber(r.alpha) + "," +
             (std::isnan(r.mean_nearest) ? "" : formatNumber(r.mean_nearest)) + "\n";
    }
    writeFileAtomically((out / "readings.csv").string(), csv);
    std::printf("wrote %s/readings.csv: %zu readings x samplers\n", out.string().c_str(),
                readings.size());
  }
}

}  // namespace

void addSamplingStudyCommand(CLI::App& app) {
  auto options = std::make_shared<SamplingStudyOptions>();
  CLI::App* command = app.add_subcommand(
      "sampling-study",
      "Compare control samplers as in the paper's Table I: useful-sample ratio alpha, "
      "endpoint nearest-neighbour distance L and limit-breaking primitives");
  command
      ->add_option("config", options->config_path,
                   "Study file (kind: sampling_study), e.g. "
                   "experiments/paper_table1_samplers.yaml")
      ->required();
  command->add_option("--out", options->out_dir,
                      "Directory for sampling_study.csv (per sampler and state), summary.csv and, "
                      "with readings:, readings.csv (every sampler under every reading) "
                      "(default: out/sampling_study/NAME)");
  command->footer("Samplers are plugins: see `kinolab list samplers`.");
  command->callback([options] { runSamplingStudyCommand(*options); });
}

}  // namespace kinolab::apps
