#include "fluid_sim/io/mesh_loader.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <unordered_map>
#include <utility>

#include "fluid_sim/core/cell_key.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/io/collada_check.h"
#include "fluid_sim/io/file_util.h"
#include "fluid_sim/io/mesh_topology.h"
#include "fluid_sim/io/ply_reader.h"

namespace fluid_sim
{
namespace io
{
namespace fs = std::filesystem;

namespace
{
std::string lower(std::string text)
{
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

Eigen::Matrix4d toEigen(const aiMatrix4x4& m)
{
  Eigen::Matrix4d out;
  out << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return out;
}

/// Triangles of a scene in the root frame, before joining.
struct Soup
{
  std::vector<Vec3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::size_t dropped_primitives = 0;
};

/// Deepest node hierarchy collect() follows (a recursion per level).
constexpr int kMaxNodeDepth = 256;

void collect(const aiScene& scene, const aiNode& node, const Eigen::Matrix4d& parent, const std::string& path,
             Soup& soup, int depth = 0)
{
  // aiProcess_ValidateDataStructure has checked the scene; these checks keep a malformed file
  // from reading memory it does not own even if a loader got something past it.
  if (depth > kMaxNodeDepth)
    throw ConfigError(path, "the node hierarchy is deeper than " + std::to_string(kMaxNodeDepth) + " levels");
  const Eigen::Matrix4d transform = parent * toEigen(node.mTransformation);
  const Eigen::Matrix3d linear = transform.topLeftCorner<3, 3>();
  const bool mirrored = linear.determinant() < 0.0;
  for (unsigned k = 0; k < node.mNumMeshes; ++k)
  {
    if (!node.mMeshes || node.mMeshes[k] >= scene.mNumMeshes || !scene.mMeshes[node.mMeshes[k]])
      throw ConfigError(path, "node '" + std::string(node.mName.C_Str()) + "' names a mesh that does not exist");
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[k]];
    if (mesh.mNumVertices > 0 && !mesh.mVertices)
      throw ConfigError(path, "mesh '" + std::string(mesh.mName.C_Str()) + "' has no vertex array");
    if (soup.vertices.size() + mesh.mNumVertices > std::size_t(std::numeric_limits<int>::max()))
      throw ConfigError(path, "more than " + std::to_string(std::numeric_limits<int>::max()) + " vertices");
    const int first = static_cast<int>(soup.vertices.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v)
    {
      const aiVector3D& a = mesh.mVertices[v];
      const Vec3d p = linear * Vec3d(a.x, a.y, a.z) + transform.topRightCorner<3, 1>();
      if (!p.allFinite())
        throw ConfigError(path, "mesh '" + std::string(mesh.mName.C_Str()) + "' has a NaN or infinite vertex (number " +
                                    std::to_string(v) + ")");
      soup.vertices.push_back(p);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
    {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3)
      {
        ++soup.dropped_primitives;
        continue;
      }
      for (unsigned i = 0; i < 3; ++i)
        if (face.mIndices[i] >= mesh.mNumVertices)
          throw ConfigError(path, "mesh '" + std::string(mesh.mName.C_Str()) + "': face " + std::to_string(f) +
                                      " names vertex " + std::to_string(face.mIndices[i]) + ", but the mesh has " +
                                      std::to_string(mesh.mNumVertices) + " vertices");
      std::array<int, 3> t = {first + int(face.mIndices[0]), first + int(face.mIndices[1]),
                              first + int(face.mIndices[2])};
      if (mirrored) std::swap(t[1], t[2]);
      soup.triangles.push_back(t);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
  {
    if (!node.mChildren || !node.mChildren[c])
      throw ConfigError(path, "node '" + std::string(node.mName.C_Str()) + "' has a missing child");
    collect(scene, *node.mChildren[c], transform, path, soup, depth + 1);
  }
}

/// Joins vertices closer than `eps` (m): the first of a cluster stands for it.
std::vector<int> joinVertices(const std::vector<Vec3d>& vertices, double eps, std::vector<Vec3d>& joined)
{
  std::unordered_map<CellKey, std::vector<int>, CellKeyHash> cells;  // cells of side eps
  std::vector<int> map(vertices.size());
  const double eps2 = eps * eps;
  for (std::size_t i = 0; i < vertices.size(); ++i)
  {
    const Vec3d& p = vertices[i];
    const CellKey key = cellKeyOf(p, eps);
    int found = -1;
    for (long long dz = -1; dz <= 1 && found < 0; ++dz)
      for (long long dy = -1; dy <= 1 && found < 0; ++dy)
        for (long long dx = -1; dx <= 1 && found < 0; ++dx)
        {
          const auto it = cells.find({key.x + dx, key.y + dy, key.z + dz});
          if (it == cells.end()) continue;
          for (int j : it->second)
            if ((joined[j] - p).squaredNorm() <= eps2)
            {
              found = j;
              break;
            }
        }
    if (found < 0)
    {
      found = static_cast<int>(joined.size());
      joined.push_back(p);
      cells[key].push_back(found);
    }
    map[i] = found;
  }
  return map;
}

/// At most this many facets around a cylinder or a sphere (half a million triangles for a sphere):
/// only a spacing far below the body's size asks for more, and validate() refuses such a body.
constexpr int kMaxSegments = 1000;

/// Places vertices on a circle of radius r_v such that the polygon's vertices lie outside the
/// circle of radius r by as much as its edge midpoints lie inside: the facet error is halved.
double balancedRadius(double radius, double cos_half_angle)
{
  return 2.0 * radius / (1.0 + cos_half_angle);
}

int segmentsFor(double radius, double max_error)
{
  // Balanced polygon: error r (1 - c) / (1 + c) with c = cos(pi / n).
  int n = 8;
  while (n < kMaxSegments)
  {
    const double c = std::cos(M_PI / n);
    if (radius * (1.0 - c) / (1.0 + c) <= max_error) break;
    n = std::max(n + 1, int(n * 1.1));
  }
  return std::min(n, kMaxSegments);
}
}  // namespace

MeshFile readMeshFile(const std::string& path, const Vec3d& scale)
{
  openForReading(path, "mesh file");  // a missing or unreadable file, before assimp tries it
  const std::string ext = lower(fs::path(path).extension().string());
  Assimp::Importer importer;
  if (ext.empty() || !importer.IsExtensionSupported(ext))
    throw ConfigError(path, "unknown mesh format" +
                                (ext.empty() ? std::string(" (no file extension)") : " '" + ext + "'") +
                                "; use STL, OBJ, COLLADA (.dae), PLY or another format assimp reads");
  if (!scale.allFinite() || (scale.array() == 0.0).any())
    throw ConfigError(path, "mesh scale must be finite and not zero on any axis");
  // assimp's COLLADA parser trusts the file's counts and tokens (collada_check.h): a bad one cost
  // 18.9 GB and 96 s before std::bad_alloc; checked first, such a file is refused in milliseconds.
  if (looksLikeCollada(path)) checkColladaText(path, readTextFile(path, "mesh file"));
  // assimp's PLY reader loops without end on a header it cannot finish (ply_reader.h).
  if (ext == ".ply") checkPlyMeshHeader(path, readTextFile(path, "mesh file"));
  // Meshes are used as written, z up (what rviz and Gazebo do); the COLLADA unit stays in the
  // root node's transform and is applied below.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  // No aiProcess_JoinIdenticalVertices: it merges a NaN vertex into a finite one (hiding it), and
  // it would not join STL corners anyway (their per-face normals differ); the vertices are joined
  // by position below instead.
  // aiProcess_ValidateDataStructure: a face index beyond its mesh's vertices (an ascii PLY
  // that says "3 0 1 7" with three vertices) fails the import instead of being read out of
  // bounds; the error names the file.
  const auto refuse = [&] {
    const std::string reason = importer.GetErrorString();
    throw ConfigError(path, "cannot read the mesh: " + (reason.empty() ? std::string("incomplete scene") : reason));
  };
  const aiScene* scene = importer.ReadFile(path, aiProcess_ValidateDataStructure);
  if (!scene || !scene->mRootNode || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE)) refuse();
  // assimp's triangulation asserts on a face without indices, and Debian's assimp keeps its
  // asserts: abort(), the node gone without a word (fuzz_mesh_ply: a PLY whose vertex count is
  // short makes the reader take vertex lines for faces, "0 1 0" a face of none). Such a face is
  // refused here, before the post-processing ReadFile would otherwise run in the same call.
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
  {
    const aiMesh& mesh = *scene->mMeshes[m];
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
      if (mesh.mFaces[f].mNumIndices == 0)
        throw ConfigError(path, "mesh " + std::to_string(m) + " (" + mesh.mName.C_Str() + "), face " +
                                    std::to_string(f) + ": a face without vertex indices");
  }
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_SortByPType);
  if (!scene || !scene->mRootNode) refuse();

