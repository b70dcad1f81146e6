// libFuzzer entry point of one target (clang, -DKINOLAB_FUZZ=ON): fuzz_<target> CORPUS_DIR.
#include <cstring>

#include "fuzz_targets.hpp"

#ifndef KINOLAB_FUZZ_TARGET
#error "KINOLAB_FUZZ_TARGET names the target"
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (const auto& target : kinolab::fuzz::targets()) {
    if (std::strcmp(target.name, KINOLAB_FUZZ_TARGET) == 0) target.run(data, size);
  }
  return 0;
}
