#include "kinolab/experiment/experiment.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "experiment_document.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_fields.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;
using namespace experiment_document;

// ---- reading one variant -----------------------------------------------------------------

ExperimentPlanner readPlanner(const YamlReader& node) {
  ExperimentPlanner planner;
  planner.id = readName(node["id"]);
  planner.type = node.get<std::string>("type");
  if (const auto params = node.optional("params")) {
    planner.assignments = assignmentsFromYaml(*params);
  }
  // A plugin parameter of the planner (its `sampler`, `heuristic`, ...) may be written as a
  // block, `NAME: {type: KEY, params: {...}}`: the same as `params: {NAME: KEY, NAME.P: ...}`.
  if (const auto& planners = pluginRegistry<Planner>(); planners.contains(planner.type)) {
    for (const ParameterSpec& spec : planners.info(planner.type).parameters.all()) {
      const auto block = spec.type == ParameterType::kPlugin ? node.optional(spec.name)
                                                             : std::optional<YamlReader>();
      if (!block) continue;
      const YamlReader type = (*block)["type"];
      planner.assignments.push_back({spec.name, type.as<std::string>(), type.where()});
      if (const auto params = block->optional("params")) {
        for (ParameterAssignment assignment : assignmentsFromYaml(*params)) {
          assignment.name = spec.name + "." + assignment.name;
          planner.assignments.push_back(std::move(assignment));
        }
      }
      block->finish();
    }
  }
  node.finish();
  try {
    planner.parameters = configurePlanner(planner.type, planner.assignments).parameters;
  } catch (const PluginCodeError&) {
    // The planner's own code threw (its factory or its check): each of its runs records that
    // as its error when it makes the planner, and the experiment's other planners go on.
    planner.parameters = pluginRegistry<Planner>().resolve(planner.type, planner.assignments);
  } catch (const PluginError& error) {
    // An unknown planner or plugin key: the registry cannot know where it was written.
    // (Errors about assignments are ConfigErrors that carry their own position.)
    node.fail(error.what());
  }
  return planner;
}

/// The radius `queries.random.connected` joins start and goal at: the planners' largest body
/// radius, plus the planning margin of a flight (whose planners plan for the body grown by it).
double connectedRadius(const ExperimentVariant& variant, bool flights) {
  double radius = 0.0;
  for (const ExperimentPlanner& planner : variant.planners) {
    radius = std::max(radius, bodyFrom(planner.parameters).radius);
  }
  return radius + (flights ? variant.flight.real("planning_margin") : 0.0);
}

ExperimentVariant readVariant(const YamlReader& root, const std::string& directory,
                              const std::map<std::string, std::string>& spec_directories,
                              bool flights) {
  ExperimentVariant variant;
  std::set<std::string> ids;
  for (const YamlReader& item : root["worlds"].items()) {
    ExperimentWorld world;
    world.id = readName(item["id"]);
    if (!ids.insert("world " + world.id).second) item["id"].fail("duplicate world id");
    const auto found = spec_directories.find(world.id);
    world.spec = WorldSpec::fromYaml(item["spec"],
                                     found != spec_directories.end() ? found->second : directory);
    item.finish();
    variant.worlds.push_back(std::move(world));
  }
  if (variant.worlds.empty()) root["worlds"].fail("no worlds");
  readYamlFields(root, variant);
  if (variant.queries.random.max_distance < variant.queries.random.min_distance) {
    root["queries"]["random"]["max_distance"].fail("max_distance is below min_distance");
  }
  if (variant.queries.count() == 0)
    root["queries"].fail("no queries: give fixed, random or across");
  for (const YamlReader& item : root["planners"].items()) {
    ExperimentPlanner planner = readPlanner(item);
    if (!ids.insert("planner " + planner.id).second) item["id"].fail("duplicate planner id");
    variant.planners.push_back(std::move(planner));
  }
  if (variant.planners.empty()) root["planners"].fail("no planners");
  if (const auto flight = root.optional("flight")) {
    variant.flight = flightParameters().resolve(assignmentsFromYaml(*flight), "flight");
  } else {
    variant.flight = flightParameters().resolve({}, "flight");
  }
  variant.queries.random.connected_radius = connectedRadius(variant, flights);
  return variant;
}

}  // namespace

// ---- queries -------------------------------------------------------------------------------

