// Test-only plugin libraries that are refused when loaded, one per KINOLAB_HOSTILE value
// (tests/CMakeLists.txt builds each): 1 a library built for another plugin ABI (its record
// says ABI - 1; its entry point would crash if called), 2 an entry point that throws a
// std::exception after registering a planner, 3 one that throws an int, 4 an ABI record of
// one byte (reading kinolab's 16 would run past it), 5 an entry point that is data.
#include <stdexcept>
#include <string>

#include "kinolab/core/plugin.hpp"
#include "kinolab/planner/planner.hpp"

#if KINOLAB_HOSTILE == 1
extern "C" __attribute__((visibility("default")))
const KinolabPluginAbiRecord kinolab_plugin_abi_record = {
    0x6b6e6c62u, KINOLAB_PLUGIN_ABI_VERSION - 1, _GLIBCXX_USE_CXX11_ABI, sizeof(std::string)};
extern "C" __attribute__((visibility("default"))) void kinolab_register_plugins(
    kinolab::PluginRegistrar& registrar) {
  // A library of another ABI: never called (it would register through another layout).
  __builtin_trap();
  (void)registrar;
}
#elif KINOLAB_HOSTILE == 4
extern "C" __attribute__((visibility("default"))) const char kinolab_plugin_abi_record = 'k';
extern "C" __attribute__((visibility("default"))) void kinolab_register_plugins(
    kinolab::PluginRegistrar& registrar) {
  __builtin_trap();  // never called: the record is not kinolab's
  (void)registrar;
}
#elif KINOLAB_HOSTILE == 5
extern "C" __attribute__((visibility("default")))
const KinolabPluginAbiRecord kinolab_plugin_abi_record = KINOLAB_PLUGIN_ABI_RECORD;
// Data where the entry point should be: calling it would jump into these bytes.
extern "C" __attribute__((visibility("default")))
const unsigned char kinolab_register_plugins[] = {0x0f, 0x0b};
#else
KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<kinolab::Planner>(
      "test_half_registered", "registered before the throw", kinolab::ParameterSpecs(),
      [](const kinolab::ParameterSet&) -> std::unique_ptr<kinolab::Planner> { return nullptr; });
#if KINOLAB_HOSTILE == 2
  throw std::runtime_error("hostile entry point always throws");
#else
  throw 3;
#endif
}
#endif
