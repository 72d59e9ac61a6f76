#include "fluid_sim/io/ply_writer.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "fluid_sim/io/file_util.h"

namespace fluid_sim
{
namespace io
{
namespace
{
constexpr std::size_t kFloatsPerVertex = 8;  // x y z vx vy vz pressure density

/// Appends a float32 in little-endian byte order, whatever the host order.
void putFloat(std::string& out, Real value)
{
  const auto f = static_cast<float>(value);
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((bits >> (8 * k)) & 0xffu));
}

}  // namespace

void writePly(const std::string& path, const std::vector<Vec3>& positions, const std::vector<Vec3>& velocities,
              const std::vector<Real>& pressures, const std::vector<Real>& densities)
{
  const std::size_t n = positions.size();
  if (velocities.size() != n || pressures.size() != n || densities.size() != n)
    throw std::invalid_argument("writePly(" + path + "): particle arrays differ in length (" + std::to_string(n) +
                                " positions, " + std::to_string(velocities.size()) + " velocities, " +
                                std::to_string(pressures.size()) + " pressures, " + std::to_string(densities.size()) +
                                " densities)");

  std::string data =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment fluid_sim particles: m, m/s, Pa, kg/m^3\n"
      "element vertex " +
      std::to_string(n) +
      "\n"
      "property float x\n"
      "property float y\n"
      "property float z\n"
      "property float vx\n"
      "property float vy\n"
      "property float vz\n"
      "property float pressure\n"
      "property float density\n"
      "end_header\n";
  data.reserve(data.size() + n * kFloatsPerVertex * 4);
  for (std::size_t i = 0; i < n; ++i)
  {
    for (int k = 0; k < 3; ++k) putFloat(data, positions[i][k]);
    for (int k = 0; k < 3; ++k) putFloat(data, velocities[i][k]);
    putFloat(data, pressures[i]);
    putFloat(data, densities[i]);
  }

  writeFileAtomically(path, data);
}

std::string frameFileName(std::size_t frame_index)
{
  char name[32];
  std::snprintf(name, sizeof name, "%06zu.ply", frame_index);
  return name;
}

}  // namespace io
}  // namespace fluid_sim