  Soup soup;
  collect(*scene, *scene->mRootNode, Eigen::Matrix4d::Identity(), path, soup);
  if (soup.triangles.empty())
    throw ConfigError(path,
                      soup.dropped_primitives > 0 ? "has no triangles (only points or lines)" : "has no triangles");
  for (auto& v : soup.vertices) v = v.cwiseProduct(scale);

  // Join by position: STL repeats every corner per face (with the face normal, so assimp's own
  // joining keeps them apart), and separate meshes of one file may meet along an edge.
  const AxisBox bounds = boundsOf(soup.vertices);
  const double diagonal = (bounds.max - bounds.min).norm();
  MeshFile out;
  if (!(diagonal > 0.0)) throw ConfigError(path, "all vertices coincide: the mesh has no extent (scale zero?)");
  const std::vector<int> map = joinVertices(soup.vertices, 1e-7 * diagonal, out.mesh.vertices);
  const bool flip = scale.prod() < 0.0;
  for (const auto& t : soup.triangles)
  {
    std::array<int, 3> j = {map[t[0]], map[t[1]], map[t[2]]};
    if (j[0] == j[1] || j[1] == j[2] || j[2] == j[0])
    {
      ++out.degenerate_triangles;
      continue;
    }
    if (flip) std::swap(j[1], j[2]);
    if (zeroArea(out.mesh.vertices[j[0]], out.mesh.vertices[j[1]], out.mesh.vertices[j[2]])) ++out.degenerate_triangles;
    out.mesh.triangles.push_back(j);
  }
  if (out.degenerate_triangles >= soup.triangles.size())
    throw ConfigError(path, "all " + std::to_string(soup.triangles.size()) + " triangles have zero area");
  out.closed = orientOutward(out.mesh);
  out.border_edges = out.closed ? 0 : borderEdges(out.mesh);
  buildInsideIndex(out.mesh);
  return out;
}

TriangleMesh boxMesh(const Vec3d& size)
{
  TriangleMesh m;
  const Vec3d h = 0.5 * size;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  // Faces -z, +z, -y, +y, -x, +x, each wound counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces)
  {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

TriangleMesh cylinderMesh(double radius, double length, double max_error)
{
  const int n = segmentsFor(radius, max_error);
  const double rv = balancedRadius(radius, std::cos(M_PI / n));
  TriangleMesh m;
  for (int z = 0; z < 2; ++z)
    for (int j = 0; j < n; ++j)
    {
      const double phi = 2.0 * M_PI * j / n;
      m.vertices.emplace_back(rv * std::cos(phi), rv * std::sin(phi), z ? 0.5 * length : -0.5 * length);
    }
  const int bottom = static_cast<int>(m.vertices.size());
  m.vertices.emplace_back(0.0, 0.0, -0.5 * length);
  m.vertices.emplace_back(0.0, 0.0, 0.5 * length);
  for (int j = 0; j < n; ++j)
  {
    const int a = j, b = (j + 1) % n;
    m.triangles.push_back({a, b, b + n});
    m.triangles.push_back({a, b + n, a + n});
    m.triangles.push_back({bottom, b, a});
    m.triangles.push_back({bottom + 1, a + n, b + n});
  }
  return m;
}

TriangleMesh sphereMesh(double radius, double max_error)
{
  // Latitude-longitude sphere whose angular steps keep the facets within max_error, then scaled so
  // that the vertices lie as far outside the sphere as the facet centres lie inside.
  int n_lon = std::max(8, segmentsFor(radius, 0.5 * max_error));
  for (;;)
  {
    const int n_lat = std::max(4, (n_lon + 1) / 2);
    TriangleMesh m;
    m.vertices.emplace_back(0.0, 0.0, 1.0);
    for (int i = 1; i < n_lat; ++i)
    {
      const double theta = M_PI * i / n_lat;
      for (int j = 0; j < n_lon; ++j)
      {
        const double phi = 2.0 * M_PI * j / n_lon;
        m.vertices.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      }
    }
    const int south = static_cast<int>(m.vertices.size());
    m.vertices.emplace_back(0.0, 0.0, -1.0);
    const auto ring = [&](int i, int j) { return 1 + i * n_lon + (j % n_lon); };
    for (int j = 0; j < n_lon; ++j) m.triangles.push_back({0, ring(0, j), ring(0, j + 1)});
    for (int i = 0; i + 1 < n_lat - 1; ++i)
      for (int j = 0; j < n_lon; ++j)
      {
        m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
        m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
      }
    for (int j = 0; j < n_lon; ++j) m.triangles.push_back({south, ring(n_lat - 2, j + 1), ring(n_lat - 2, j)});
    // Nearest approach of each facet's plane to the centre (unit sphere): a lower bound on the
    // facet's distance, reached at its foot point or beyond.
    double c = 1.0;
    for (const auto& t : m.triangles)
    {
      const Vec3d& a = m.vertices[t[0]];
      const Vec3d nrm = (m.vertices[t[1]] - a).cross(m.vertices[t[2]] - a).normalized();
      c = std::min(c, std::abs(nrm.dot(a)));
    }
    const double rv = balancedRadius(radius, c);
    if (rv - radius <= max_error || n_lon >= kMaxSegments)
    {
      for (auto& v : m.vertices) v *= rv;
      return m;
    }
    n_lon = std::min(kMaxSegments, int(n_lon * 1.2) + 1);
  }
}

std::vector<std::string> surfaceNotes(const std::string& what, bool closed, std::size_t border_edges,
                                      std::size_t degenerate_triangles)
{
  std::vector<std::string> notes;
  if (degenerate_triangles > 0)
    notes.push_back(what + ": " + std::to_string(degenerate_triangles) +
                    " degenerate (zero-area) triangles, skipped when sampling");
  if (!closed)
    notes.push_back(what + ": not a closed surface (" +
                    (border_edges > 0 ? std::to_string(border_edges) + " border edges"
                                      : std::string("no border edge, but edges where more than two triangles meet "
                                                    "are not wound consistently")) +
                    "): sampled on the surface as a thin shell; fluid inside it is not removed");
  return notes;
}

void appendMesh(TriangleMesh& mesh, const TriangleMesh& part, const Pose& pose)
{
  const int first = static_cast<int>(mesh.vertices.size());
  for (const auto& v : part.vertices) mesh.vertices.push_back(pose.apply(v));
  for (const auto& t : part.triangles) mesh.triangles.push_back({t[0] + first, t[1] + first, t[2] + first});
}

}  // namespace io
}  // namespace fluid_sim
