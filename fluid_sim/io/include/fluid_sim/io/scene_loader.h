#pragma once
// Scene YAML -> SceneConfig. Strict: an unknown key, a value of the wrong type or a value that
// fails validate() throws SceneError, whose what() reads "<file>: <dotted.key>: <message>".
// The schema (every key, its unit and default) is documented next to the fields in
// fluid_sim/core/scene_config.h.

#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
/// A bad scene file. key() is the dotted scene key at fault ("solver.density_error",
/// "boundaries[1].sphere.radius"; empty for a missing file or a YAML syntax error), file() the
/// scene file, and what() "<file>: <key>: <message>".
class SceneError : public ConfigError
{
public:
  SceneError(const std::string& file, const std::string& key, const std::string& message);
  const std::string& file() const
  {
    return file_;
  }
  const char* what() const noexcept override
  {
    return what_.c_str();
  }

private:
  std::string file_;
  std::string what_;
};

/// Reads and validates a scene file. `overrides` are "key.path=value" strings (the runner's
/// --set), applied to the YAML tree before conversion, e.g. "solver.boundary_pressure=sph",
/// "gravity=[0,0,-1]", "boundaries[1].sphere.radius=0.1". Values are parsed as YAML. Setting
/// time_step.fixed drops time_step.cfl/min/max; setting time_step.cfl drops time_step.fixed.
/// Sets scene.source = path. Throws SceneError.
SceneConfig loadScene(const std::string& path, const std::vector<std::string>& overrides = {});

/// As loadScene(), from YAML text; `source_name` is used in messages and as scene.source.
SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name,
                       const std::vector<std::string>& overrides = {});

}  // namespace io
}  // namespace fluid_sim
