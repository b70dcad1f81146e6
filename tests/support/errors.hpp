#pragma once

#include <string>

namespace kinolab::test {

/// The message of the `Error` that `work` throws; "" when it throws none (so a test expecting a
/// message fails, and one expecting none compares with ""). Another exception propagates.
template <typename Error, typename Work>
std::string errorOf(const Work& work) {
  try {
    work();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

}  // namespace kinolab::test
