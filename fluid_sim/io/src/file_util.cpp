#include "fluid_sim/io/file_util.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
std::ifstream openForReading(const std::string& path, const std::string& kind)
{
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw ConfigError(path, "no such file");
  if (std::filesystem::is_directory(path, ec)) throw ConfigError(path, "is a directory, not a " + kind);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path, std::string("cannot open: ") + std::strerror(errno));
  return in;
}

std::string readTextFile(const std::string& path, const std::string& kind)
{
  std::ifstream in = openForReading(path, kind);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ConfigError(path, std::string("cannot read: ") + std::strerror(errno));
  return text.str();
}

void writeFileAtomically(const std::string& path, const std::string& contents)
{
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.close();
    if (!out)
    {
      const std::string reason = std::strerror(errno);
      std::remove(tmp.c_str());
      throw std::runtime_error("cannot write " + tmp + ": " + reason);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
  {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " + ec.message());
  }
}

}  // namespace io
}  // namespace fluid_sim