std::vector<PlanningQuery> QuerySpec::make(const World& world, const std::string& world_id,
                                           std::uint64_t seed) const {
  std::vector<PlanningQuery> queries;
  for (const Fixed& item : fixed) {
    PlanningQuery query;
    query.start.col(0) = item.start;
    query.goal = item.goal;
    queries.push_back(query);
  }
  const Box& box = world.bounds();
  Rng rng = Rng::derive(seed, "queries/" + world_id);
  // Heights are above the map's floor, within the map.
  const auto region = [&](const std::array<double, 2>& h) {
    Box inside = box;
    inside.min.z() = std::max(box.min.z(), box.min.z() + h[0]);
    inside.max.z() = std::min(box.max.z(), box.min.z() + h[1]);
    return inside;
  };
  if (random.count > 0) {
    const FreeQueryRegion spec{
        region(random.height),
        random.clearance,
        random.min_distance,
        random.max_distance,
        random.lattice ? random.lattice->step : 0.0,
        random.lattice ? random.lattice->offset : 0.0,
        random.connected ? std::optional(random.connected_radius) : std::nullopt};
    const auto drawn = sampleFreeQueries(world, spec, random.count, rng, world_id);
    queries.insert(queries.end(), drawn.begin(), drawn.end());
  }
  const double voxel = world.esdf().resolution();
  for (int i = 0; i < across.count; ++i) {
    const int a = across.axis;
    Box start_face = region(across.height);
    Box goal_face = start_face;
    start_face.min[a] = box.min[a] + across.margin;
    start_face.max[a] = box.min[a] + across.margin + voxel;
    goal_face.min[a] = box.max[a] - across.margin - voxel;
    goal_face.max[a] = box.max[a] - across.margin;
    PlanningQuery query;
    query.start.col(0) =
        sampleFreePosition(world, start_face, across.clearance, rng, "an across start", world_id);
    query.goal =
        sampleFreePosition(world, goal_face, across.clearance, rng, "an across goal", world_id);
    queries.push_back(query);
  }
  return queries;
}

namespace {

// A query's rule: its fields' values alone ("5 1000000 0.6 1 2 lattice 0.5 0.05"), then with
// `connected` the radius it joins start and goal at ("... connected 0.55").
std::string randomRule(const QuerySpec::Random& random) {
  return canonicalFields(random) +
         (random.connected ? " connected " + formatNumber(random.connected_radius) : "");
}
std::string acrossRule(const QuerySpec::Across& across) { return canonicalFields(across); }

}  // namespace

std::string QuerySpec::queryText(int index) const {
  const int fixed_count = static_cast<int>(fixed.size());
  if (index < fixed_count) {
    return "fixed " + canonicalFields(fixed[static_cast<std::size_t>(index)]);
  }
  index -= fixed_count;
  // Random queries are drawn one after the other from one stream: the i-th depends on the
  // rule and on i, not on how many are drawn after it.
  if (index < random.count) return "random #" + std::to_string(index) + " " + randomRule(random);
  index -= random.count;
  return "across #" + std::to_string(index) + " " + acrossRule(across) + " after random " +
         std::to_string(random.count) + " " + randomRule(random);
}

std::string ExperimentVariant::budgetText(bool flights) const {
  // "10/4096/0/timing 1+3", then a flight's parameters.
  return canonicalFields(budget, {.separator = "/"}) + "/timing " +
         canonicalFields(timing, {.separator = "+"}) +
         (flights ? "/flight " + flight.canonical() : std::string());
}

std::string ExperimentPlanner::sampler() const {
  const auto& planners = pluginRegistry<Planner>();
  if (!planners.contains(type)) return "";
  for (const ParameterSpec& spec : planners.info(type).parameters.all()) {
    if (spec.type == ParameterType::kPlugin && spec.kind == "sampler") {
      return parameters.text(spec.name);
    }
  }
  return "";
}

std::string ExperimentPlanner::canonicalText() const {
  // The parameters' canonical text holds every plugin parameter's own (the sampler's too).
  return type + "{" + parameters.canonical() + "}";
}

bool ExperimentPlanner::ownTimeLimit() const {
  // An own limit of 0 ("none") leaves the experiment's budget as the planner's.
  return std::any_of(assignments.begin(), assignments.end(),
                     [](const ParameterAssignment& a) { return a.name == "time_limit"; }) &&
         parameters.real("time_limit") > 0.0;
}

