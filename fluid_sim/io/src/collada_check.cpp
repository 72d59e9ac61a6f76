#include "fluid_sim/io/collada_check.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
namespace io
{
namespace
{
using Count = std::uint64_t;
constexpr Count kHuge = std::numeric_limits<Count>::max();

/// a * b, saturating: counts come from the file and may be anything.
Count times(Count a, Count b)
{
  return (a != 0 && b > kHuge / a) ? kHuge : a * b;
}
Count plus(Count a, Count b)
{
  return b > kHuge - a ? kHuge : a + b;
}

/// Splits on the whitespace assimp skips between values (space, tab, line ends); anything else,
/// '\f' or '\v' included, stays in a token and fails the number checks.
void forEachToken(std::string_view text, const std::function<void(std::string_view)>& visit)
{
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  std::size_t i = 0;
  while (i < text.size())
  {
    while (i < text.size() && space(text[i])) ++i;
    const std::size_t start = i;
    while (i < text.size() && !space(text[i])) ++i;
    if (i > start) visit(text.substr(start, i - start));
  }
}

bool isInteger(std::string_view token, bool allow_minus, long long max_value)
{
  // from_chars reads a leading '-' itself (not a '+'), so a minus is refused here unless allowed.
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  if (token.empty() || (!allow_minus && token[0] == '-')) return false;
  long long value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size() && value <= max_value && value >= -max_value;
}

bool isReal(std::string_view token)
{
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  // Out of range (1e999) is a number too: assimp reads it as infinite and the loader refuses it
  // with the vertex it belongs to.
  return (ec == std::errc() || ec == std::errc::result_out_of_range) && end == token.data() + token.size() &&
         !token.empty();
}

/// The text assimp reads from an element: its first text (or CDATA) child, as pugixml's text().
std::string_view textOf(const tinyxml2::XMLElement& element)
{
  for (const tinyxml2::XMLNode* child = element.FirstChild(); child; child = child->NextSibling())
    if (const tinyxml2::XMLText* text = child->ToText()) return text->Value() ? text->Value() : "";
  return "";
}

std::vector<const tinyxml2::XMLElement*> children(const tinyxml2::XMLElement& element, const char* name)
{
  std::vector<const tinyxml2::XMLElement*> out;
  for (const tinyxml2::XMLElement* c = element.FirstChildElement(name); c; c = c->NextSiblingElement(name))
    out.push_back(c);
  return out;
}

class Checker
{
public:
  Checker(const std::string& path) : path_(path) {}

  void run(const tinyxml2::XMLElement& root)
  {
    // Iterative walk (tinyxml2 has already refused nesting deeper than its limit).
    std::vector<const tinyxml2::XMLElement*> stack = {&root};
    std::vector<const tinyxml2::XMLElement*> accessors, primitives, weights;
    while (!stack.empty())
    {
      const tinyxml2::XMLElement* e = stack.back();
      stack.pop_back();
      const std::string_view name = e->Name();
      if (name.size() > 6 && name.substr(name.size() - 6) == "_array")
        checkArray(*e);
      else if (name == "accessor")
        accessors.push_back(e);
      else if (name == "triangles" || name == "polylist" || name == "polygons" || name == "lines" ||
               name == "linestrips" || name == "trifans" || name == "tristrips")
        primitives.push_back(e);
      else if (name == "vertex_weights")
        weights.push_back(e);
      for (const tinyxml2::XMLElement* c = e->LastChildElement(); c; c = c->PreviousSiblingElement())
        stack.push_back(c);
    }
    for (const auto* e : accessors) checkAccessor(*e);
    for (const auto* e : primitives) checkPrimitive(*e);
    for (const auto* e : weights) checkVertexWeights(*e);
  }

private:
  [[noreturn]] void fail(const tinyxml2::XMLElement& e, const std::string& what) const
  {
    throw ConfigError(
        path_, "COLLADA <" + std::string(e.Name()) + "> on line " + std::to_string(e.GetLineNum()) + ": " + what);
  }

  /// An unsigned attribute; `fallback` if absent (assimp's default).
  Count attribute(const tinyxml2::XMLElement& e, const char* name, Count fallback) const
  {
    const char* raw = e.Attribute(name);
    if (!raw) return fallback;
    std::string_view text = raw;
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
    Count value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || end != text.data() + text.size() || (ec != std::errc() && ec != std::errc::result_out_of_range))
      fail(e, std::string(name) + "=\"" + raw + "\" is not a whole number");
    return ec == std::errc::result_out_of_range ? kHuge : value;
  }

