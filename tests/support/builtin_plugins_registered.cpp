// Every test of kinolab_tests sees the built-in plugins, and those of the libraries in
// $KINOLAB_TEST_PLUGINS, registered before it runs, whichever test runs alone (ctest runs
// each in its own process).
#include "support/test_plugins.hpp"

namespace {

const bool kRegistered = (kinolab::test::loadTestPlugins(), true);

}  // namespace