double ExperimentPlanner::timeLimit(const ExperimentBudget& budget) const {
  return ownTimeLimit() ? parameters.real("time_limit") : budget.time;
}

// ---- the experiment -------------------------------------------------------------------------

namespace {

/// The folder the relative paths of top-level `key` are in: its file's (loadDocument), else
/// the experiment file's.
std::string directoryOf(const std::map<std::string, std::string>& directories,
                        const std::string& key, const std::string& path) {
  const auto found = directories.find(key);
  return found != directories.end() ? found->second : fs::path(path).parent_path().string();
}

/// The experiment file with its `extends:` chain merged, and world specs given as files read
/// in (so that a sweep can reach into them); `spec_directories` gets each such world's folder
/// and `directories` the folder each top-level key's relative paths are in (the file of the
/// chain it came from).
YAML::Node loadDocument(const std::string& path, std::string& source,
                        std::map<std::string, std::string>& spec_directories,
                        std::map<std::string, std::string>& directories) {
  std::vector<std::string> chain;
  YAML::Node document = loadWithBase(path, chain, directories);
  source = path;
  if (chain.size() > 1) {
    source +=
        " (extends " + join(std::vector<std::string>(chain.begin() + 1, chain.end()), ", ") + ")";
  }
  const std::string directory = directoryOf(directories, "worlds", path);
  const YamlReader root = YamlReader::fromNode(document, source);
  if (const auto worlds = root.optional("worlds")) {
    for (const YamlReader& item : worlds->items()) {
      if (const auto map = item.optional("map")) {
        // `map: FILE` (an OctoMap .bt/.ot) with `resolution`: a spec of one octomap generator.
        const std::string file =
            (fs::path(directory) / map->as<std::string>()).lexically_normal().string();
        if (!isRegularFile(file)) map->fail("no such map file: " + file);
        YAML::Node generator(YAML::NodeType::Map);
        generator["type"] = "octomap";
        // As written, relative to the experiment's folder as a spec file's paths are to its
        // own: the run identity is then the same in every checkout.
        generator["file"] = map->as<std::string>();
        generator["unknown"] = "free";
        YAML::Node spec(YAML::NodeType::Map);
        spec["name"] = item.get<std::string>("id");
        spec["resolution"] = item["resolution"].node();
        spec["generators"].push_back(generator);
        YAML::Node node = item.node();
        if (node["spec"]) item["spec"].fail("give either spec or map, not both");
        node.remove("map");
        node.remove("resolution");
        node["spec"] = spec;
        spec_directories[item.get<std::string>("id")] = directory;
        continue;
      }
      const auto spec = item.optional("spec");
      if (!spec || spec->isMap()) continue;
      const std::string file =
          (fs::path(directory) / spec->as<std::string>()).lexically_normal().string();
      if (!isRegularFile(file)) spec->fail("no such world spec file: " + file);
      YAML::Node node = item.node();
      node["spec"] = YamlReader::loadFile(file).node();
      spec_directories[item.get<std::string>("id")] = fs::path(file).parent_path().string();
    }
  }
  return document;
}

}  // namespace

