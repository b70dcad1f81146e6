#include "kinolab/core/parameters.hpp"

#include <gtest/gtest.h>

#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/flight/flight.hpp"
#include "kinolab/plugins/depth_camera.hpp"
#include "kinolab/plugins/lidar.hpp"

namespace kinolab {
namespace {

ParameterSpecs exampleSpecs() {
  return ParameterSpecs()
      .integer("samples_per_axis", 5, 1, 64, "values per axis")
      .real("sigma", 0.5, 0.05, 10.0, "standard deviation")
      .choice("variant", "quantile", {"quantile", "random"}, "which variant")
      .boolean("verbose", false, "talk more")
      .text("label", "none", "free text");
}

std::string errorOf(const ParameterSpecs& specs, const std::vector<ParameterAssignment>& set) {
  try {
    specs.resolve(set, "sampler 'normal'");
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "no error";
}

TEST(Parameters, DefaultsWhenNothingIsSet) {
  const ParameterSet values = exampleSpecs().resolve({}, "test");
  EXPECT_EQ(values.integer("samples_per_axis"), 5);
  EXPECT_DOUBLE_EQ(values.real("sigma"), 0.5);
  EXPECT_EQ(values.text("variant"), "quantile");
  EXPECT_FALSE(values.boolean("verbose"));
  EXPECT_EQ(values.canonical(),
            "samples_per_axis=5;sigma=0.5;variant=quantile;verbose=false;label=none");
}

TEST(Parameters, AssignmentsOverrideInOrder) {
  const ParameterSet values = exampleSpecs().resolve(
      parseAssignments({"sigma=0.25", "variant=random", "verbose=yes", "sigma=2", "label=a=b"},
                       "--set"),
      "test");
  EXPECT_DOUBLE_EQ(values.real("sigma"), 2.0);
  EXPECT_EQ(values.text("variant"), "random");
  EXPECT_TRUE(values.boolean("verbose"));
  EXPECT_EQ(values.text("label"), "a=b");
  // A real parameter takes an integer literal; the value is the same double.
  EXPECT_DOUBLE_EQ(exampleSpecs().resolve({{"sigma", "3", "x"}}, "t").real("sigma"), 3.0);
}

TEST(Parameters, UnknownNameSuggestsTheClosest) {
  const std::string message = errorOf(exampleSpecs(), {{"sigm", "0.3", "--set"}});
  EXPECT_NE(message.find("--set: sampler 'normal': unknown parameter 'sigm'"), std::string::npos)
      << message;
  EXPECT_NE(message.find("did you mean 'sigma'"), std::string::npos) << message;
  EXPECT_NE(message.find("samples_per_axis, sigma, variant"), std::string::npos) << message;
}

TEST(Parameters, WrongTypeAndOutOfRangeNameTheExpectedValues) {
  const auto specs = exampleSpecs();
  EXPECT_NE(errorOf(specs, {{"samples_per_axis", "2.5", "f:3:4"}})
                .find("f:3:4: sampler 'normal': parameter 'samples_per_axis': expected an "
                      "integer in [1, 64], got '2.5'"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"samples_per_axis", "65", "x"}}).find("[1, 64], got '65'"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"sigma", "0.01", "x"}}).find("a number in [0.05, 10], got '0.01'"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"sigma", "nan", "x"}}).find("a number in"), std::string::npos);
  EXPECT_NE(errorOf(specs, {{"sigma", "", "x"}}).find("a number in"), std::string::npos);
  EXPECT_NE(errorOf(specs, {{"verbose", "maybe", "x"}}).find("expected true or false"),
            std::string::npos);
  const std::string choice = errorOf(specs, {{"variant", "quantil", "x"}});
  EXPECT_NE(choice.find("expected one of quantile|random (did you mean 'quantile'?)"),
            std::string::npos)
      << choice;
}

TEST(Parameters, MalformedSetItemsAreRejected) {
  EXPECT_THROW(parseAssignments({"sigma"}, "--set"), ConfigError);
  EXPECT_THROW(parseAssignments({"=3"}, "--set"), ConfigError);
}