  void checkArray(const tinyxml2::XMLElement& e)
  {
    const std::string_view name = e.Name();
    const bool floats = name == "float_array", ints = name == "int_array";
    Count values = 0;
    forEachToken(textOf(e), [&](std::string_view token) {
      ++values;
      if ((floats && !isReal(token)) || (ints && !isInteger(token, true, std::numeric_limits<long long>::max())))
        fail(e, "'" + std::string(token) + "' is not " + (floats ? "a number" : "a whole number"));
    });
    const Count count = attribute(e, "count", 0);
    if (e.Attribute("count") && count != values)
      fail(e,
           "count=\"" + std::string(e.Attribute("count")) + "\", but it holds " + std::to_string(values) + " values");
    if (const char* id = e.Attribute("id")) array_sizes_[id] = count;
  }

  void checkAccessor(const tinyxml2::XMLElement& e)
  {
    const char* source = e.Attribute("source");
    if (!source || source[0] != '#') return;  // not an array of this file: assimp's business
    const auto it = array_sizes_.find(source + 1);
    if (it == array_sizes_.end()) return;
    const Count count = attribute(e, "count", 0), stride = attribute(e, "stride", 1),
                offset = attribute(e, "offset", 0);
    if (count == 0) return;
    Count params = 0;
    for (const auto* p : children(e, "param"))
    {
      const char* type = p->Attribute("type");
      params += (type && std::string_view(type) == "float4x4") ? 16 : 1;
    }
    const Count needed = plus(plus(offset, times(count - 1, stride)), params);
    if (needed > it->second)
      fail(e, "count " + std::to_string(count) + ", stride " + std::to_string(stride) + ", offset " +
                  std::to_string(offset) + " and " + std::to_string(params) + " params read " +
                  (needed == kHuge ? std::string("more than 2^64") : std::to_string(needed)) + " values of '" +
                  (source + 1) + "', which holds " + std::to_string(it->second));
  }

  /// Number of index tokens in `e`, each checked to be an index (or, with `allow_minus`, any
  /// whole number: a skin's <v> names joint -1, the bind shape).
  Count indices(const tinyxml2::XMLElement& e, const char* what, bool allow_minus = false) const
  {
    Count n = 0;
    forEachToken(textOf(e), [&](std::string_view token) {
      ++n;
      if (!isInteger(token, allow_minus, std::numeric_limits<std::int32_t>::max()))
        fail(e, "'" + std::string(token) + "' is not " + what + " (a whole number" + (allow_minus ? "" : " from 0") +
                    " up to 2147483647)");
    });
    return n;
  }

  /// 1 + the largest <input offset> among `e`'s inputs: how many indices make one vertex.
  Count inputsPerVertex(const tinyxml2::XMLElement& e) const
  {
    Count n = 1;
    for (const auto* input : children(e, "input")) n = std::max(n, plus(attribute(*input, "offset", 0), 1));
    return n;
  }

