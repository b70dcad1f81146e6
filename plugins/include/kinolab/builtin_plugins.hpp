#pragma once

namespace kinolab {

/// Registers every plugin under plugins/ (once; later calls do nothing).
void registerBuiltinPlugins();

}  // namespace kinolab
