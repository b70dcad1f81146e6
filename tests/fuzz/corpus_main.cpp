// The fuzz targets as a regression test with any compiler: every file of
// tests/fuzz/corpus/<target>/ as it is, then `--mutations N` seeded mutations of each (bit
// flips, byte changes, insertions, deletions, truncations, duplicated spans), so a gcc build
// fuzzes too, reproducibly. Exit 0 when every input was loaded or refused with a kinolab
// error; a crash or another exception fails it, and the input that caused it is saved to
// `--crashes DIR` for the corpus.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"

namespace fs = std::filesystem;

namespace {

std::vector<std::uint8_t> mutate(std::vector<std::uint8_t> bytes, std::mt19937_64& rng) {
  const auto pick = [&](std::size_t n) { return n == 0 ? 0 : rng() % n; };
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int edit = 0; edit < edits; ++edit) {
    switch (rng() % 6) {
      case 0:  // flip a bit
        if (!bytes.empty())
          bytes[pick(bytes.size())] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      case 1:  // an interesting byte
        if (!bytes.empty()) {
          static const std::uint8_t kBytes[] = {0,   0xff, '\n', ':', '-', '[',
                                                '{', '9',  '.',  'e', '"', '\''};
          bytes[pick(bytes.size())] = kBytes[rng() % sizeof(kBytes)];
        }
        break;
      case 2:  // insert a byte
        bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(pick(bytes.size() + 1)),
                     static_cast<std::uint8_t>(rng()));
        break;
      case 3:  // delete a span
        if (!bytes.empty()) {
          const std::size_t at = pick(bytes.size());
          const std::size_t length = std::min<std::size_t>(1 + rng() % 16, bytes.size() - at);
          bytes.erase(bytes.begin() + static_cast<std::ptrdiff_t>(at),
                      bytes.begin() + static_cast<std::ptrdiff_t>(at + length));
        }
        break;
      case 4:  // truncate
        bytes.resize(pick(bytes.size() + 1));
        break;
      case 5:  // duplicate a span
        if (!bytes.empty() && bytes.size() < (1u << 20)) {
          const std::size_t at = pick(bytes.size());
          const std::size_t length = std::min<std::size_t>(1 + rng() % 64, bytes.size() - at);
          const std::vector<std::uint8_t> span(
              bytes.begin() + static_cast<std::ptrdiff_t>(at),
              bytes.begin() + static_cast<std::ptrdiff_t>(at + length));
          bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(pick(bytes.size() + 1)),
                       span.begin(), span.end());
        }
        break;
    }
  }
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  std::string corpus = "corpus";
  std::string crashes;
  int mutations = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--corpus") == 0) corpus = argv[i + 1];
    if (std::strcmp(argv[i], "--mutations") == 0) mutations = std::stoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--crashes") == 0) crashes = argv[i + 1];
  }
  int inputs = 0;
  int failures = 0;
  for (const auto& target : kinolab::fuzz::targets()) {
    const fs::path folder = fs::path(corpus) / target.name;
    if (!fs::is_directory(folder)) {
      std::fprintf(stderr, "fuzz_corpus: no corpus folder %s\n", folder.c_str());
      return 2;
    }
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    int target_inputs = 0;
    for (const fs::path& file : files) {
      std::ifstream in(file, std::ios::binary);
      const std::vector<std::uint8_t> seed((std::istreambuf_iterator<char>(in)),
                                           std::istreambuf_iterator<char>());
      std::mt19937_64 rng(std::hash<std::string>{}(file.filename().string()));
      for (int round = 0; round <= mutations; ++round) {
        const std::vector<std::uint8_t> bytes = round == 0 ? seed : mutate(seed, rng);
        ++inputs;
        ++target_inputs;
        try {
          target.run(bytes.data(), bytes.size());
        } catch (const std::exception& error) {
          ++failures;
          std::fprintf(stderr, "FAIL %s %s mutation %d: %s\n", target.name, file.c_str(), round,
                       error.what());
          if (!crashes.empty()) {
            fs::create_directories(crashes);
            const fs::path saved =
                fs::path(crashes) / (std::string(target.name) + "_" + file.filename().string() +
                                     "_" + std::to_string(round));
            std::ofstream(saved, std::ios::binary)
                .write(reinterpret_cast<const char*>(bytes.data()),
                       static_cast<std::streamsize>(bytes.size()));
          }
        }
      }
    }
    std::printf("fuzz_corpus: %s: %d inputs\n", target.name, target_inputs);
  }
  std::printf("%d passed, %d failed\n", inputs - failures, failures);
  return failures == 0 ? 0 : 1;
}
