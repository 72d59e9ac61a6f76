#include "fluid_sim/io/resource_resolver.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "fluid_sim/core/types.h"
#include "fluid_sim/io/file_util.h"

namespace fluid_sim
{
namespace io
{
namespace fs = std::filesystem;

namespace
{
bool startsWith(const std::string& text, const std::string& prefix)
{
  return text.compare(0, prefix.size(), prefix) == 0;
}

std::string relativeTo(const std::string& base_dir, const std::string& path)
{
  if (base_dir.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

/// Name -> folder of every package found below the search folders (first found wins).
struct PackageIndex
{
  std::map<std::string, std::string> packages;
};

void crawl(const fs::path& folder, int depth_left, PackageIndex& index)
{
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return;
  if (fs::exists(folder / "CATKIN_IGNORE", ec)) return;
  const fs::path manifest = folder / "package.xml";
  if (fs::is_regular_file(manifest, ec))
  {
    const std::string name = packageNameOf(manifest.string());
    if (!name.empty()) index.packages.emplace(name, folder.lexically_normal().string());
    return;  // rospack does not look inside a package
  }
  if (depth_left <= 0) return;
  // Sorted, so that which of two same-named packages wins does not depend on the file system.
  std::vector<fs::path> children;
  for (fs::directory_iterator it(folder, fs::directory_options::skip_permission_denied, ec), end; !ec && it != end;
       it.increment(ec))
  {
    const std::string leaf = it->path().filename().string();
    if (!leaf.empty() && leaf[0] != '.' && it->is_directory(ec)) children.push_back(it->path());
  }
  std::sort(children.begin(), children.end());
  for (const auto& child : children) crawl(child, depth_left - 1, index);
}

int hexValue(char c)
{
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// A file URI's path is percent-encoded (RFC 8089 with RFC 3986): exporters and file managers
/// write a space as %20, which no file name on disk contains literally.
std::string percentDecoded(const std::string& uri, const std::string& path)
{
  std::string out;
  out.reserve(path.size());
  for (std::size_t i = 0; i < path.size(); ++i)
  {
    if (path[i] != '%')
    {
      out += path[i];
      continue;
    }
    const int high = i + 2 < path.size() ? hexValue(path[i + 1]) : -1;
    const int low = i + 2 < path.size() ? hexValue(path[i + 2]) : -1;
    if (high < 0 || low < 0)
      throw ConfigError(
          uri, "malformed percent escape '" + path.substr(i, 3) + "' in file URI (a literal % is written %25)");
    const char decoded = static_cast<char>(high * 16 + low);
    if (decoded == '\0') throw ConfigError(uri, "file URI contains %00");
    out += decoded;
    i += 2;
  }
  return out;
}
}  // namespace

std::string packageNameOf(const std::string& package_xml)
{
  std::string text;
  try
  {
    text = readTextFile(package_xml, "package.xml file");
  }
  catch (const ConfigError&)
  {
    return "";
  }
  // An XML parse, not a regular expression (std::regex recursed per character and overflowed
  // the stack on a long comment): comments, CDATA and nesting are the parser's business, and
  // tinyxml2 refuses nesting deeper than TINYXML2_MAX_ELEMENT_DEPTH instead of recursing on.
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS) return "";
  const tinyxml2::XMLElement* package = doc.RootElement();
  if (!package || std::string(package->Name()) != "package") return "";
  const tinyxml2::XMLElement* name = package->FirstChildElement("name");
  if (!name || !name->GetText()) return "";
  std::string value = name->GetText();
  const auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  value.erase(value.begin(), std::find_if_not(value.begin(), value.end(), space));
  value.erase(std::find_if_not(value.rbegin(), value.rend(), space).base(), value.end());
  // A package name is one word (rospack: [a-z][a-z0-9_]*; be lenient, but no spaces).
  if (value.empty() || std::any_of(value.begin(), value.end(), space)) return "";
  return value;
}

std::string enclosingPackageFolder(const std::string& start)
{
  std::error_code ec;
  fs::path folder = fs::absolute(start.empty() ? fs::path(".") : fs::path(start), ec).lexically_normal();
  if (ec) return "";
  if (!fs::is_directory(folder, ec)) folder = folder.parent_path();
  while (!folder.empty())
  {
    if (fs::is_regular_file(folder / "package.xml", ec)) return folder.string();
    const fs::path parent = folder.parent_path();
    if (parent == folder) break;
    folder = parent;
  }
  return "";
}

PackageResolver defaultPackageResolver(const std::vector<std::string>& folders, int max_depth)
{
  // Roots are searched one at a time, in order, only as far as a lookup needs: a package found in
  // the first folder never costs a crawl of a large ROS_PACKAGE_PATH entry (/usr/share).
  struct State
  {
    std::mutex mutex;
    bool roots_known = false;
    std::vector<std::string> roots;
    std::size_t next_root = 0;
    int max_depth = 6;
    PackageIndex index;
  };
  auto state = std::make_shared<State>();
  state->roots = folders;
  state->max_depth = max_depth;
  return [state](const std::string& name) -> std::string {
    std::lock_guard<std::mutex> lock(state->mutex);
    if (!state->roots_known)  // ROS_PACKAGE_PATH as set at the first lookup
    {
      state->roots_known = true;
      if (const char* env = std::getenv("ROS_PACKAGE_PATH"))
      {
        std::stringstream entries(env);
        std::string entry;
        while (std::getline(entries, entry, ':'))
          if (!entry.empty()) state->roots.push_back(entry);
      }
    }
    for (;;)
    {
      const auto it = state->index.packages.find(name);
      if (it != state->index.packages.end()) return it->second;
      if (state->next_root >= state->roots.size()) return "";
      crawl(state->roots[state->next_root++], state->max_depth, state->index);
    }
  };
}

std::string resolveResource(const std::string& uri, const std::string& base_dir, const PackageResolver& packages)
{
  if (uri.empty()) throw ConfigError("", "empty file name");
  if (startsWith(uri, "package://"))
  {
    const std::string rest = uri.substr(10);
    const std::size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    if (package.empty() || slash == std::string::npos || slash + 1 == rest.size())
      throw ConfigError(uri, "malformed package URI (expected package://<package>/<path>)");
    if (!packages) throw ConfigError(uri, "cannot resolve package://" + package + ": no package resolver was given");
    const std::string folder = packages(package);
    if (folder.empty())
    {
      const char* env = std::getenv("ROS_PACKAGE_PATH");
      throw ConfigError(uri, "unknown package '" + package + "': put the folder that holds it on ROS_PACKAGE_PATH (" +
                                 (env && *env ? "now " + std::string(env) : std::string("not set")) + ")");
    }
    return (fs::path(folder) / rest.substr(slash + 1)).lexically_normal().string();
  }
  if (startsWith(uri, "file://"))
  {
    std::string path = uri.substr(7);
    // file://localhost/path names the same file as file:///path (RFC 8089); any other host
    // is a remote file this loader cannot open.
    if (startsWith(path, "localhost/")) path = path.substr(9);
    path = percentDecoded(uri, path);
    if (path.empty()) throw ConfigError(uri, "empty file URI");
    return relativeTo(base_dir, path);
  }
  const std::size_t scheme = uri.find("://");
  if (scheme != std::string::npos && uri.find('/') > scheme)
    throw ConfigError(uri,
                      "unsupported URI scheme '" + uri.substr(0, scheme) + "://' (use package://, file:// or a path)");
  return relativeTo(base_dir, uri);
}

}  // namespace io
}  // namespace fluid_sim
