#include "fluid_sim/io/bodies_writer.h"

#include <stdexcept>

namespace fluid_sim
{
namespace io
{
std::string csvField(const std::string& text)
{
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text)
  {
    out += c;
    if (c == '"') out += '"';
  }
  return out + '"';
}

CsvFile::CsvFile(const std::string& path, const char* header) : path_(path), out_(path, std::ios::trunc)
{
  if (!out_) throw std::runtime_error("cannot create " + path_);
  out_.precision(9);  // significant digits, as stats.csv and the instrument files
  out_ << header << '\n';
}

void CsvFile::flush()
{
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_);
}

const char* BodiesCsvWriter::header()
{
  return "t,body,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,fx,fy,fz,tx,ty,tz";
}

BodiesCsvWriter::BodiesCsvWriter(const std::string& path) : CsvFile(path, header()) {}

void BodiesCsvWriter::write(double t, const std::vector<BodyInfo>& bodies)
{
  const auto vec = [this](const Vec3d& v) { out_ << ',' << v.x() << ',' << v.y() << ',' << v.z(); };
  for (const BodyInfo& b : bodies)
  {
    if (!b.free) continue;
    const Eigen::Quaterniond& q = b.pose.rotation;
    out_ << t << ',' << csvField(b.name);
    vec(b.center_of_mass);
    out_ << ',' << q.x() << ',' << q.y() << ',' << q.z() << ',' << q.w();
    vec(b.com_velocity);
    vec(b.angular_velocity);
    vec(b.force);
    vec(b.torque_com);
    out_ << '\n';
  }
}

const char* WrenchesCsvWriter::header()
{
  return "t,body,fx,fy,fz,tx,ty,tz,window_s";
}

WrenchesCsvWriter::WrenchesCsvWriter(const std::string& path, std::vector<std::string> names)
    : CsvFile(path, header()), names_(std::move(names)), sum_(names_.size())
{
}

void WrenchesCsvWriter::add(const std::vector<Wrench>& wrenches, double dt)
{
  for (std::size_t k = 0; k < sum_.size() && k < wrenches.size(); ++k)
  {
    sum_[k].force += dt * wrenches[k].force;
    sum_[k].torque += dt * wrenches[k].torque;
  }
  window_ += dt;
}

void WrenchesCsvWriter::write(double t)
{
  if (!(window_ > 0.0)) return;
  const auto vec = [this](const Vec3d& v) { out_ << ',' << v.x() << ',' << v.y() << ',' << v.z(); };
  for (std::size_t k = 0; k < sum_.size(); ++k)
  {
    out_ << t << ',' << csvField(names_[k]);
    vec(sum_[k].force / window_);
    vec(sum_[k].torque / window_);
    out_ << ',' << window_ << '\n';
    sum_[k] = Wrench();
  }
  window_ = 0.0;
}

const char* SinksCsvWriter::header()
{
  return "t,sink,particles,volume_m3,mass_kg";
}

SinksCsvWriter::SinksCsvWriter(const std::string& path) : CsvFile(path, header()) {}

void SinksCsvWriter::write(double t, const std::vector<SinkTotal>& sinks)
{
  for (const SinkTotal& s : sinks)
    out_ << t << ',' << csvField(s.name) << ',' << s.particles << ',' << s.volume << ',' << s.mass << '\n';
}

const char* EmittersCsvWriter::header()
{
  return "t,emitter,particles,volume_m3,mass_kg,blocked";
}

EmittersCsvWriter::EmittersCsvWriter(const std::string& path) : CsvFile(path, header()) {}

void EmittersCsvWriter::write(double t, const std::vector<EmitterTotal>& emitters)
{
  for (const EmitterTotal& e : emitters)
    out_ << t << ',' << csvField(e.name) << ',' << e.particles << ',' << e.volume << ',' << e.mass << ',' << e.blocked
         << '\n';
}

}  // namespace io
}  // namespace fluid_sim
