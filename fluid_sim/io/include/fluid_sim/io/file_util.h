#pragma once
// Small file helpers shared by the writers.

#include <string>

namespace fluid_sim
{
namespace io
{
/// Writes `contents` to "<path>.tmp" and renames it to `path`, so a reader of `path` sees either
/// the old file or the complete new one, never a half-written one. Throws std::runtime_error
/// naming the path.
void writeFileAtomically(const std::string& path, const std::string& contents);

}  // namespace io
}  // namespace fluid_sim