namespace {

/// The top-level fields (kind, name, seed, store) and `plugins:` (each loaded now, so that the
/// rest of the file can name their keys).
void readHeader(const YamlReader& root, const std::string& directory, Experiment& experiment) {
  if (const auto kind = root.optional("kind");
      kind && kind->as<std::string>() == "sampling_study") {
    kind->fail(
        "sampling studies run with kinolab sampling-study; kinolab run takes 'planning' or "
        "'flight'");
  }
  readYamlFields(root, experiment);
  if (!experiment.flights && root.optional("flight")) {
    root["flight"].fail("flight parameters belong to 'kind: flight' experiments");
  }
  if (experiment.flights && root.optional("timing")) {
    root["timing"].fail("a flight is flown once: the timing protocol is for 'kind: planning'");
  }
  experiment.name = readName(root["name"]);
  if (const auto plugins = root.optional("plugins")) {
    for (const YamlReader& item : plugins->items()) {
      std::string file = item.as<std::string>();
      if (fs::path(file).is_relative()) file = (fs::path(directory) / file).string();
      if (!isRegularFile(file)) item.fail("no such plugin library: " + file);
      loadPluginLibrary(file);
      experiment.plugins.push_back(file);
    }
  }
}

/// `reproduces: {paper, rows, setting}`: a known paper, rows of it, and which variants run in
/// its setting (checked against the variants once they are read).
void readReproduces(const YamlReader& reproduces, Experiment& experiment) {
  const YamlReader paper = reproduces["paper"];
  experiment.reproduces_paper = paper.as<std::string>();
  const auto papers = reproducibleRows();
  const auto known = papers.find(experiment.reproduces_paper);
  if (known == papers.end()) {
    std::vector<std::string> names;
    for (const auto& [name, rows] : papers) names.push_back(name);
    paper.fail("unknown paper '" + experiment.reproduces_paper + "'" +
               didYouMean(experiment.reproduces_paper, names) + "; known: " + join(names, ", "));
  }
  for (const auto& [id, row] : reproduces["rows"].entries()) {
    const std::string name = row.as<std::string>();
    if (std::find(known->second.begin(), known->second.end(), name) == known->second.end()) {
      row.fail("'" + name + "' is not a row of " + experiment.reproduces_paper +
               "; its rows: " + join(known->second, ", "));
    }
    experiment.reproduces_rows.emplace_back(id, name);
  }
  if (const auto setting = reproduces.optional("setting")) {
    if (setting->isSequence()) {
      for (const YamlReader& label : setting->items()) {
        experiment.reproduces_setting.push_back(label.as<std::string>());
      }
    } else if (setting->as<bool>()) {
      experiment.reproduces_setting.push_back("*");  // every variant, resolved below
    }
  }
  reproduces.finish();
}

/// Every sweep point's variant: the one document with the point's values set, read, then set
/// back. The sweep's value nodes belong to the document (no memory merges) and keep their
/// file positions for messages, and each variant costs the size of the document without its
/// sweep. Also the experiment's canonical text: the document without its sweep, then each
/// variant's values (dumping every variant would cost far more).
void readVariants(YAML::Node document, const std::vector<SweepPoint>& points,
                  const std::string& directory, const std::string& source,
                  const std::map<std::string, std::string>& spec_directories,
                  Experiment& experiment) {
  YAML::Node variant_node = document;
  variant_node.remove("sweep");
  experiment.canonical = YAML::Dump(variant_node) + "\n--- # variants\n";
  std::vector<PathChange> changes;
  std::size_t total_runs = 0;
  for (const SweepPoint& point : points) {
    std::string label;
    for (std::size_t i = 0; i < point.values.size(); ++i) {
      const auto& [key, value] = point.values[i];
      setPath(variant_node, key, value, point.where[i], changes);
      if (!point.shown[i].empty()) label += (label.empty() ? "" : ", ") + point.shown[i];
    }
    const YamlReader reader = YamlReader::fromNode(variant_node, source);
    for (const char* key : {"kind", "name", "seed", "plugins", "store", "reproduces"}) {
      (void)reader.optional(key);
    }
    ExperimentVariant variant =
        readVariant(reader, directory, spec_directories, experiment.flights);
    reader.finish();
    variant.label = label;
    total_runs += variant.worlds.size() * static_cast<std::size_t>(variant.queries.count()) *
                  variant.planners.size() * static_cast<std::size_t>(variant.repetitions);
    if (total_runs > kMaxRuns) {
      throw ConfigError(source + ": more than " + std::to_string(kMaxRuns) +
                        " runs (worlds x queries x planners x repetitions over " +
                        std::to_string(points.size()) +
                        " variants); split the experiment or shrink it");
    }
    experiment.canonical += "- " + (label.empty() ? std::string("(no sweep)") : label) + "\n";
    experiment.variants.push_back(std::move(variant));
    undo(changes);
  }
}

}  // namespace

