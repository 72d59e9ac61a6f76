// Name lists and nearest-name suggestions for error messages (see message_names.h).
#include "fluid_sim/io/message_names.h"

#include <algorithm>

namespace fluid_sim
{
namespace io
{
std::string joinNames(const std::vector<std::string>& names, const std::string& last_separator,
                      const std::string& if_none)
{
  if (names.empty()) return if_none;
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == names.size() ? last_separator : ", ")) + names[i];
  return out;
}

std::size_t editDistance(const std::string& a, const std::string& b)
{
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
  {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
    {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string closestName(const std::string& name, const std::vector<std::string>& candidates, std::size_t max_distance)
{
  std::string best;
  std::size_t best_distance = max_distance;
  for (const auto& candidate : candidates)
  {
    const std::size_t d = editDistance(name, candidate);
    if (d < best_distance)
    {
      best = candidate;
      best_distance = d;
    }
  }
  return best;
}

}  // namespace io
}  // namespace fluid_sim
