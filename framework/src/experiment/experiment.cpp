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
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/experiment/query_sampler.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab {
namespace {

namespace fs = std::filesystem;
using namespace experiment_document;

// ---- reading one variant -----------------------------------------------------------------

std::array<double, 2> height(const YamlReader& node) {
  return node.getInterval("height", std::array<double, 2>{1.0, 2.0}, -1e4, 1e4);
}

QuerySpec readQueries(const YamlReader& node) {
  QuerySpec spec;
  if (const auto fixed = node.optional("fixed")) {
    for (const YamlReader& item : fixed->items()) {
      const auto start = item.getVector3("start");
      const auto goal = item.getVector3("goal");
      spec.fixed.emplace_back(Eigen::Vector3d(start[0], start[1], start[2]),
                              Eigen::Vector3d(goal[0], goal[1], goal[2]));
      item.finish();
    }
  }
  if (const auto random = node.optional("random")) {
    QuerySpec::Random& r = spec.random;
    r.count = static_cast<int>(random->getInteger("count", std::nullopt, 1, 1000000));
    r.min_distance = random->getNumber("min_distance", 5.0, 0.0, 1e6);
    r.max_distance = random->getNumber("max_distance", 1e6, 0.0, 1e6);
    if (r.max_distance < r.min_distance) {
      (*random)["max_distance"].fail("max_distance is below min_distance");
    }
    r.clearance = random->getNumber("clearance", 0.6, 0.0, 100.0);
    const auto h = height(*random);
    r.height[0] = h[0];
    r.height[1] = h[1];
    if (const auto lattice = random->optional("lattice")) {
      r.lattice_step = lattice->getNumber("step", std::nullopt, 1e-3, 1e4);
      r.lattice_offset = lattice->getNumber("offset", 0.0, -1e4, 1e4);
      lattice->finish();
    }
    random->finish();
  }
  if (const auto across = node.optional("across")) {
    QuerySpec::Across& a = spec.across;
    a.count = static_cast<int>(across->getInteger("count", std::nullopt, 1, 1000000));
    const std::string axis = across->get<std::string>("axis", "x");
    if (axis != "x" && axis != "y") (*across)["axis"].fail("expected x or y, got '" + axis + "'");
    a.axis = axis == "x" ? 0 : 1;
    a.margin = across->getNumber("margin", 1.0, 0.0, 1e4);
    a.clearance = across->getNumber("clearance", 0.6, 0.0, 100.0);
    const auto h = height(*across);
    a.height[0] = h[0];
    a.height[1] = h[1];
    across->finish();
  }
  node.finish();
  if (spec.count() == 0) node.fail("no queries: give fixed, random or across");
  return spec;
}

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

ExperimentVariant readVariant(const YamlReader& root, const std::string& directory,
                              const std::map<std::string, std::string>& spec_directories) {
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
  variant.queries = readQueries(root["queries"]);
  for (const YamlReader& item : root["planners"].items()) {
    ExperimentPlanner planner = readPlanner(item);
    if (!ids.insert("planner " + planner.id).second) item["id"].fail("duplicate planner id");
    variant.planners.push_back(std::move(planner));
  }
  if (variant.planners.empty()) root["planners"].fail("no planners");
  variant.repetitions = static_cast<int>(root.getInteger("repetitions", 1, 1, 100000));
  if (const auto budget = root.optional("budget")) {
    variant.budget.time = budget->getNumber("time", 10.0, 0.001, 1e6);
    variant.budget.memory_mb = budget->getInteger("memory_mb", 4096, 16, 1 << 24);
    variant.budget.iterations = budget->getInteger("iterations", 0, 0, 1LL << 50);
    budget->finish();
  }
  if (const auto flight = root.optional("flight")) {
    variant.flight = flightParameters().resolve(assignmentsFromYaml(*flight), "flight");
  } else {
    variant.flight = flightParameters().resolve({}, "flight");
  }
  if (const auto timing = root.optional("timing")) {
    variant.timing.warmup = static_cast<int>(timing->getInteger("warmup", 1, 0, 100));
    variant.timing.repeats = static_cast<int>(timing->getInteger("repeats", 3, 1, 100));
    timing->finish();
  }
  return variant;
}

}  // namespace

// ---- queries -------------------------------------------------------------------------------

std::vector<PlanningQuery> QuerySpec::make(const World& world, const std::string& world_id,
                                           std::uint64_t seed) const {
  std::vector<PlanningQuery> queries;
  for (const auto& [start, goal] : fixed) {
    PlanningQuery query;
    query.start.col(0) = start;
    query.goal = goal;
    queries.push_back(query);
  }
  const Box& box = world.bounds();
  Rng rng = Rng::derive(seed, "queries/" + world_id);
  // Heights are above the map's floor, within the map.
  const auto region = [&](const double(&h)[2]) {
    Box inside = box;
    inside.min.z() = std::max(box.min.z(), box.min.z() + h[0]);
    inside.max.z() = std::min(box.max.z(), box.min.z() + h[1]);
    return inside;
  };
  if (random.count > 0) {
    const FreeQueryRegion spec{region(random.height), random.clearance,    random.min_distance,
                               random.max_distance,   random.lattice_step, random.lattice_offset};
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

std::string randomRule(const QuerySpec::Random& random) {
  return formatNumber(random.min_distance) + " " + formatNumber(random.max_distance) + " " +
         formatNumber(random.clearance) + " " + formatNumber(random.height[0]) + " " +
         formatNumber(random.height[1]) +
         (random.lattice_step > 0.0 ? " lattice " + formatNumber(random.lattice_step) + " " +
                                          formatNumber(random.lattice_offset)
                                    : std::string());
}

std::string acrossRule(const QuerySpec::Across& across) {
  return std::to_string(across.axis) + " " + formatNumber(across.margin) + " " +
         formatNumber(across.clearance) + " " + formatNumber(across.height[0]) + " " +
         formatNumber(across.height[1]);
}

}  // namespace

std::string QuerySpec::queryText(int index) const {
  const int fixed_count = static_cast<int>(fixed.size());
  if (index < fixed_count) {
    const auto& [start, goal] = fixed[static_cast<std::size_t>(index)];
    return "fixed " + formatPoint(start) + " " + formatPoint(goal);
  }
  index -= fixed_count;
  // Random queries are drawn one after the other from one stream: the i-th depends on the
  // rule and on i, not on how many are drawn after it.
  if (index < random.count) return "random #" + std::to_string(index) + " " + randomRule(random);
  index -= random.count;
  return "across #" + std::to_string(index) + " " + acrossRule(across) + " after random " +
         std::to_string(random.count) + " " + randomRule(random);
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
        generator["file"] = fs::absolute(file).string();
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

/// `plugins:` (each loaded now, so that the rest of the file can name their keys) and
/// `store:`.
void readHeader(const YamlReader& root, const std::string& directory, Experiment& experiment) {
  const std::string kind = root.get<std::string>("kind", "planning");
  if (kind != "planning" && kind != "flight") {
    root["kind"].fail("expected 'planning' or 'flight' (kinolab run), got '" + kind +
                      "'; sampling studies run with kinolab sampling-study");
  }
  experiment.flights = kind == "flight";
  if (!experiment.flights && root.optional("flight")) {
    root["flight"].fail("flight parameters belong to 'kind: flight' experiments");
  }
  if (experiment.flights && root.optional("timing")) {
    root["timing"].fail("a flight is flown once: the timing protocol is for 'kind: planning'");
  }
  experiment.name = readName(root["name"]);
  experiment.seed = static_cast<std::uint64_t>(root.getInteger("seed", 1, 0, 1LL << 62));
  if (const auto plugins = root.optional("plugins")) {
    for (const YamlReader& item : plugins->items()) {
      std::string file = item.as<std::string>();
      if (fs::path(file).is_relative()) file = (fs::path(directory) / file).string();
      if (!isRegularFile(file)) item.fail("no such plugin library: " + file);
      loadPluginLibrary(file);
      experiment.plugins.push_back(file);
    }
  }
  if (const auto store = root.optional("store")) {
    experiment.store_trajectories = store->get<bool>("trajectories", false);
    // trees: true (every run), false, or N (the first N queries of each world: trees are big).
    if (const auto trees = store->optional("trees")) {
      const std::string text = trees->as<std::string>();
      if (text == "true" || text == "false") {
        experiment.store_tree_queries = text == "true" ? -1 : 0;
      } else {
        experiment.store_tree_queries = static_cast<int>(store->getInteger("trees", 0, 0, 1000000));
      }
    }
    store->finish();
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
    ExperimentVariant variant = readVariant(reader, directory, spec_directories);
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
    const std::string budget =
        formatNumber(variant.budget.time) + "/" + std::to_string(variant.budget.memory_mb) + "/" +
        std::to_string(variant.budget.iterations) + "/timing " +
        std::to_string(variant.timing.warmup) + "+" + std::to_string(variant.timing.repeats) +
        (flights ? "/flight " + variant.flight.canonical() : std::string());
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
