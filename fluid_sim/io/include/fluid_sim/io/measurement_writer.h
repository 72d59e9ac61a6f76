#pragma once
// The runner's instrument files (scene keys regions, probes, spill), one row per instrument per
// measurement (the runner measures at its frame times). Only the files of the instruments a
// scene declares are created. Columns, a contract read by name:
//   regions.csv  t,region,volume_m3,mass_kg,fill_fraction,vx,vy,vz,particles
//   probes.csv   t,probe,x,y,z,pressure_pa,density,vx,vy,vz,wet
//   spill.csv    t,below_m,particles,volume_m3,mass_kg
// t in s; velocities in m/s (a region's mean, a probe's interpolated; 0 when empty or dry);
// position in m, world; density in kg/m^3; wet 0 | 1.

#include <fstream>
#include <memory>
#include <string>

#include "fluid_sim/core/measurements.h"

namespace fluid_sim
{
namespace io
{
class MeasurementCsvWriter
{
public:
  /// Creates (truncates) in `dir` the files of the instruments `measurements` has, with their
  /// headers. Throws std::runtime_error naming a file that cannot be created.
  MeasurementCsvWriter(const std::string& dir, const Measurements& measurements);

  /// The rows of one measurement.
  void write(const MeasurementReport& report);
  /// Flushes; throws std::runtime_error naming a file that could not be written.
  void flush();

  static const char* regionsHeader();
  static const char* probesHeader();
  static const char* spillHeader();

private:
  struct File
  {
    std::string path;
    std::ofstream out;
  };
  static std::unique_ptr<File> open(const std::string& path, const char* header);

  std::unique_ptr<File> regions_, probes_, spill_;
};

}  // namespace io
}  // namespace fluid_sim
