#include "kinolab/core/files.hpp"

#include <filesystem>
#include <fstream>
#include <system_error>

#include "kinolab/core/error.hpp"

namespace kinolab {

void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary);
    out << text;
    if (!out.flush()) throw FileError(path + ": cannot write");
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) throw FileError(path + ": cannot write (" + error.message() + ")");
}

}  // namespace kinolab
