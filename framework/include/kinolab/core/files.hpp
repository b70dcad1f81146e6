#pragma once

#include <string>

namespace kinolab {

/// Writes `text` to a temporary file beside `path` and renames it over `path`, so a reader
/// never sees half a file. Throws FileError naming the path when it cannot.
void writeFileAtomically(const std::string& path, const std::string& text);

}  // namespace kinolab
