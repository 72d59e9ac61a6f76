// Reading particle frames back (see ply_reader.h): the header first, checked line by line, then
// the binary or ascii data, checked against the vertex count it announces.

#include "fluid_sim/io/ply_reader.h"

#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "fluid_sim/io/file_util.h"

namespace fluid_sim
{
namespace io
{
namespace
{
/// The properties a frame needs, in the order they fill PlyFrame: position then velocity.
constexpr std::array<const char*, 6> kNeeded = {"x", "y", "z", "vx", "vy", "vz"};

enum class Format
{
  Ascii,
  BinaryLittleEndian
};

struct Property
{
  std::string type;
  std::string name;
  std::size_t size = 0;    // bytes in binary data
  std::size_t offset = 0;  // bytes from the start of a vertex in binary data
};

struct Header
{
  Format format = Format::Ascii;
  std::size_t count = 0;  // vertices
  std::vector<Property> properties;
  std::size_t stride = 0;               // bytes per vertex in binary data
  std::size_t data_offset = 0;          // first byte after end_header
  std::array<std::size_t, 6> needed{};  // index into properties of each of kNeeded
  std::size_t lines = 0;                // header lines, for ascii data line numbers
};

/// Bytes of a PLY scalar type, 0 for an unknown name (PLY 1.0 names and their sized aliases).
std::size_t scalarSize(const std::string& type)
{
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32") return 4;
  if (type == "float" || type == "float32") return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

bool isFloating(const std::string& type)
{
  return type == "float" || type == "float32" || type == "double" || type == "float64";
}

std::vector<std::string> splitWords(const std::string& line)
{
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

/// A whole decimal number without sign, or false (also beyond 10^12, far more than any frame).
bool parseCount(const std::string& text, std::size_t& out)
{
  if (text.empty() || text.size() > 12) return false;
  out = 0;
  for (char c : text)
  {
    if (c < '0' || c > '9') return false;
    out = out * 10 + std::size_t(c - '0');
  }
  return true;
}

Header parseHeader(const std::string& data, const std::string& path)
{
  Header h;
  std::size_t pos = 0;
  bool have_format = false, have_vertex = false, ended = false;
  while (!ended)
  {
    const std::size_t eol = data.find('\n', pos);
    if (eol == std::string::npos)
      throw ConfigError(path, h.lines == 0 ? "empty file, not a PLY frame"
                                           : "the header has no end_header line (a truncated or not a PLY file)");
    std::string line = data.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();  // a file written on Windows
    pos = eol + 1;
    ++h.lines;
    const std::string at = "header line " + std::to_string(h.lines) + ": ";
    if (h.lines == 1)
    {
      if (line != "ply") throw ConfigError(path, "not a PLY file (the first line is not 'ply')");
      continue;
    }
    const std::vector<std::string> w = splitWords(line);
    if (w.empty()) throw ConfigError(path, at + "empty line");
    const std::string& keyword = w[0];
    if (keyword == "comment" || keyword == "obj_info") continue;  // free text, e.g. units
    if (keyword == "format")
    {
      if (have_format) throw ConfigError(path, at + "a second format line");
      if (w.size() != 3 || w[2] != "1.0")
        throw ConfigError(path, at + "expected 'format <kind> 1.0', got '" + line + "'");
      if (w[1] == "ascii")
        h.format = Format::Ascii;
      else if (w[1] == "binary_little_endian")
        h.format = Format::BinaryLittleEndian;
      else
        throw ConfigError(
            path, at + "format '" + w[1] + "' is not supported (binary_little_endian, as the runner writes, or ascii)");
      have_format = true;
    }
    else if (keyword == "element")
    {
      if (w.size() != 3) throw ConfigError(path, at + "expected 'element <name> <count>', got '" + line + "'");
      if (w[1] != "vertex")
        throw ConfigError(path, at + "element '" + w[1] + "': a particle frame has one element, vertex, and no other");
      if (have_vertex) throw ConfigError(path, at + "a second element vertex");
      if (!parseCount(w[2], h.count))
        throw ConfigError(path, at + "the vertex count '" + w[2] + "' is not a whole number >= 0");
      have_vertex = true;
    }
    else if (keyword == "property")
    {
      if (!have_vertex) throw ConfigError(path, at + "a property before any element");
      if (w.size() >= 2 && w[1] == "list")
        throw ConfigError(path, at + "list property '" + w.back() + "': a particle frame has scalar properties only");
      if (w.size() != 3) throw ConfigError(path, at + "expected 'property <type> <name>', got '" + line + "'");
      Property p;
      p.type = w[1];
      p.name = w[2];
      p.size = scalarSize(p.type);
      if (p.size == 0) throw ConfigError(path, at + "property '" + p.name + "' has an unknown type '" + p.type + "'");
      for (const Property& q : h.properties)
        if (q.name == p.name) throw ConfigError(path, at + "property '" + p.name + "' is declared twice");
      p.offset = h.stride;
      h.stride += p.size;
      h.properties.push_back(p);
    }
    else if (keyword == "end_header")
    {
      if (w.size() != 1) throw ConfigError(path, at + "expected 'end_header', got '" + line + "'");
      ended = true;
    }
    else
    {
      throw ConfigError(path, at + "unknown keyword '" + keyword + "'");
    }
  }
  h.data_offset = pos;
  if (!have_format) throw ConfigError(path, "the header has no format line");
  if (!have_vertex) throw ConfigError(path, "the header has no element vertex");
  for (std::size_t k = 0; k < kNeeded.size(); ++k)
  {
    std::size_t found = h.properties.size();
    for (std::size_t j = 0; j < h.properties.size(); ++j)
      if (h.properties[j].name == kNeeded[k]) found = j;
    if (found == h.properties.size())
      throw ConfigError(path, std::string("the vertex element has no property '") + kNeeded[k] +
                                  "' (a particle frame needs x y z vx vy vz)");
    if (!isFloating(h.properties[found].type))
      throw ConfigError(path, std::string("property '") + kNeeded[k] + "' is of type '" + h.properties[found].type +
                                  "'; expected float (or double)");
    h.needed[k] = found;
  }
  return h;
}

/// "1 byte", "n bytes".
std::string bytes(std::size_t n)
{
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

/// A little-endian float32 or float64 at p, whatever the host's byte order.
double readLittleEndian(const char* p, std::size_t size)
{
  std::uint64_t bits = 0;
  for (std::size_t k = 0; k < size; ++k) bits |= std::uint64_t(static_cast<unsigned char>(p[k])) << (8 * k);
  if (size == 4)
  {
    const auto b32 = static_cast<std::uint32_t>(bits);
    float f;
    std::memcpy(&f, &b32, sizeof f);
    return f;
  }
  double d;
  std::memcpy(&d, &bits, sizeof d);
  return d;
}

/// Sets value k (in the order of kNeeded) of vertex i.
void setValue(PlyFrame& frame, std::size_t i, std::size_t k, double value)
{
  if (k < 3)
    frame.positions[i][k] = value;
  else
    frame.velocities[i][k - 3] = value;
}

/// The needed values of every vertex from binary data.
void readBinary(const std::string& data, const Header& h, const std::string& path, PlyFrame& frame)
{
  const std::size_t available = data.size() - h.data_offset;  // bytes
  if (h.count > available / h.stride)
    throw ConfigError(path, "truncated: the header announces " + std::to_string(h.count) + " vertices of " +
                                bytes(h.stride) + ", the file has " + bytes(available) + " of data (" +
                                std::to_string(available / h.stride) + " whole vertices)");
  if (available != h.count * h.stride)
    throw ConfigError(path, bytes(available - h.count * h.stride) + " after the " + std::to_string(h.count) +
                                " vertices the header announces: the vertex count does not match the data");
  frame.positions.resize(h.count);
  frame.velocities.resize(h.count);
  const char* base = data.data() + h.data_offset;
  for (std::size_t i = 0; i < h.count; ++i)
    for (std::size_t k = 0; k < kNeeded.size(); ++k)
    {
      const Property& p = h.properties[h.needed[k]];
      setValue(frame, i, k, readLittleEndian(base + i * h.stride + p.offset, p.size));
    }
}

/// The same from ascii data: one vertex per line, as many numbers as properties.
void readAscii(const std::string& data, const Header& h, const std::string& path, PlyFrame& frame)
{
  std::size_t pos = h.data_offset, line_number = h.lines;
  // Each value takes at least two characters (a digit and a separator; the last may lack its
  // newline): a count beyond that is refused before anything is allocated for it.
  const std::size_t available = data.size() - h.data_offset;  // bytes
  if (h.count > (available + 1) / (2 * h.properties.size()))
    throw ConfigError(path, "truncated: the header announces " + std::to_string(h.count) + " vertices of " +
                                std::to_string(h.properties.size()) + " values, the data has only " +
                                std::to_string(available) + " characters");
  frame.positions.resize(h.count);
  frame.velocities.resize(h.count);
  std::vector<double> values(h.properties.size());
  for (std::size_t i = 0; i < h.count; ++i)
  {
    if (pos >= data.size())
      throw ConfigError(path, "truncated: the data ends after " + std::to_string(i) + " of the " +
                                  std::to_string(h.count) + " vertices the header announces");
    std::size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) eol = data.size();
    const std::vector<std::string> w = splitWords(data.substr(pos, eol - pos));
    pos = eol + 1;
    ++line_number;
    const std::string at = "vertex " + std::to_string(i) + " (line " + std::to_string(line_number) + "): ";
    if (w.size() != h.properties.size())
      throw ConfigError(path, at + std::to_string(w.size()) + " values, the header declares " +
                                  std::to_string(h.properties.size()) + " properties");
    for (std::size_t j = 0; j < w.size(); ++j)
    {
      // strtod reads "nan" and "inf" too: the finiteness check names them with their vertex.
      char* end = nullptr;
      values[j] = std::strtod(w[j].c_str(), &end);
      if (end != w[j].c_str() + w[j].size())
        throw ConfigError(path, at + "'" + w[j] + "' is not a number (property '" + h.properties[j].name + "')");
    }
    for (std::size_t k = 0; k < kNeeded.size(); ++k) setValue(frame, i, k, values[h.needed[k]]);
  }
  for (; pos < data.size(); ++pos)
    if (!std::isspace(static_cast<unsigned char>(data[pos])))
      throw ConfigError(path, "more data after the " + std::to_string(h.count) +
                                  " vertices the header announces: the vertex count does not match the data");
}

}  // namespace

namespace
{
/// One property of a mesh PLY's element: a scalar, or a list with its count's type.
struct MeshProperty
{
  std::string name;
  bool list = false;
  std::string count_type;  // a list's
  std::string type;        // the scalar's, or the list items'
};
struct MeshElement
{
  std::string name;
  std::size_t count = 0;
  std::vector<MeshProperty> properties;
};

/// A PLY element or property name: a letter or '_' first, then letters, digits, '_' or '-'.
bool isPlyName(const std::string& name)
{
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_')) return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) return false;
  return true;
}

/// Largest value an integer PLY type holds (the signed ones' positive range).
std::uint64_t integerMax(const std::string& type)
{
  const std::size_t bytes = scalarSize(type);
  const bool is_signed =
      type == "char" || type == "int8" || type == "short" || type == "int16" || type == "int" || type == "int32";
  return bytes >= 8 ? ~std::uint64_t(0) : ((std::uint64_t(1) << (8 * bytes - (is_signed ? 1 : 0))) - 1);
}

/// Reads an unsigned integer of `bytes` bytes at `p`, in the file's byte order.
std::uint64_t readUnsigned(const char* p, std::size_t bytes, bool big_endian)
{
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < bytes; ++k)
  {
    const std::size_t i = big_endian ? k : bytes - 1 - k;
    v = (v << 8) | static_cast<unsigned char>(p[i]);
  }
  return v;
}

/// Walks a mesh PLY's data as its header declares it, so that no list asks for more entries than
/// its count type holds or the file has left: assimp allocates a list's count before it reads it
/// (a face whose ASCII count was 4294967295 asked for 32 GB).
void checkPlyMeshBody(const std::string& path, const std::string& data, std::size_t pos, const std::string& format,
                      const std::vector<MeshElement>& elements)
{
  if (format == "ascii")
  {
    std::size_t line_no = 0;
    for (const MeshElement& e : elements)
      for (std::size_t n = 0; n < e.count; ++n)
      {
        if (pos >= data.size())
          throw ConfigError(path, "PLY data ends in element '" + e.name + "' at instance " + std::to_string(n) +
                                      " of " + std::to_string(e.count) +
                                      " (the header declares more than the file holds)");
        std::size_t eol = data.find('\n', pos);
        if (eol == std::string::npos) eol = data.size();
        const std::vector<std::string> w = splitWords(data.substr(pos, eol - pos));
        pos = eol + 1;
        ++line_no;
        const std::string at = "PLY data line " + std::to_string(line_no) + " (element '" + e.name + "'): ";
        std::size_t k = 0;  // next word
        for (const MeshProperty& p : e.properties)
        {
          if (k >= w.size()) throw ConfigError(path, at + "no value for property '" + p.name + "'");
          if (!p.list)
          {
            ++k;
            continue;
          }
          std::size_t count = 0;
          if (!parseCount(w[k], count))
            throw ConfigError(path, at + "list '" + p.name + "' has the count '" + w[k] + "', not a whole number");
          if (count > integerMax(p.count_type) || count > w.size() - k - 1)
            throw ConfigError(path, at + "list '" + p.name + "' has the count " + w[k] + ", above its count type '" +
                                        p.count_type + "' or the " + std::to_string(w.size() - k - 1) +
                                        " values on the line");
          k += 1 + count;
        }
      }
    return;
  }
  const bool big = format == "binary_big_endian";
  for (const MeshElement& e : elements)
    for (std::size_t n = 0; n < e.count; ++n)
      for (const MeshProperty& p : e.properties)
      {
        const std::size_t left = data.size() - std::min(pos, data.size());
        const std::string at =
            "PLY element '" + e.name + "' instance " + std::to_string(n) + ", property '" + p.name + "': ";
        if (!p.list)
        {
          if (left < scalarSize(p.type)) throw ConfigError(path, at + "the file ends (truncated)");
          pos += scalarSize(p.type);
          continue;
        }
        const std::size_t count_bytes = scalarSize(p.count_type);
        if (left < count_bytes) throw ConfigError(path, at + "the file ends (truncated)");
        const std::uint64_t count = readUnsigned(data.data() + pos, count_bytes, big);
        pos += count_bytes;
        const std::uint64_t need = count * scalarSize(p.type);  // count < 2^32, size <= 8: no overflow
        if (need > left - count_bytes)
          throw ConfigError(path, at + "a list of " + std::to_string(count) + " entries, more than the " +
                                      std::to_string(left - count_bytes) + " bytes left in the file");
        pos += std::size_t(need);
      }
}
}  // namespace

void checkPlyMeshHeader(const std::string& path, const std::string& data)
{
  // The header, then the data walked as the header declares it (checkPlyMeshBody); the values
  // themselves (indices in range, finite coordinates) are assimp's and the mesh checks'.
  std::size_t pos = 0, lines = 0;
  bool have_format = false, have_element = false;
  std::string format;
  std::vector<MeshElement> elements;
  while (true)
  {
    const std::size_t eol = data.find('\n', pos);
    if (eol == std::string::npos)
      throw ConfigError(path, lines == 0 ? "empty file, not a PLY mesh"
                                         : "the PLY header has no end_header line (a truncated or not a PLY file)");
    std::string line = data.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = eol + 1;
    ++lines;
    const std::string at = "PLY header line " + std::to_string(lines) + ": ";
    if (lines == 1)
    {
      if (line != "ply") throw ConfigError(path, "not a PLY file (the first line is not 'ply')");
      continue;
    }
    const std::vector<std::string> w = splitWords(line);
    if (w.empty()) throw ConfigError(path, at + "empty line");
    const std::string& keyword = w[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format")
    {
      if (have_format || have_element) throw ConfigError(path, at + "a format line after the first line or element");
      if (w.size() != 3 || w[2] != "1.0" ||
          (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian"))
        throw ConfigError(
            path, at + "expected 'format ascii|binary_little_endian|binary_big_endian 1.0', got '" + line + "'");
      have_format = true;
      format = w[1];
    }
    else if (keyword == "element")
    {
      std::size_t count = 0;
      if (w.size() != 3 || !parseCount(w[2], count))
        throw ConfigError(path, at + "expected 'element <name> <count>' with a whole count, got '" + line + "'");
      // assimp reads a name that starts with a digit as a count (an element '4294967295face'
      // asked for 96 GB, fuzz_mesh_ply): names are identifiers.
      if (!isPlyName(w[1])) throw ConfigError(path, at + "element name '" + w[1] + "' is not a name (a letter first)");
      have_element = true;
      elements.push_back({w[1], count, {}});
    }
    else if (keyword == "property")
    {
      if (!have_element) throw ConfigError(path, at + "a property before any element");
      const bool list = w.size() >= 2 && w[1] == "list";
      if (list ? w.size() != 5 : w.size() != 3)
        throw ConfigError(
            path,
            at + "expected 'property <type> <name>' or 'property list <count type> <type> <name>', got '" + line + "'");
      if (list && (scalarSize(w[2]) == 0 || isFloating(w[2])))
        throw ConfigError(path, at + "list count type '" + w[2] + "' is not an integer type");
      if (scalarSize(w[list ? 3 : 1]) == 0) throw ConfigError(path, at + "unknown type '" + w[list ? 3 : 1] + "'");
      if (!isPlyName(w.back()))
        throw ConfigError(path, at + "property name '" + w.back() + "' is not a name (a letter first)");
      elements.back().properties.push_back(list ? MeshProperty{w[4], true, w[2], w[3]}
                                                : MeshProperty{w[2], false, std::string(), w[1]});
    }
    else if (keyword == "end_header")
    {
      if (w.size() != 1) throw ConfigError(path, at + "expected 'end_header', got '" + line + "'");
      break;
    }
    else
    {
      throw ConfigError(path, at + "unknown keyword '" + keyword + "'");
    }
  }
  if (!have_format) throw ConfigError(path, "the PLY header has no format line");
  if (!have_element) throw ConfigError(path, "the PLY header declares no element");
  checkPlyMeshBody(path, data, pos, format, elements);
}

PlyFrame readPlyFrame(const std::string& path)
{
  const std::string data = readTextFile(path, "PLY file");
  const Header h = parseHeader(data, path);
  PlyFrame frame;
  if (h.format == Format::Ascii)
    readAscii(data, h, path, frame);
  else
    readBinary(data, h, path, frame);
  for (std::size_t i = 0; i < h.count; ++i)
    for (std::size_t k = 0; k < kNeeded.size(); ++k)
    {
      const double value = k < 3 ? frame.positions[i][k] : frame.velocities[i][k - 3];
      if (!std::isfinite(value))
      {
        std::ostringstream text;
        text << value;
        throw ConfigError(path,
                          "vertex " + std::to_string(i) + " has a non-finite " + kNeeded[k] + " (" + text.str() + ")");
      }
    }
  return frame;
}

}  // namespace io
}  // namespace fluid_sim