  void checkPrimitive(const tinyxml2::XMLElement& e)
  {
    const std::string_view name = e.Name();
    const Count count = attribute(e, "count", 0);
    const Count per_vertex = inputsPerVertex(e);
    Count total = 0;
    std::vector<Count> lengths;  // per <p> or <ph>
    for (const tinyxml2::XMLElement* c = e.FirstChildElement(); c; c = c->NextSiblingElement())
    {
      const std::string_view child = c->Name();
      if (child == "p")
        lengths.push_back(indices(*c, "an index"));
      else if (child == "ph")
      {
        Count n = 0;
        for (const tinyxml2::XMLElement* g = c->FirstChildElement(); g; g = g->NextSiblingElement())
          if (std::string_view(g->Name()) == "p" || std::string_view(g->Name()) == "h")
            n = plus(n, indices(*g, "an index"));
        lengths.push_back(n);
      }
      else
        continue;
      total = plus(total, lengths.back());
    }
    const std::string announced = "count=\"" + std::to_string(count) + "\" with " + std::to_string(per_vertex) +
                                  (per_vertex == 1 ? " index" : " indices") + " per vertex";
    if (per_vertex > std::max<Count>(total, 1))
      fail(e, "an <input> offset of " + std::to_string(per_vertex - 1) + " is beyond its " + std::to_string(total) +
                  " indices");
    if (name == "triangles")
    {
      const Count needed = times(times(count, 3), per_vertex);
      if (needed != total)
        fail(e, announced + " needs " + std::to_string(needed) + " indices, its <p> holds " + std::to_string(total));
    }
    else if (name == "polylist")
    {
      const auto vcounts = children(e, "vcount");
      Count polygons = 0, corners = 0;
      for (const auto* v : vcounts)
        forEachToken(textOf(*v), [&](std::string_view token) {
          ++polygons;
          if (!isInteger(token, false, std::numeric_limits<std::int32_t>::max()))
            fail(*v, "'" + std::string(token) + "' is not a number of corners (a whole number from 0)");
          Count k = 0;
          std::from_chars(token.data() + (token[0] == '+'), token.data() + token.size(), k);
          corners = plus(corners, k);
        });
      if (polygons != count)
        fail(e, "count=\"" + std::to_string(count) + "\", but its <vcount> holds " + std::to_string(polygons) +
                    " polygons");
      const Count needed = times(corners, per_vertex);
      if (needed != total)
        fail(e, "its <vcount> adds up to " + std::to_string(corners) + " corners with " + std::to_string(per_vertex) +
                    " indices each: " + std::to_string(needed) + " indices, its <p> holds " + std::to_string(total));
    }
    else if (name == "polygons")
    {
      if (lengths.size() != count)
        fail(e, "count=\"" + std::to_string(count) + "\", but it has " + std::to_string(lengths.size()) +
                    " <p> and <ph> elements");
      for (std::size_t k = 0; k < lengths.size(); ++k)
        if (lengths[k] % per_vertex != 0)
          fail(e, "polygon " + std::to_string(k) + " has " + std::to_string(lengths[k]) +
                      " indices, not a multiple of " + std::to_string(per_vertex) + " per vertex");
    }
    else if (count > total)
    {
      // Lines and strips: assimp tolerates a wrong count here (SketchUp writes one), but reserves
      // room for it; a primitive has at least one index.
      fail(e, announced + " is more primitives than its " + std::to_string(total) + " indices");
    }
  }

  void checkVertexWeights(const tinyxml2::XMLElement& e)
  {
    const Count count = attribute(e, "count", 0);
    const Count per_weight = inputsPerVertex(e);
    Count vertices = 0, weights = 0;
    for (const auto* v : children(e, "vcount"))
      forEachToken(textOf(*v), [&](std::string_view token) {
        ++vertices;
        if (!isInteger(token, false, std::numeric_limits<std::int32_t>::max()))
          fail(*v, "'" + std::string(token) + "' is not a number of weights (a whole number from 0)");
        Count k = 0;
        std::from_chars(token.data() + (token[0] == '+'), token.data() + token.size(), k);
        weights = plus(weights, k);
      });
    if (vertices != count)
      fail(e,
           "count=\"" + std::to_string(count) + "\", but its <vcount> holds " + std::to_string(vertices) + " values");
    Count total = 0;
    for (const auto* v : children(e, "v")) total = plus(total, indices(*v, "an index", true));
    const Count needed = times(weights, per_weight);
    if (needed != total)
      fail(e, "its <vcount> adds up to " + std::to_string(weights) + " weights with " + std::to_string(per_weight) +
                  " indices each: " + std::to_string(needed) + " indices, its <v> holds " + std::to_string(total));
  }

  const std::string& path_;
  std::unordered_map<std::string, Count> array_sizes_;  // id -> the values assimp reads (its count)
};

std::string lowerCase(std::string text)
{
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}
}  // namespace

bool looksLikeCollada(const std::string& path)
{
  const auto dot = path.find_last_of("./");
  const std::string ext = (dot != std::string::npos && path[dot] == '.') ? lowerCase(path.substr(dot)) : "";
  if (ext == ".dae") return true;
  if (ext == ".zae") return false;  // zipped COLLADA: assimp unpacks it itself (not checked)
  // assimp also picks its COLLADA importer by content (e.g. for ".xml").
  std::ifstream in(path, std::ios::binary);
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return lowerCase(head).find("<collada") != std::string::npos;
}

void checkColladaText(const std::string& path, const std::string& text)
{
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
    throw ConfigError(path,
                      "not well-formed XML (line " + std::to_string(doc.ErrorLineNum()) + ": " + doc.ErrorName() + ")");
  if (!doc.RootElement()) throw ConfigError(path, "no XML element");
  // Every top-level element, not only the first: tinyxml2 accepts several, and assimp looks for
  // <COLLADA> among them (a stray element before it hid a '#' in <p> from this check; assimp then
  // asked for 2.4 GB).
  Checker checker(path);
  for (const tinyxml2::XMLElement* e = doc.FirstChildElement(); e; e = e->NextSiblingElement()) checker.run(*e);
}

}  // namespace io
}  // namespace fluid_sim
