// Point files of every format pnsplat reads and writes: PLY (ply.h), PCL's PCD (pcd.h) and text
// with one point a line (point_text.h, `.xyz .txt .pts .csv`). Readers written here, no library:
// see docs/ARCHITECTURE.md, "Point files". Any thread may call these functions.
//
// The format of a file is told by its extension (case ignored): `.ply`, `.pcd`, or one of the
// text extensions. Any other name, and "-" (standard input), by its first bytes: "ply" and a line
// break start a PLY file, "# .PCD", "VERSION" or "FIELDS" a PCD file; anything else is text.
#pragma once

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat {

enum class PointFileKind { Ply, Pcd, Text };

// The kind an extension names (`.ply`, `.pcd`, `.xyz .txt .pts .csv`; case ignored), or nothing.
std::optional<PointFileKind> pointFileKindOf(const std::filesystem::path& path);
// The kind the first bytes of a file show (never fails: text is the rest).
PointFileKind sniffPointFile(std::string_view bytes);

struct PointFileOptions {
    // When cleared, a file without normals reads as positions only (PointSet::normal empty).
    bool requireNormals = true;
    // Text files only: the names of the columns, left to right (point_text.h lists the names),
    // which take the place of the file's header line and of the rule by count. Empty: not given.
    std::vector<std::string> columns;
};

// What every reader returns: PlyData (ply.h). PLY fills all of it; PCD and text name their unused
// fields or columns in unusedProperties, have no elements besides the points and no comments.
// PCD's points whose position is NaN (the holes of an organised cloud) are left out and counted
// in `skippedPoints`.
struct PointFileData {
    PlyData data;
    PointFileKind kind = PointFileKind::Ply;
    std::size_t skippedPoints = 0;
};

// Reads `path` ("-": standard input) as its extension, else its content, says. Errors are one line
// naming the file (and the line, in text and ascii PCD); ply.h, pcd.h and point_text.h list them.
Result<PointFileData> readPointFile(const std::filesystem::path& path, const PointFileOptions& options = {});
// The same from bytes in memory (`kind` given, or sniffed when empty); `name` names the file in
// messages and, for text, its extension picks nothing: every text flavour reads the same.
Result<PointFileData> parsePointFile(std::string_view bytes, std::string_view name,
                                     std::optional<PointFileKind> kind, const PointFileOptions& options = {});

// How an output is written: PLY by default and for names of no point-file kind ("-" included);
// PCD for `.pcd`; text for `.xyz .txt .pts .csv`. `ascii` selects PLY's and PCD's ascii encoding;
// `comments` (PlyData::comments) go into PLY files only; `origin` (PlyData::origin) is added back
// to the positions, written as doubles where it is not zero. `points.normal` must be filled.
// Written through OutputFile (output_file.h): complete or not at all.
Result<void> writePointFile(const std::filesystem::path& path, const PointSet& points, bool ascii = false,
                            std::span<const std::string> comments = {}, glm::dvec3 origin = glm::dvec3(0.0));

} // namespace pnsplat
