#pragma once
// Scene YAML -> SceneConfig. Strict: an unknown key, a value of the wrong type or a value that
// fails validate() throws SceneError, whose what() reads "<file>: <dotted.key>: <message>".
// The schema (every key, its unit and default) is documented next to the fields in
// fluid_sim/core/scene_config.h; the strict reading is yaml_reader.h, --set is scene_overrides.h.

#include <string>
#include <vector>

#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"
#include "fluid_sim/io/resource_resolver.h"

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

/// What the loader needs from its caller beyond the scene text.
struct SceneLoadOptions
{
  /// Finds a package's folder for package:// file names (the ROS node passes
  /// ros::package::getPath). Empty: defaultPackageResolver() over the package that holds the scene
  /// file (the nearest folder above it with a package.xml), then ROS_PACKAGE_PATH.
  PackageResolver packages;
  /// Folder that relative file names in the scene are relative to. Empty: the scene file's folder.
  std::string base_dir;
};

/// Reads and validates a scene file. `overrides` are "key.path=value" strings (the runner's
/// --set), applied to the YAML tree before conversion, e.g. "solver.boundary_pressure=sph",
/// "gravity=[0,0,-1]", "boundaries[1].sphere.radius=0.1". Values are parsed as YAML. Setting
/// time_step.fixed drops time_step.cfl/min/max; setting time_step.cfl drops time_step.fixed.
/// Mesh files and URDFs named by the scene are read (relative to the scene file's folder);
/// notes that are not errors land in scene.warnings, each naming its file.
/// Sets scene.source = path. Throws SceneError.
SceneConfig loadScene(const std::string& path, const std::vector<std::string>& overrides = {},
                      const SceneLoadOptions& options = {});

/// As loadScene(), from YAML text; `source_name` is used in messages and as scene.source, and its
/// folder is the base of relative file names unless options.base_dir is given.
SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name,
                       const std::vector<std::string>& overrides = {}, const SceneLoadOptions& options = {});

}  // namespace io
}  // namespace fluid_sim
