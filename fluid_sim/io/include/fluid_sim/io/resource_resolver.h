#pragma once
// Where a file named in a scene or a URDF lives: "package://pkg/path", "file:///abs/path", an
// absolute path, or a path relative to the folder of the file that names it. Finding a package's
// folder is injected by the caller (the ROS node passes ros::package::getPath); a ROS-free default
// searches ROS_PACKAGE_PATH and given folders for the package.xml whose <name> matches.

#include <functional>
#include <string>
#include <vector>

namespace fluid_sim
{
namespace io
{
/// The folder of a package, given its name; "" if it is not known.
using PackageResolver = std::function<std::string(const std::string& package_name)>;

/// Resolves a resource reference to a file path (not checked for existence):
///   "package://pkg/rel/path" -> packages("pkg") + "/rel/path"
///   "file:///abs/path"       -> "/abs/path" ("file://rel" is taken relative, like a plain path)
///   "/abs/path"              -> as is
///   "rel/path"               -> base_dir + "/rel/path" (base_dir "" = the working directory)
/// Throws ConfigError(uri, ...) for an unknown package (naming the folders searched when the
/// resolver says so), a package:// URI without a resolver, an empty reference or another scheme
/// ("http://...").
std::string resolveResource(const std::string& uri, const std::string& base_dir, const PackageResolver& packages);

/// A resolver that searches `folders` and then every entry of the environment variable
/// ROS_PACKAGE_PATH (as set at its first call) for folders with a package.xml, at most `max_depth`
/// levels deep, the way rospack does: it does not look inside a package's folder (nor in hidden
/// folders or those with a CATKIN_IGNORE file), and the first package found with a name wins.
/// Each folder is searched once, and only when a name was not found in the folders before it.
/// Thread-safe.
PackageResolver defaultPackageResolver(const std::vector<std::string>& folders = {}, int max_depth = 6);

/// The <name> of a package.xml file ("" if it cannot be read or has none).
std::string packageNameOf(const std::string& package_xml);

/// The nearest folder at or above `start` that holds a package.xml ("" if none): the package a
/// scene file belongs to.
std::string enclosingPackageFolder(const std::string& start);

}  // namespace io
}  // namespace fluid_sim