Experiment Experiment::fromFile(const std::string& path) {
  std::string source;
  std::map<std::string, std::string> spec_directories;
  std::map<std::string, std::string> directories;
  const YAML::Node document = loadDocument(path, source, spec_directories, directories);
  Experiment experiment;
  experiment.source = path;

  const YamlReader root = YamlReader::fromNode(document, source);
  readHeader(root, directoryOf(directories, "plugins", path), experiment);
  const std::optional<YamlReader> reproduces = root.optional("reproduces");
  if (reproduces) readReproduces(*reproduces, experiment);
  std::vector<SweepPoint> points(1);
  if (const auto sweep = root.optional("sweep")) points = expandSweep(*sweep);
  // The keys every variant reads; marked read here so that finish() sees only unknown ones.
  for (const char* key :
       {"worlds", "queries", "planners", "repetitions", "budget", "timing", "flight"}) {
    (void)root.optional(key);
  }
  root.finish();

  readVariants(document, points, directoryOf(directories, "worlds", path), source, spec_directories,
               experiment);
  // The run-hash format is part of the experiment's identity: a database whose runs were
  // hashed another way (before plugin parameters nested) is another experiment, never
  // resumed into or merged with this one.
  experiment.config_hash = toHex(hashString("run hashes 3\n" + experiment.canonical));
  // Every row names a planner id of every variant.
  for (const auto& entry : experiment.reproduces_rows) {
    const std::string& id = entry.first;  // (a structured binding: not capturable by clang 14)
    for (const ExperimentVariant& variant : experiment.variants) {
      const bool found = std::any_of(variant.planners.begin(), variant.planners.end(),
                                     [&](const ExperimentPlanner& p) { return p.id == id; });
      if (!found) (*reproduces)["rows"][id].fail("no planner has the id '" + id + "'");
    }
  }
  // The declared setting names variants of this experiment.
  std::vector<std::string> labels;
  for (const ExperimentVariant& variant : experiment.variants) labels.push_back(variant.label);
  if (experiment.reproduces_setting == std::vector<std::string>{"*"}) {
    experiment.reproduces_setting = labels;
  }
  for (const std::string& label : experiment.reproduces_setting) {
    if (std::find(labels.begin(), labels.end(), label) == labels.end()) {
      (*reproduces)["setting"].fail("'" + label + "' is not a variant of this experiment" +
                                    didYouMean(label, labels) +
                                    "; its variants: " + join(labels, ", "));
    }
  }
  return experiment;
}

std::map<std::string, std::vector<std::string>> reproducibleRows() {
  // The one definition of the papers, which the analysis package reads for their figures.
  const std::string path = analysisDirectory() + "/kinolab_analysis/papers.yaml";
  std::map<std::string, std::vector<std::string>> papers;
  for (const auto& [key, paper] : YamlReader::loadFile(path).entries()) {
    std::vector<std::string>& rows = papers[key];
    for (const auto& [row, figures] : paper["rows"].entries()) rows.push_back(row);
  }
  return papers;
}

std::vector<RunSpec> Experiment::runs() const {
  std::vector<RunSpec> runs;
  for (std::size_t v = 0; v < variants.size(); ++v) {
    const ExperimentVariant& variant = variants[v];
    const std::string budget = variant.budgetText(flights);
    for (std::size_t w = 0; w < variant.worlds.size(); ++w) {
      const ExperimentWorld& world = variant.worlds[w];
      const std::string world_text = world.id + ":" + toHex(world.spec.hash());
      for (int q = 0; q < variant.queries.count(); ++q) {
        for (int r = 0; r < variant.repetitions; ++r) {
          const std::string the_case =
              "world=" + world.id + ";query=" + std::to_string(q) + ";rep=" + std::to_string(r);
          const std::uint64_t case_seed = hashString(the_case, seed);
          for (std::size_t p = 0; p < variant.planners.size(); ++p) {
            RunSpec run;
            run.variant = v;
            run.world = w;
            run.query = q;
            run.planner = p;
            run.repetition = r;
            run.seed = case_seed;
            run.hash = toHex(hashString(world_text + "|" + variant.queries.queryText(q) + "|" +
                                            the_case + "|" + variant.planners[p].id + "=" +
                                            variant.planners[p].canonicalText() + "|" + budget,
                                        seed));
            runs.push_back(std::move(run));
          }
        }
      }
    }
  }
  // A run that does not change between variants (a reference planner the sweep does not
  // touch) has the same hash in each: it runs once, in the first variant that has it.
  std::set<std::string> seen;
  std::vector<RunSpec> unique;
  for (RunSpec& run : runs) {
    if (seen.insert(run.hash).second) unique.push_back(std::move(run));
  }
  return unique;
}

}  // namespace kinolab
