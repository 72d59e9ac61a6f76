#pragma once
// The runner's bodies.csv, wrenches.csv, sinks.csv and emitters.csv. bodies.csv: the state of every free body (scene
// key `dynamic`, or a urdf entry's free_links), one row per free body per measurement (the runner writes at its frame
// times, as regions.csv). Created only when the scene has a free body. Columns, a contract read by name:
//   t,body,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,fx,fy,fz,tx,ty,tz
// t in s; x y z the centre of mass, m, world; q the body's orientation (body -> world, unit
// quaternion); v the centre of mass's velocity, m/s, world; w the angular velocity, rad/s, world;
// f the fluid's force, N, world; t the fluid's torque about the centre of mass, N m, world.

#include <fstream>
#include <string>
#include <vector>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/run_summary.h"

namespace fluid_sim
{
namespace io
{
/// A CSV file the runner appends rows to: created (truncated) with its header line, 9
/// significant digits as stats.csv and the instrument files; the writers below add the rows.
/// A text field as a CSV cell (RFC 4180): as it is, or, when it holds a comma, a double quote or a
/// line break, in double quotes with its double quotes doubled (a body may be named "a,b").
std::string csvField(const std::string& text);

class CsvFile
{
public:
  /// Flushes; throws std::runtime_error naming the file if it could not be written.
  void flush();

protected:
  /// Creates (truncates) `path` with the `header` line; throws std::runtime_error naming the file.
  CsvFile(const std::string& path, const char* header);
  std::string path_;
  std::ofstream out_;
};

class BodiesCsvWriter : public CsvFile
{
public:
  /// Creates (truncates) `path` with the header. Throws std::runtime_error naming the file if it
  /// cannot be created.
  explicit BodiesCsvWriter(const std::string& path);

  /// One row per body of `bodies` whose `free` is set, at simulated time `t` (s); the others are
  /// skipped.
  void write(double t, const std::vector<BodyInfo>& bodies);

  static const char* header();
};

/// The runner's wrenches.csv: the fluid's force and torque on every body (static, scripted, posed
/// or free, containers too), time-averaged over the steps since the previous row, one row per body
/// per measurement (the same times as bodies.csv, no row before the first step). Created when the
/// scene has a body. Columns, a contract read by name: t,body,fx,fy,fz,tx,ty,tz,window_s
/// t in s (the row's end); f in N and the torque about the body's origin in N m, world axes (as
/// summary.json's wrenches); window_s the simulated time averaged over, s.
class WrenchesCsvWriter : public CsvFile
{
public:
  /// Creates (truncates) `path` with the header; throws std::runtime_error naming the file.
  WrenchesCsvWriter(const std::string& path, std::vector<std::string> names);
  /// Adds one step's wrenches (body index order) over its time step `dt` (s).
  void add(const std::vector<Wrench>& wrenches, double dt);
  /// Writes the means since the last row, at simulated time `t` (s), and starts a new window;
  /// nothing when no step was added since.
  void write(double t);
  static const char* header();

private:
  std::vector<std::string> names_;
  std::vector<Wrench> sum_;  // N s and N m s over the window
  double window_ = 0.0;      // s
};

/// The runner's sinks.csv: what each sink (scene key sinks) has removed since t = 0, one row per
/// sink per measurement (the same times as bodies.csv). Created only when the scene has a sink.
/// Columns: t,sink,particles,volume_m3,mass_kg (cumulative; volume as particles times spacing^3).
class SinksCsvWriter : public CsvFile
{
public:
  /// Creates (truncates) `path` with the header; throws std::runtime_error naming the file.
  explicit SinksCsvWriter(const std::string& path);
  void write(double t, const std::vector<SinkTotal>& sinks);
  static const char* header();
};

/// The runner's emitters.csv: what each emitter (scene key emitters) has released since t = 0, one
/// row per emitter per measurement (the same times as bodies.csv). Created only when the scene has
/// an emitter. Columns: t,emitter,particles,volume_m3,mass_kg,blocked (cumulative; volume as
/// particles times spacing^3; blocked: nozzle points left out because water or a wall was there).
class EmittersCsvWriter : public CsvFile
{
public:
  /// Creates (truncates) `path` with the header; throws std::runtime_error naming the file.
  explicit EmittersCsvWriter(const std::string& path);
  void write(double t, const std::vector<EmitterTotal>& emitters);
  static const char* header();
};

}  // namespace io
}  // namespace fluid_sim
