#include <gtest/gtest.h>

#include "kinolab/core/plugin.hpp"
#include "support/errors.hpp"

namespace kinolab {

/// A plugin interface that exists only in this test, with its own registry.
struct Widget {
  virtual ~Widget() = default;
  virtual double size() const = 0;
};

template <>
PluginRegistry<Widget>& pluginRegistry<Widget>() {
  static PluginRegistry<Widget> registry("widget");
  return registry;
}

namespace {

struct SizedWidget final : Widget {
  explicit SizedWidget(double s) : s_(s) {}
  double size() const override { return s_; }
  double s_;
};

void addSized(PluginRegistrar& registrar, const std::string& key) {
  registrar.add<Widget>(key, "a widget of a given size",
                        ParameterSpecs().real("size", 1.0, 0.0, 10.0, "its size"),
                        [](const ParameterSet& parameters) {
                          return std::make_unique<SizedWidget>(parameters.real("size"));
                        });
}

TEST(PluginRegistry, RegistersCreatesAndLists) {
  PluginRegistrar registrar("test origin");
  addSized(registrar, "square");
  addSized(registrar, "circle");
  registrar.commit();
  auto& registry = pluginRegistry<Widget>();
  EXPECT_EQ(registry.keys(), (std::vector<std::string>{"circle", "square"}));
  EXPECT_EQ(registry.info("square").origin, "test origin");
  EXPECT_DOUBLE_EQ(registry.create("square", {})->size(), 1.0);
  EXPECT_DOUBLE_EQ(registry.create("square", {{"size", "2.5", "--set"}})->size(), 2.5);
  const std::string unknown = test::errorOf<PluginError>([&] { registry.create("sqare", {}); });
  EXPECT_NE(unknown.find("unknown widget 'sqare' (did you mean 'square'?); known widgets: "
                         "circle, square"),
            std::string::npos)
      << unknown;
  EXPECT_THROW(registry.create("square", {{"colour", "red", "--set"}}), ConfigError);
  EXPECT_THROW(registry.create("square", {{"size", "11", "--set"}}), ConfigError);
}

TEST(PluginRegistry, ADuplicateKeyAddsNothingFromThatOrigin) {
  PluginRegistrar first("first.so");
  addSized(first, "triangle");
  first.commit();
  PluginRegistrar second("second.so");
  addSized(second, "hexagon");
  addSized(second, "triangle");
  const std::string message = test::errorOf<PluginError>([&] { second.commit(); });
  EXPECT_NE(message.find("widget 'triangle' from second.so is already registered"),
            std::string::npos)
      << message;
  EXPECT_FALSE(pluginRegistry<Widget>().contains("hexagon"));

  PluginRegistrar twice("twice.so");
  addSized(twice, "pentagon");
  addSized(twice, "pentagon");
  EXPECT_NE(
      test::errorOf<PluginError>([&] { twice.commit(); }).find("registers widget 'pentagon' twice"),
      std::string::npos);
  EXPECT_FALSE(pluginRegistry<Widget>().contains("pentagon"));
}

TEST(PluginLibrary, BadLibrariesAreClearErrors) {
  EXPECT_NE(test::errorOf<PluginError>([] {
              loadPluginLibrary("/no/such/plugin.so");
            }).find("plugin library '/no/such/plugin.so': no such file"),
            std::string::npos);
  const std::string not_a_library = KINOLAB_SOURCE_DIR "/tests/CMakeLists.txt";
  EXPECT_NE(test::errorOf<PluginError>([&] {
              loadPluginLibrary(not_a_library);
            }).find("cannot be loaded"),
            std::string::npos);
}

}  // namespace
}  // namespace kinolab
