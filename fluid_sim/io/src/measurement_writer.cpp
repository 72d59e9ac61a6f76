#include "fluid_sim/io/measurement_writer.h"

#include <filesystem>
#include <stdexcept>

namespace fluid_sim
{
namespace io
{
const char* MeasurementCsvWriter::regionsHeader()
{
  return "t,region,volume_m3,mass_kg,fill_fraction,vx,vy,vz,particles";
}
const char* MeasurementCsvWriter::probesHeader()
{
  return "t,probe,x,y,z,pressure_pa,density,vx,vy,vz,wet";
}
const char* MeasurementCsvWriter::spillHeader()
{
  return "t,below_m,particles,volume_m3,mass_kg";
}

std::unique_ptr<MeasurementCsvWriter::File> MeasurementCsvWriter::open(const std::string& path, const char* header)
{
  auto file = std::make_unique<File>();
  file->path = path;
  file->out.open(path, std::ios::trunc);
  if (!file->out) throw std::runtime_error("cannot create " + path);
  file->out.precision(9);
  file->out << header << '\n';
  return file;
}

MeasurementCsvWriter::MeasurementCsvWriter(const std::string& dir, const Measurements& m)
{
  const std::filesystem::path d(dir);
  if (!m.regions().empty()) regions_ = open((d / "regions.csv").string(), regionsHeader());
  if (!m.probes().empty()) probes_ = open((d / "probes.csv").string(), probesHeader());
  if (m.spillEnabled()) spill_ = open((d / "spill.csv").string(), spillHeader());
}

void MeasurementCsvWriter::write(const MeasurementReport& r)
{
  if (regions_)
    for (const RegionMeasurement& m : r.regions)
      regions_->out << r.time << ',' << m.name << ',' << m.volume << ',' << m.mass << ',' << m.fill_fraction << ','
                    << m.mean_velocity.x() << ',' << m.mean_velocity.y() << ',' << m.mean_velocity.z() << ','
                    << m.particles << '\n';
  if (probes_)
    for (const ProbeMeasurement& m : r.probes)
      probes_->out << r.time << ',' << m.name << ',' << m.position.x() << ',' << m.position.y() << ',' << m.position.z()
                   << ',' << m.pressure << ',' << m.density << ',' << m.velocity.x() << ',' << m.velocity.y() << ','
                   << m.velocity.z() << ',' << int(m.wet) << '\n';
  if (spill_ && r.spill.enabled)
    spill_->out << r.time << ',' << r.spill.below << ',' << r.spill.particles << ',' << r.spill.volume << ','
                << r.spill.mass << '\n';
}

void MeasurementCsvWriter::flush()
{
  for (File* f : {regions_.get(), probes_.get(), spill_.get()})
  {
    if (!f) continue;
    f->out.flush();
    if (!f->out) throw std::runtime_error("cannot write " + f->path);
  }
}

}  // namespace io
}  // namespace fluid_sim
