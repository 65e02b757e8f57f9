// PLY input and output of oriented point sets.
//
// Reads ascii and binary little-endian (and big-endian) PLY files with one `vertex` element whose
// properties may come in any order and any scalar type: `x y z nx ny nz` are required (`nx ny nz`
// may be left out where PlyReadOptions allow; PCL's `normal_x normal_y normal_z` are read where
// the file has no `nx ny nz`), `red green blue` (uchar, or float in [0,1]) and `radius` are
// optional; other properties and other elements (faces, ...) are skipped, and named in PlyData for
// a warning. Any thread may call these functions.
//
// Details of reading: integer colours are clamped to 0..255, float colours scaled by 255 and
// rounded; colour is kept only when all of red, green and blue are present. List properties of any
// element are skipped. Ascii data is read as whitespace-separated tokens (line breaks do not
// matter); data after the last element is ignored.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

struct PlyReadOptions {
    // Triangles of a `face` element are returned in PlyData::triangles when set (for `eval`):
    // its `vertex_indices` (or `vertex_index`) list, polygons fan-triangulated; a face of fewer
    // than 3 vertices or with an index outside the vertex element is an error. A file without a
    // face element gives no triangles. When set, nx ny nz may be absent as a whole (a bare mesh
    // such as ../shared/data/*-mesh.ply): PointSet::normal is then left empty.
    bool readFaces = false;
    // When cleared, nx ny nz may be absent as a whole (a scan of positions only): PointSet::normal
    // is then left empty, for estimateNormals (normal_estimation.h). Some of them alone stay an error.
    // A file whose every normal is zero (0 0 0) has none then too (PlyData::zeroNormals); set, it fails.
    bool requireNormals = true;
};

struct PlyData {
    PointSet points;
    std::vector<glm::u32vec3> triangles; // filled only with PlyReadOptions::readFaces
    // What the file holds beyond that, for the reader to be told (names printable: other bytes
    // are '?'): the vertex properties not read (a partial colour or crease normal included), in
    // file order, and the other elements (`face` too, unless readFaces) with their counts.
    std::vector<std::string> unusedProperties;
    struct Element {
        std::string name;
        std::uint64_t count = 0;
    };
    std::vector<Element> unusedElements;
    // Every normal of the file was zero (0 0 0): read as none (`points` has no normals).
    bool zeroNormals = false;
    // The file's positions are origin + points.position (in double). Where single precision would
    // round the file's coordinates coarsely for the points' spacing at their distance from 0
    // (georeferenced scans: UTM coordinates of 10^5 to 10^7), the points are stored less a nearby
    // origin, so that they keep their detail and what is computed from them too; else zero, and
    // the positions are the file's as floats. Files read together share one origin through
    // moveToOrigin; the writers add it back in double.
    glm::dvec3 origin{0.0};
    // Where the file holds such coordinates in single precision, rounded by more than a hundredth
    // of their spacing: that step over the mean spacing (else 0).
    double roundedBy = 0.0;
    // The readers' own, empty once read: the positions in double, from a file's first point that
    // lies kOriginFrom or farther from 0 on, while it is read.
    std::vector<glm::dvec3> farPositions;
    // The header's `comment` and `obj_info` lines as they stand, from the keyword on (writePly
    // can carry them on).
    std::vector<std::string> comments;
};

// A point's distance from 0 on an axis from which the readers keep the positions in double until
// they decide on PlyData::origin (below it, a float steps by at most 2^-20, so the points before
// the first such one are kept as the floats they were read as).
inline constexpr double kOriginFrom = 16.0;

// Positions stored less `from` (PlyData::origin of the file they came from) restated less `to`, in
// double then rounded to float: how a file read with one origin joins another's points.
void moveToOrigin(std::span<glm::vec3> positions, glm::dvec3 from, glm::dvec3 to);

// `path` "-" is standard input (inputName); pipes and character devices (/dev/stdin, process
// substitution) are read to their end as well.
// Fails with a one-line message naming the file for: a missing or unreadable file, a malformed or
// unsupported header, a truncated body, a non-finite coordinate or normal, a normal of (near)
// zero length, a negative or non-finite radius, and a file with no points. Normals are
// normalised on reading (below 1e-12 counts as zero length); a normal already within 1e-6 of unit
// length is kept bit for bit, so files from writePly read back exactly.
Result<PlyData> readPly(const std::filesystem::path& path, const PlyReadOptions& options = {});
// How messages name an input: "standard input" for "-", else the path.
std::string inputName(const std::filesystem::path& path);
// The same from bytes in memory (the fuzz targets' entry); `name` stands for the file in messages.
Result<PlyData> parsePly(std::string_view bytes, std::string_view name, const PlyReadOptions& options = {});

enum class PlyFormat { Ascii, BinaryLittleEndian };

// Writes `points` (x y z nx ny nz as float, then radius when present, then red green blue when
// present; x y z as double, origin + position, where `origin` is not zero: PlyData::origin) through
// OutputFile (output_file.h): complete or not at all, "-" for standard output,
// links followed, devices and pipes written through, binary data never to a terminal. Floats
// round-trip exactly in both formats (ascii uses the shortest representation). `points.normal`
// must be filled. `comments` (PlyData::comments of the file the points came from: lines that start
// with `comment` or `obj_info` and hold no line break) go into the header before pnsplat's own
// comment; a header they would take beyond the 64 KiB that readPly reads is an error.
Result<void> writePly(const std::filesystem::path& path, const PointSet& points,
                      PlyFormat format = PlyFormat::BinaryLittleEndian,
                      std::span<const std::string> comments = {}, glm::dvec3 origin = glm::dvec3(0.0));

// pnsplat's own comment, which writePly puts in every header.
inline constexpr std::string_view kWrittenByPnsplat = "comment written by pnsplat";
// Whether a file's comments (PlyData::comments) say pnsplat wrote it.
bool writtenByPnsplat(std::span<const std::string> comments);

} // namespace pnsplat
