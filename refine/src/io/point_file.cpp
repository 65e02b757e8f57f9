// Point files of every format (point_file.h): the kind by extension or content, then the reader
// or writer of that kind (ply.h, pcd.h, point_text.h).
#include "pnsplat/refine/io/point_file.h"

#include <string>

#include <fmt/format.h>

#include "pnsplat/refine/io/pcd.h"
#include "pnsplat/refine/io/point_text.h"
#include "point_rows.h"

namespace pnsplat {

std::optional<PointFileKind> pointFileKindOf(const std::filesystem::path& path) {
    std::string extension = path.extension().string();
    for (char& c : extension)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (extension == ".ply") return PointFileKind::Ply;
    if (extension == ".pcd") return PointFileKind::Pcd;
    if (extension == ".xyz" || extension == ".txt" || extension == ".pts" || extension == ".csv")
        return PointFileKind::Text;
    return std::nullopt;
}

PointFileKind sniffPointFile(std::string_view bytes) {
    if (bytes.size() >= 4 && bytes.starts_with("ply") && (bytes[3] == '\n' || bytes[3] == '\r'))
        return PointFileKind::Ply;
    if (bytes.starts_with("# .PCD") || bytes.starts_with("VERSION") || bytes.starts_with("FIELDS"))
        return PointFileKind::Pcd;
    return PointFileKind::Text;
}

Result<PointFileData> parsePointFile(std::string_view bytes, std::string_view name,
                                     std::optional<PointFileKind> kind, const PointFileOptions& options) {
    PointFileData out;
    out.kind = kind ? *kind : sniffPointFile(bytes);
    Result<PlyData> data = Error{};
    switch (out.kind) {
    case PointFileKind::Ply:
        data = parsePly(bytes, name, {.requireNormals = options.requireNormals});
        break;
    case PointFileKind::Pcd:
        data = parsePcd(bytes, name, options, out.skippedPoints);
        break;
    case PointFileKind::Text:
        data = parsePointText(bytes, name, options);
        break;
    }
    if (!data) {
        // Read as text for want of a kind (a name such as notes.log, or standard input): say so, so
        // that "line 4: a second header line" does not read as the fault of a point file.
        const std::string prefix = fmt::format("{}: ", name);
        if (kind || out.kind != PointFileKind::Text || !data.error().message.starts_with(prefix))
            return data.error();
        return Error{fmt::format("{}: read by its content as a text point file: {}", name,
                                 data.error().message.substr(prefix.size()))};
    }
    out.data = std::move(*data);
    return out;
}

Result<PointFileData> readPointFile(const std::filesystem::path& path, const PointFileOptions& options) {
    const std::string file = inputName(path);
    return detail::guarded(file, "reading", [&]() -> Result<PointFileData> {
        Result<detail::FileData> bytes = detail::readWholeFile(path, file);
        if (!bytes) return bytes.error();
        return parsePointFile(bytes->view(), file, path == "-" ? std::nullopt : pointFileKindOf(path),
                              options);
    });
}

Result<void> writePointFile(const std::filesystem::path& path, const PointSet& points, bool ascii,
                            std::span<const std::string> comments, glm::dvec3 origin) {
    switch (path == "-" ? PointFileKind::Ply : pointFileKindOf(path).value_or(PointFileKind::Ply)) {
    case PointFileKind::Pcd:
        return writePcd(path, points, ascii, origin);
    case PointFileKind::Text:
        return writePointText(path, points, origin);
    case PointFileKind::Ply:
        break;
    }
    return writePly(path, points, ascii ? PlyFormat::Ascii : PlyFormat::BinaryLittleEndian, comments, origin);
}

} // namespace pnsplat
