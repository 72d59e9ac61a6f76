#pragma once
// Small file helpers shared across io: reading a whole file with messages that say why it cannot
// be read, and writing a file atomically (the writers).

#include <fstream>
#include <string>

namespace fluid_sim
{
namespace io
{
/// Opens `path` for reading (binary). Throws ConfigError(path, message) with message "no such
/// file", "is a directory, not a <kind>" (kind e.g. "scene file") or "cannot open: <reason>".
std::ifstream openForReading(const std::string& path, const std::string& kind);

/// The whole content of the file at `path`, byte for byte. Throws as openForReading(), or
/// ConfigError(path, "cannot read: <reason>").
std::string readTextFile(const std::string& path, const std::string& kind);

/// Writes `contents` to "<path>.tmp" and renames it to `path`, so a reader of `path` sees either
/// the old file or the complete new one, never a half-written one. Throws std::runtime_error
/// naming the path.
void writeFileAtomically(const std::string& path, const std::string& contents);

}  // namespace io
}  // namespace fluid_sim
