#pragma once
// One fuzz target per loader kinolab reads untrusted files with. Each takes the bytes of one
// file; a kinolab::Error (the clear message a user gets) is the expected way to refuse
// input, anything else (a crash, another exception, a hang) is a bug. Built two ways:
// with clang and -DKINOLAB_FUZZ=ON as libFuzzer binaries (fuzz_<target>), and always as
// the `fuzz_corpus` regression test over tests/fuzz/corpus/ with seeded mutations.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace kinolab::fuzz {

struct Target {
  const char* name;  ///< also the corpus folder
  void (*run)(const std::uint8_t* data, std::size_t size);
};

/// experiment (a `kinolab run` file), world_spec, octomap (.bt), results_db (`merge` input).
const std::vector<Target>& targets();

}  // namespace kinolab::fuzz