TEST(Parameters, DeclarationsAreChecked) {
  EXPECT_THROW(ParameterSpecs().real("a", 1, 0, 1, "").real("a", 1, 0, 1, ""), InvalidArgument);
  EXPECT_THROW(ParameterSpecs().real("a", 2, 0, 1, "default out of range"), ConfigError);
  EXPECT_THROW(ParameterSpecs().choice("c", "x", {"a", "b"}, "default not a choice"), ConfigError);
  EXPECT_THROW(exampleSpecs().resolve({}, "t").real("undeclared"), InvalidArgument);
}

TEST(Parameters, GroupsListsAndPluginsStayNested) {
  const ParameterSpecs specs =
      ParameterSpecs()
          .interval("radius", {0.1, 0.2}, 0.0, 1.0, "an interval")
          .reals("corner", {0, 0, 0}, -10.0, 10.0, 3, "a point")
          .group("canopy", ParameterSpecs().real("p", 0.5, 0.0, 1.0, "share"), "a group")
          .groupList("boxes",
                     ParameterSpecs().reals("min", {0, 0, 0}, -9, 9, 3, "corner").required(),
                     "a list")
          .plugin("heuristic", "heuristic", "time_optimal", "a plugin");
  const ParameterSet defaults = specs.resolve({}, "t");
  EXPECT_EQ(defaults.reals("radius"), (std::vector<double>{0.1, 0.2}));
  EXPECT_FALSE(defaults.boolean("canopy"));
  EXPECT_EQ(defaults.nested("canopy").real("p"), 0.5);
  EXPECT_TRUE(defaults.items("boxes").empty());
  EXPECT_EQ(defaults.text("heuristic"), "time_optimal");

  const ParameterSet set = specs.resolve({{"radius", "0.3", "t"},
                                          {"canopy.p", "0.25", "t"},
                                          {"boxes.0.min", "4 5 6", "t"},
                                          {"boxes.1.min", "[1, 2, 3]", "t"},
                                          {"heuristic", "obvp", "t"}},
                                         "t");
  EXPECT_EQ(set.reals("radius"), (std::vector<double>{0.3, 0.3}));  // one number: [x, x]
  EXPECT_TRUE(set.boolean("canopy"));                               // set by its member
  EXPECT_EQ(set.nested("canopy").real("p"), 0.25);
  ASSERT_EQ(set.items("boxes").size(), 2u);
  EXPECT_EQ(set.items("boxes")[0]->reals("min"), (std::vector<double>{4, 5, 6}));
  EXPECT_EQ(set.items("boxes")[1]->reals("min"), (std::vector<double>{1, 2, 3}));
  EXPECT_NE(set.canonical(), defaults.canonical());
  EXPECT_NE(set.canonical().find("canopy=true{p=0.25}"), std::string::npos) << set.canonical();

  EXPECT_NE(errorOf(specs, {{"radius", "0.5, 0.2", "w"}}).find("expected [low, high] within"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"corner", "1, 2", "w"}}).find("expected 3 numbers"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"canopy.q", "1", "w"}}).find("unknown parameter 'q'"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"boxes.x.min", "1,2,3", "w"}}).find("boxes.INDEX.PARAMETER"),
            std::string::npos);
  // An item without its required member, and an unknown plugin key with the known ones.
  EXPECT_NE(errorOf(specs, {{"boxes.0.min", "1,2,3", "w"}, {"boxes.1.max", "1", "w"}})
                .find("boxes[1]: unknown parameter 'max'"),
            std::string::npos);
  // Items come in order, by plain indices: no gap, no huge or padded index.
  for (const char* name :
       {"boxes.1.min", "boxes.99999.min", "boxes.10000000.min", "boxes.00.min", "boxes.+0.min"}) {
    EXPECT_NE(errorOf(specs, {{name, "1,2,3", "w"}}).find("items in order"), std::string::npos)
        << name;
  }
  // A YAML mapping only for a plugin parameter or a group; a nested list is not a point.
  EXPECT_NE(errorOf(specs, {{"radius", "3", "w", true}}).find("not a mapping"), std::string::npos);
  EXPECT_NE(errorOf(specs, {{"corner", "[1, [2, 3]]", "w"}}).find("expected 3 numbers"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"heuristic", "obpv", "w"}}).find("did you mean 'obvp'"),
            std::string::npos);
  EXPECT_NE(errorOf(specs, {{"radius.x", "1", "w"}}).find("no plugin parameter 'radius'"),
            std::string::npos);
}

