// Field lists (core/fields.hpp) read from YAML, written as canonical text and declared: one
// declaration with nested groups, an optional group, a list, a choice and required keys.
#include "kinolab/core/yaml_fields.hpp"

#include <gtest/gtest.h>

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "support/errors.hpp"

namespace kinolab {
namespace {

enum class Shape { kRound, kSquare };

struct Hole {
  double depth = 0.0;
  template <typename Fields>
  void fields(Fields& f) {
    f.real("depth", depth, 0.0, 10.0, "m", {.required = true});
  }
};

struct Part {
  Eigen::Vector3d at = Eigen::Vector3d::Zero();
  template <typename Fields>
  void fields(Fields& f) {
    f.point("at", at, "where", {.required = true});
  }
};

struct Plate {
  struct Size {
    double width = 1.0;
    long long count = 2;
    template <typename Fields>
    void fields(Fields& f) {
      f.real("width", width, 0.1, 5.0, "m");
      f.integer("count", count, 1, 9, "how many");
    }
  };
  std::string name = "plate";
  Shape shape = Shape::kRound;
  bool painted = false;
  int tries = 0;
  std::array<double, 2> band = {1.0, 2.0};
  Size size;
  std::optional<Hole> hole;
  std::vector<Part> parts;
  template <typename Fields>
  void fields(Fields& f) {
    f.text("name", name, "not part of its identity", {.identity = false});
    f.choice("shape", shape, {{"round", Shape::kRound}, {"square", Shape::kSquare}}, "outline");
    f.boolean("painted", painted, "painted");
    f.countOrAll("tries", tries, 100, "tries");
    f.interval("band", band, 0.0, 10.0, "band, m");
    f.group("size", size, "its size");
    f.group("hole", hole, "a hole (optional)");
    f.list("parts", parts, "parts in order");
  }
};

Plate read(const std::string& text) {
  const YamlReader root = YamlReader::loadString(text, "plate.yaml");
  Plate plate;
  readYamlFields(root, plate);
  root.finish();
  return plate;
}

std::string errorOf(const std::string& text) {
  return test::errorOf<ConfigError>([&] { read(text); });
}

TEST(YamlFieldsTest, AbsentKeysKeepTheStructsDefaultsAndGivenOnesAreRead) {
  const Plate defaults = read("{}");
  EXPECT_EQ(defaults.name, "plate");
  EXPECT_EQ(defaults.size.width, 1.0);
  EXPECT_EQ(defaults.size.count, 2);
  EXPECT_FALSE(defaults.hole);
  EXPECT_TRUE(defaults.parts.empty());

  const Plate plate = read(
      "name: p\nshape: square\npainted: true\ntries: true\nband: 3\nsize: {count: 4}\n"
      "hole: {depth: 0.5}\nparts: [{at: [1, 2, 3]}, {at: [4, 5, 6]}]\n");
  EXPECT_EQ(plate.shape, Shape::kSquare);
  EXPECT_TRUE(plate.painted);
  EXPECT_EQ(plate.tries, -1);  // true: all
  EXPECT_EQ(plate.band, (std::array<double, 2>{3.0, 3.0}));
  EXPECT_EQ(plate.size.width, 1.0);
  EXPECT_EQ(plate.size.count, 4);
  ASSERT_TRUE(plate.hole);
  EXPECT_EQ(plate.hole->depth, 0.5);
  ASSERT_EQ(plate.parts.size(), 2u);
  EXPECT_EQ(plate.parts[1].at.z(), 6.0);
  EXPECT_EQ(read("tries: 7\n").tries, 7);
  EXPECT_EQ(read("tries: false\n").tries, 0);
}

TEST(YamlFieldsTest, ErrorsNameTheFileTheKeyPathAndWhatWasExpected) {
  EXPECT_EQ(errorOf("size: {width: 9}\n"),
            "plate.yaml:1:15: size.width: expected a number in [0.1, 5], got 9");
  EXPECT_EQ(errorOf("shape: sqaure\n"),
            "plate.yaml:1:8: shape: unknown shape 'sqaure' (did you mean 'square'?); expected "
            "round or square");
  EXPECT_EQ(errorOf("hole: {}\n"), "plate.yaml:1:7: hole: missing required key 'depth'");
  EXPECT_EQ(errorOf("parts: [{at: [1, 2]}]\n"),
            "plate.yaml:1:14: parts[0].at: expected a list of 3 numbers [x, y, z], got a list");
  EXPECT_EQ(errorOf("tries: 101\n"),
            "plate.yaml:1:8: tries: expected an integer in [0, 100], got 101");
  EXPECT_EQ(errorOf("size: 3\n"),
            "plate.yaml:1:7: size: expected a mapping of keys to values, got \"3\"");
  // Unknown keys, nested or not, are errors naming the closest known one.
  const std::string nested = errorOf("size: {widht: 2}\n");
  EXPECT_NE(nested.find("plate.yaml:1:8: size.widht: unknown key 'widht' (did you mean "
                        "'width'?); known keys: count width"),
            std::string::npos)
      << nested;
  const std::string top = errorOf("paintd: true\n");
  EXPECT_NE(top.find("paintd: unknown key 'paintd' (did you mean 'painted'?)"), std::string::npos)
      << top;
  EXPECT_NE(errorOf("parts: [{at: [1, 2, 3], on: 1}]\n").find("parts[0].on: unknown key 'on'"),
            std::string::npos);
}

TEST(YamlFieldsTest, CanonicalTextWritesTheIdentityFieldsInEitherStyle) {
  Plate plate = read(
      "name: p\nshape: square\nband: [0.5, 2]\nhole: {depth: 0.1}\n"
      "parts: [{at: [1, 2, 3]}]\n");
  EXPECT_EQ(canonicalFields(plate), "1 false 0 0.5 2 size 1 2 hole 0.1 parts (1, 2, 3)");
  EXPECT_EQ(canonicalFields(plate, {.names = true, .hex = true}),
            "shape=square painted=false tries=0 band=0x1p-1,0x1p+1 width=0x1p+0 count=2 "
            "depth=0x1.999999999999ap-4 at=0x1p+0,0x1p+1,0x1.8p+1");
  plate.hole.reset();  // an absent optional group writes nothing
  EXPECT_EQ(canonicalFields(plate.size, {.separator = "/"}), "1/2");
  EXPECT_EQ(canonicalFields(plate).find("hole"), std::string::npos);
}

TEST(YamlFieldsTest, TheDeclarationServesTheDocsWithDefaultsAndRequiredKeys) {
  const ParameterSpecs specs = declareFields<Plate>();
  ASSERT_NE(specs.find("shape"), nullptr);
  EXPECT_EQ(specs.find("shape")->rangeText(), "round|square");
  const ParameterSpec* size = specs.find("size");
  ASSERT_NE(size, nullptr);
  ASSERT_TRUE(size->members);
  EXPECT_EQ(std::get<double>(size->members->find("width")->default_value), 1.0);
  const ParameterSpec* hole = specs.find("hole");
  ASSERT_TRUE(hole && hole->members);
  EXPECT_TRUE(hole->members->find("depth")->required);
  EXPECT_EQ(specs.find("parts")->type, ParameterType::kGroupList);
}

}  // namespace
}  // namespace kinolab
