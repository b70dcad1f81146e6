#include "kinolab/core/metric_specs.hpp"

#include "kinolab/core/error.hpp"

namespace kinolab {

std::string MetricSpec::typeName() const {
  switch (type) {
    case MetricType::kReal:
      return "real";
    case MetricType::kInteger:
      return "integer";
    case MetricType::kBoolean:
      return "boolean";
    case MetricType::kText:
      return "text";
  }
  return "?";
}

std::string MetricSpec::directionName() const {
  switch (direction) {
    case MetricDirection::kLower:
      return "lower";
    case MetricDirection::kHigher:
      return "higher";
    case MetricDirection::kNone:
      break;
  }
  return "";
}

MetricSpec& MetricSpecs::last(const char* modifier) {
  if (specs_.empty()) throw InvalidArgument(std::string(modifier) + ": no metric declared yet");
  return specs_.back();
}

MetricSpecs& MetricSpecs::lower() {
  last("lower()").direction = MetricDirection::kLower;
  return *this;
}

MetricSpecs& MetricSpecs::higher() {
  last("higher()").direction = MetricDirection::kHigher;
  return *this;
}

MetricSpecs& MetricSpecs::comparable() {
  last("comparable()").comparable = true;
  return *this;
}

MetricSpecs& MetricSpecs::add(MetricSpec spec) {
  if (find(spec.name)) throw InvalidArgument("metric '" + spec.name + "' declared twice");
  specs_.push_back(std::move(spec));
  return *this;
}

MetricSpecs& MetricSpecs::real(std::string name, std::string unit, std::string doc) {
  return add({std::move(name), MetricType::kReal, std::move(unit), std::move(doc), false});
}

MetricSpecs& MetricSpecs::counter(std::string name, std::string doc) {
  return add({std::move(name), MetricType::kInteger, "count", std::move(doc), false});
}

MetricSpecs& MetricSpecs::clock(std::string name, std::string doc) {
  return add({std::move(name), MetricType::kReal, "ms", std::move(doc), true});
}

MetricSpecs& MetricSpecs::machine(std::string name, MetricType type, std::string unit,
                                  std::string doc) {
  return add({std::move(name), type, std::move(unit), std::move(doc), true});
}

MetricSpecs& MetricSpecs::boolean(std::string name, std::string doc) {
  return add({std::move(name), MetricType::kBoolean, "", std::move(doc), false});
}

MetricSpecs& MetricSpecs::text(std::string name, std::string doc) {
  return add({std::move(name), MetricType::kText, "", std::move(doc), false});
}

MetricSpecs& MetricSpecs::series(std::string name, std::string unit, std::string doc) {
  MetricSpec spec{std::move(name), MetricType::kReal, std::move(unit), std::move(doc), false};
  spec.series = true;
  return add(std::move(spec));
}

MetricSpecs& MetricSpecs::include(const MetricSpecs& other) {
  for (const MetricSpec& spec : other.specs_) add(spec);
  return *this;
}

std::vector<std::string> MetricSpecs::names() const {
  std::vector<std::string> result;
  for (const MetricSpec& spec : specs_) result.push_back(spec.name);
  return result;
}

const MetricSpec* MetricSpecs::find(std::string_view name) const {
  for (const MetricSpec& spec : specs_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

}  // namespace kinolab
