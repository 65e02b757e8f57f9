// PCD files, the Point Cloud Library's format (pointclouds.org, "The PCD (Point Cloud Data) file
// format", v0.7): a header (VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA, '#'
// lines comments), then `ascii` lines, `binary` rows (little-endian) or `binary_compressed`
// columns (LZF). Any thread may call these functions.
//
// Fields read: x y z; normal_x normal_y normal_z (or nx ny nz); rgb or rgba (4 bytes 0xAARRGGBB,
// alpha dropped, of type F, U or I; in ascii a float's text, or an integer's text when it holds
// only digits, as PCL writes either); radius; nx2 ny2 nz2 and crease (ply.h's second normals).
// Other fields (curvature, intensity, ...) are named in PlyData::unusedProperties; PCL's padding
// fields `_` are not. A point whose x, y or z is NaN (a hole of an organised cloud) is left out
// and counted; other non-finite values are errors.
//
// Errors are one line naming the file: a malformed header (naming its line), a field used with
// COUNT above 1, POINTS not WIDTH x HEIGHT, a truncated body, an ascii line of another number of
// values or a value that is not a number (naming the line), a binary point with a non-finite value
// (naming the point), corrupt compressed data, a file with no points.
#pragma once

#include <filesystem>
#include <string_view>

#include "pnsplat/refine/io/point_file.h"

namespace pnsplat {

// The file's bytes in memory; `name` names it in messages. `skipped` receives the points left out
// for a NaN position.
Result<PlyData> parsePcd(std::string_view bytes, std::string_view name, const PointFileOptions& options,
                         std::size_t& skipped);

// Writes `points` as PCD v0.7 (FIELDS x y z normal_x normal_y normal_z, then radius, nx2 ny2 nz2
// crease, rgb where the set has them; rgb a packed float as PCL's PointXYZRGB has it, written in
// ascii as the integer of its bits), DATA ascii (floats in their shortest exact form) or binary.
// `points.normal` must be filled; through OutputFile. Where `origin` is not zero, x y z are
// 8-byte doubles, origin + position (PlyData::origin).
Result<void> writePcd(const std::filesystem::path& path, const PointSet& points, bool ascii,
                      glm::dvec3 origin = glm::dvec3(0.0));

} // namespace pnsplat
