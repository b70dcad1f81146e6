#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

namespace kinolab {

/// The candidate closest to `word` by edit distance, when it is close enough to be a likely
/// misspelling (at most two edits, and fewer than the word's length); empty otherwise.
std::string closestMatch(std::string_view word, const std::vector<std::string>& candidates);

/// " (did you mean 'x'?)" for the closest candidate, or nothing.
std::string didYouMean(std::string_view word, const std::vector<std::string>& candidates);

/// The shortest decimal text that reads back as the same double ("0.1", "1e-06", "inf").
std::string formatNumber(double value);

/// "(x, y, z)" with formatNumber() components.
std::string formatPoint(const Eigen::Vector3d& point);

/// `text` safe to print in a message: control characters and bytes outside printable ASCII
/// as \xHH escapes (a newline cannot start a forged line).
std::string printable(std::string_view text);

/// The words joined by `separator`.
std::string join(const std::vector<std::string>& words, std::string_view separator);

}  // namespace kinolab
