#pragma once
// Names in error messages: the list of valid names ("mirroring, sph or mls"), and the valid name
// nearest to a misspelt one (for "did you mean ..."). Shared by the YAML reader and the URDF loader.

#include <cstddef>
#include <string>
#include <vector>

namespace fluid_sim
{
namespace io
{
/// The names separated by ", ", the last two by `last_separator` ("a, b or c" with " or ");
/// `if_none` when there are none.
std::string joinNames(const std::vector<std::string>& names, const std::string& last_separator = ", ",
                      const std::string& if_none = "");

/// Levenshtein distance: the fewest single-character insertions, deletions and substitutions that
/// turn `a` into `b`.
std::size_t editDistance(const std::string& a, const std::string& b);

/// The first of `candidates` at the smallest edit distance from `name` below `max_distance`; "" if
/// none is that close.
std::string closestName(const std::string& name, const std::vector<std::string>& candidates, std::size_t max_distance);

}  // namespace io
}  // namespace fluid_sim