TEST(Parameters, YamlMappingsKeepTheirLocations) {
  const YamlReader reader =
      YamlReader::loadString("params:\n  sigma: 0.3\n  variant: random\n", "exp.yaml");
  const auto assignments = assignmentsFromYaml(reader["params"]);
  ASSERT_EQ(assignments.size(), 2u);
  EXPECT_EQ(assignments[0].name, "sigma");
  EXPECT_EQ(assignments[0].value, "0.3");
  EXPECT_EQ(assignments[0].where, "exp.yaml:2:10: params.sigma");
  // Nested values: a list of numbers is one value, a plugin's or group's mapping nests with
  // '.', a list of mappings is indexed.
  const YamlReader nested = YamlReader::loadString(
      "params:\n  corner: [1, [2, 3]]\n  heuristic: {type: obvp, scale: 2}\n"
      "  boxes: [{min: [0, 0, 0]}, {max: [1, 1, 1]}]\n  canopy: {}\n",
      "exp.yaml");
  std::vector<std::pair<std::string, std::string>> flat;
  for (const auto& assignment : assignmentsFromYaml(nested["params"])) {
    flat.emplace_back(assignment.name, assignment.value);
  }
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"corner", "[1,[2,3]]"},    {"heuristic", "obvp"},      {"heuristic.scale", "2"},
      {"boxes.0.min", "[0,0,0]"}, {"boxes.1.max", "[1,1,1]"}, {"canopy", "true"}};
  EXPECT_EQ(flat, expected);
  const YamlReader bad = YamlReader::loadString("params:\n  boxes: [{min: 1}, 2]\n", "exp.yaml");
  EXPECT_THROW(assignmentsFromYaml(bad["params"]), ConfigError);
}

}  // namespace
}  // namespace kinolab

namespace kinolab {
namespace {

/// A settings struct's field list: its declaration carries the struct's defaults, reading
/// resolved defaults gives the defaults back, and any settings written back as assignments
/// resolve and read to themselves (units and choices included).
template <typename Settings>
void checkFieldsRoundTrip(Settings changed) {
  const ParameterSpecs specs = declareFields<Settings>();
  const auto text = [](const Settings& s) {
    std::string all;
    for (const ParameterAssignment& a : writeFields(s, "test")) all += a.name + "=" + a.value + " ";
    return all;
  };
  EXPECT_EQ(text(readFields<Settings>(specs.resolve({}, "test"))), text(Settings()));
  const Settings back = readFields<Settings>(specs.resolve(writeFields(changed, "test"), "test"));
  EXPECT_EQ(text(back), text(changed));
  EXPECT_NE(text(changed), text(Settings())) << "the change must change something";
}

TEST(Fields, EveryFieldListDeclaresReadsAndWritesBackTheSameValues) {
  DepthCamera camera;
  camera.fov_horizontal = 1.2;
  camera.width = 640;
  checkFieldsRoundTrip(camera);
  Lidar lidar;
  lidar.fov_vertical = 0.5;
  lidar.channels = 32;
  checkFieldsRoundTrip(lidar);
  MapModel map;
  map.unknown = UnknownSpace::kFreeBeyond;
  map.resolution = 0.05;
  checkFieldsRoundTrip(map);
  FlightSettings flight;
  flight.latency = 0.25;
  flight.timing = FlightTiming::kDeterministic;
  checkFieldsRoundTrip(flight);
  // Declared in degrees, kept in radians: the default camera's 87 degrees, not 86.999...
  const ParameterSpecs specs = declareFields<DepthCamera>();
  EXPECT_EQ(std::get<double>(specs.find("fov_horizontal")->default_value), 87.0);
  EXPECT_DOUBLE_EQ(readFields<DepthCamera>(specs.resolve({}, "t")).fov_horizontal,
                   87.0 * M_PI / 180.0);
}

}  // namespace
}  // namespace kinolab
