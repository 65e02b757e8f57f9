// Text point files (`.xyz .txt .pts .csv`, as scanners, CloudCompare and spreadsheets write them):
// one point a line, numbers separated by spaces, tabs or commas (runs of them count as one).
// Any thread may call these functions.
//
// Lines: blank lines and lines starting with '#' are skipped; a line of one integer is a point
// count (a `.pts` file starts with one, before each scan) and skipped.
//
// Columns are named, first found first:
//  1. by PointFileOptions::columns (`--columns` of the tools); a header line of the file is then
//     skipped;
//  2. by a header line: the first line that is not blank, a comment or a count, when its first
//     field starts with a letter or '_' (after an optional "//", as CloudCompare writes:
//     `//X,Y,Z,R,G,B`);
//  3. by the number of columns of the first point: 3 to 5: x y z (the rest unused); 6 and 8:
//     x y z nx ny nz; 7: x y z intensity r g b (Leica's and E57 exports' `.pts`); 9 or more:
//     x y z nx ny nz r g b.
// Names, case ignored: x y z; nx ny nz (or normal_x normal_y normal_z); r g b (or red green blue);
// rf gf bf (colours in [0, 1]); radius; nx2 ny2 nz2 and crease (second normals, ply.h). Other
// columns are not used and are named in PlyData::unusedProperties ("column 4" when unnamed);
// their fields are not read. x, y and z are required; normals, colour and crease normals are
// taken when all three of them are named. Every point line must have the header's (or the first
// point's) number of fields.
//
// Colours: 0-255 values, unless the file writes them as fractions in [0, 1]: named rf gf bf, or
// every colour value at most 1 with at least one of them written with a '.' or an exponent
// ("1.0 0.5 0"). Values are rounded and clamped to 0..255.
//
// Numbers are read with std::from_chars as floats (a leading '+' allowed), so the shortest
// representation that writeText writes reads back bit for bit; positions also as doubles, for
// coordinates far from 0 (PlyData::origin; elsewhere the float read is kept). Errors are one line naming the
// file and the line: a field that is not a number, a line of another number of fields, a
// non-finite value (inf, nan, out of float range), a zero-length normal, a header without x y z,
// a column named twice, a file with no points.
#pragma once

#include <filesystem>
#include <string_view>

#include "pnsplat/refine/io/point_file.h"

namespace pnsplat {

// The file's bytes in memory; `name` names it in messages. Only options.columns and
// options.requireNormals are read.
Result<PlyData> parsePointText(std::string_view bytes, std::string_view name,
                               const PointFileOptions& options);

// Writes `points` as text: a header line naming the columns (x y z nx ny nz, then radius, nx2 ny2
// nz2 crease, red green blue where the set has them), then one point a line, floats in their
// shortest exact form, colours as 0-255 integers. The extension picks the flavour: `.csv` commas
// and a bare header line; others spaces and the header after "//" (CloudCompare's comment), which
// `.pts` precedes with the count line. `points.normal` must be filled; through OutputFile. Where
// `origin` is not zero, x y z are origin + position in the shortest form of a double
// (PlyData::origin).
Result<void> writePointText(const std::filesystem::path& path, const PointSet& points,
                            glm::dvec3 origin = glm::dvec3(0.0));

} // namespace pnsplat
