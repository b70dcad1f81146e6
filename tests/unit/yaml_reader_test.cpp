#include "kinolab/core/yaml_reader.hpp"

#include <gtest/gtest.h>

namespace kinolab {
namespace {

/// The message of the ConfigError that `action` throws.
template <typename Action>
std::string errorOf(Action&& action) {
  try {
    action();
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "(no error)";
}

TEST(YamlReaderTest, ReadsTypedValuesWithFallbacks) {
  const YamlReader root = YamlReader::loadString(
      "a: 1.5\nb: 3\nc: true\nd: text\nv: [1, 2, 3]\nr: [0.1, 0.2]\ns: 4\n", "test.yaml");
  EXPECT_DOUBLE_EQ(root.getNumber("a", std::nullopt, 0.0, 2.0), 1.5);
  EXPECT_EQ(root.getInteger("b", std::nullopt, 0, 10), 3);
  EXPECT_TRUE(root.get<bool>("c"));
  EXPECT_EQ(root.get<std::string>("d"), "text");
  EXPECT_EQ(root.getVector3("v")[2], 3.0);
  EXPECT_EQ(root.getInterval("r", std::nullopt, 0.0, 1.0)[1], 0.2);
  EXPECT_EQ(root.getInterval("s", std::nullopt, 0.0, 10.0)[0], 4.0);
  EXPECT_EQ(root.getNumber("missing", 7.0, 0.0, 10.0), 7.0);
  EXPECT_NO_THROW(root.finish());
}

TEST(YamlReaderTest, ErrorsNameFileLineAndKeyPath) {
  const YamlReader root =
      YamlReader::loadString("outer:\n  inner:\n    radius: -1\n    radios: 2\n", "w.yaml");
  const YamlReader inner = root["outer"]["inner"];
  EXPECT_EQ(errorOf([&] { inner.getNumber("radius", std::nullopt, 0.0, 5.0); }),
            "w.yaml:3:13: outer.inner.radius: expected a number in [0, 5], got -1");
  const std::string unknown = errorOf([&] { inner.finish(); });
  EXPECT_NE(unknown.find("w.yaml:4:5: outer.inner.radios: unknown key 'radios'"), std::string::npos)
      << unknown;
  EXPECT_NE(unknown.find("did you mean 'radius'"), std::string::npos) << unknown;
  EXPECT_NE(errorOf([&] { root["nothing"]; }).find("missing required key 'nothing'"),
            std::string::npos);
}

TEST(YamlReaderTest, RejectsWrongTypes) {
  const YamlReader root = YamlReader::loadString("n: abc\ni: 2.5\nv: [1, 2]\nb: maybe\n", "t");
  EXPECT_NE(errorOf([&] { root.get<double>("n"); }).find("expected a finite number, got \"abc\""),
            std::string::npos);
  EXPECT_NE(errorOf([&] { root.get<long long>("i"); }).find("expected an integer"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { root.getVector3("v"); }).find("expected a list of 3 numbers"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { root.get<bool>("b"); }).find("expected true or false"),
            std::string::npos);
}

TEST(YamlReaderTest, MalformedYamlAndMissingFiles) {
  EXPECT_NE(errorOf([] {
              YamlReader::loadString("a: [1, 2\n", "bad.yaml");
            }).find("bad.yaml:2:1: malformed YAML"),
            std::string::npos);
  EXPECT_THROW(YamlReader::loadFile("/nonexistent/kinolab.yaml"), FileError);
}

TEST(YamlReaderTest, DuplicateKeysAreRefusedAtTheSecondOneAtEveryDepth) {
  EXPECT_EQ(errorOf([] { YamlReader::loadString("name: a\nseed: 1\nname: b\n", "d.yaml"); }),
            "d.yaml:3:1: duplicate key 'name' (first at line 1)");
  EXPECT_NE(errorOf([] {
              YamlReader::loadString("planners:\n  - {id: a, params: {x: 1, x: 2}}\n", "d.yaml");
            }).find("d.yaml:2:28: duplicate key 'x'"),
            std::string::npos);
  // The same key in different mappings is fine.
  EXPECT_NO_THROW(YamlReader::loadString("a: {x: 1}\nb: {x: 2}\n", "ok.yaml"));
}

TEST(YamlReaderTest, AliasesMayRepeatABlockButNotExpandWithoutBound) {
  // Shared blocks read as written out.
  const YamlReader shared = YamlReader::loadString(
      "base: &base {a: 1, b: [1, 2]}\none: *base\ntwo: *base\n", "shared.yaml");
  EXPECT_EQ(shared["two"]["b"].items().size(), 2u);
  // Nested aliases ("billion laughs", here 10^9 nodes) are refused at once, where the
  // expansion passes the bound, not walked.
  std::string laughs = "a: &a [x, x, x, x, x, x, x, x, x, x]\n";
  for (char level = 'b'; level <= 'i'; ++level) {
    const char below = static_cast<char>(level - 1);
    laughs += std::string(1, level) + ": &" + level + " [";
    for (int k = 0; k < 10; ++k) laughs += std::string(k ? ", *" : "*") + below;
    laughs += "]\n";
  }
  const std::string message = errorOf([&] { YamlReader::loadString(laughs, "laughs.yaml"); });
  EXPECT_NE(message.find("laughs.yaml:1:"), std::string::npos) << message;
  EXPECT_NE(message.find("expands to more than 1000000 YAML nodes"), std::string::npos) << message;
}

TEST(YamlReaderTest, ALargeFileWithoutAliasesIsReadAndDeepNestingIsNamed) {
  // 100,000 boxes written out (1.1 million nodes, no alias): the bound is on repetition.
  std::string boxes = "boxes:\n";
  for (int k = 0; k < 100000; ++k) boxes += "  - {min: [0, 0, 0], max: [1, 1, 1]}\n";
  EXPECT_EQ(YamlReader::loadString(boxes, "boxes.yaml")["boxes"].items().size(), 100000u);
  // Nesting deeper than the reader follows says so, where it happens.
  const std::string deep = "a: " + std::string(5000, '[') + "1" + std::string(5000, ']') + "\n";
  const std::string message = errorOf([&] { YamlReader::loadString(deep, "deep.yaml"); });
  EXPECT_NE(message.find("deep.yaml:1:"), std::string::npos) << message;
  EXPECT_NE(message.find("lists or mappings deep"), std::string::npos) << message;
}

TEST(YamlReaderTest, OnlyUtf8TextWithoutControlCharactersIsRead) {
  EXPECT_NE(errorOf([] {
              YamlReader::loadString(std::string("name: a\0b\n", 10), "n.yaml");
            }).find("n.yaml:1:8: byte 0x00 is not allowed"),
            std::string::npos);
  EXPECT_NE(errorOf([] {
              YamlReader::loadString("a: 1\nname: caf\xe9\n", "l.yaml");
            }).find("l.yaml:2:10: byte 0xe9"),
            std::string::npos);
  EXPECT_NE(errorOf([] { YamlReader::loadString("a: \x1b[31mred\n", "e.yaml"); }).find("byte 0x1b"),
            std::string::npos);
  const YamlReader utf8 = YamlReader::loadString("name: caf\xc3\xa9\t# tab\r\n", "u.yaml");
  EXPECT_EQ(utf8.get<std::string>("name"), "caf\xc3\xa9");
}

}  // namespace
}  // namespace kinolab
