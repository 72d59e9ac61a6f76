#include "fluid_sim/io/file_util.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace fluid_sim
{
namespace io
{
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
