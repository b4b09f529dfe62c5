#pragma once
// "Did you mean" for names a user typed: a command, a scene field, a flag value.
#include <optional>
#include <string>
#include <vector>

namespace lensfarm {

// The number of single-character insertions, deletions and substitutions from `a` to `b`
// (Levenshtein distance), ignoring ASCII case.
size_t editDistance(const std::string& a, const std::string& b);

// The candidate nearest to `word` if it is close enough to be a slip: at most two edits away (one
// for words of four characters or fewer), the first of equally near ones; otherwise nothing.
std::optional<std::string> nearestName(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace lensfarm
