#pragma once
// A small valid scene for the core's tests: a 0.2 m fluid cube at 5 cm spacing in a 0.8 m domain,
// no boundaries. Tests change one value and check what the core makes of it.
#include <string>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
namespace test
{
inline SceneConfig smallScene()
{
  SceneConfig s;
  s.spacing = 0.05;
  s.domain = {Vec3d(-0.2, -0.2, -0.2), Vec3d(0.6, 0.6, 0.6)};
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.2)};
  s.fluid.push_back(f);
  return s;
}

/// The key of the ConfigError that building a Simulation of `s` throws, or "<no error>".
inline std::string errorKey(const SceneConfig& s)
{
  try
  {
    Simulation sim(s);
  }
  catch (const ConfigError& e)
  {
    return e.key();
  }
  return "<no error>";
}
}  // namespace test
}  // namespace fluid_sim
