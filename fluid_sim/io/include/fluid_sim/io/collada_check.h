#pragma once
// A cheap check of a COLLADA file's numeric arrays before assimp reads it. assimp 5.2's COLLADA
// parser trusts the file's counts and tokens: a token in <p> that is not a whole number makes it
// push zeros without end (18.9 GB, then std::bad_alloc after 96 s, fuzz_mesh_dae), a `count`
// beyond the data is reserved up front, and an <accessor> reaching past its array is read out of
// bounds (a segmentation fault for a huge stride). Checked here, such a file is refused in
// milliseconds with the element and line that are wrong.

#include <string>

namespace fluid_sim
{
namespace io
{
/// Whether assimp may read the file at `path` with its COLLADA importer: a ".dae" extension (any
/// case), or "<collada" (any case) within the file's first 4096 bytes. Not for ".zae" (zipped).
bool looksLikeCollada(const std::string& path);

/// Checks the COLLADA document `text` (the content of the file at `path`); throws
/// ConfigError(path, message naming the element and its line) if
/// - it is not well-formed XML;
/// - a <float_array> or <int_array> holds a token that is not a number (a whole number for
///   int_array), or a <*_array>'s `count` differs from the number of values it holds;
/// - an <accessor> reaches past the array it reads: offset + (count - 1) * stride + params
///   values, with params the number of its <param> children (16 for a float4x4);
/// - a <p>, <h> or <vcount> of a primitive (<triangles>, <polylist>, <polygons>, <lines>,
///   <linestrips>, <trifans>, <tristrips>) holds a token that is not an index (a whole number from
///   0 to 2147483647), or an <input> offset is beyond the primitive's indices;
/// - the indices do not match the announced primitives: count * 3 * inputs for <triangles>,
///   sum(<vcount>) * inputs with `count` <vcount> values for <polylist>, `count` <p>/<ph> elements
///   of whole vertices for <polygons>, at most as many primitives as indices for the others;
/// - a skin's <vertex_weights> has not `count` <vcount> values, or not sum(<vcount>) * inputs
///   whole numbers in <v>.
/// Attributes that are absent keep assimp's defaults (count 0, stride 1, offset 0).
void checkColladaText(const std::string& path, const std::string& text);

}  // namespace io
}  // namespace fluid_sim
