// What the point-file readers share (ply.cpp, pcd.cpp, point_text.cpp; not installed): the file's
// bytes, the attributes a row may carry and how a row is checked and stored, so that every format
// gives the same points for the same values.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>
#include <glm/vec3.hpp>

#include "pnsplat/refine/io/output_file.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::detail {

// Header sections of every reader end within this many bytes (a bound on malformed input).
constexpr std::size_t kMaxHeaderBytes = 64 * 1024;

inline Error fail(std::string_view file, std::string_view problem) {
    return Error{fmt::format("{}: {}", file, problem)};
}

// The words of a header line, separated by spaces or tabs.
std::vector<std::string_view> splitWords(std::string_view line);
// A whole word as an unsigned integer, or nothing.
std::optional<std::uint64_t> parseCount(std::string_view word);

// Printable form of a word of a file for messages (bytes may be anything): at most 40 characters,
// other bytes than printable ASCII as '?'.
std::string printable(std::string_view word);

struct FileData {
    std::unique_ptr<char[]> bytes;
    std::size_t size = 0;
    std::string_view view() const { return {bytes.get(), size}; }
};

// The whole of a file, "-" (standard input), a pipe or a character device (read to its end);
// errors name `file`.
Result<FileData> readWholeFile(const std::filesystem::path& path, std::string_view file);

// A normal as stored: values within 1e-6 of unit length are kept bit for bit (so written files
// read back exactly), others normalised; nullopt for a direction shorter than 1e-12. The values are
// taken as floats first.
std::optional<glm::vec3> unitDirection(double x, double y, double z);

// The attributes of a row, as slots of one array of values (the names are PLY's).
enum Slot : int { kX, kY, kZ, kNx, kNy, kNz, kRadius, kNx2, kNy2, kNz2, kCreaseFlag, kRowSlots };

struct RowLayout {
    bool normal = false;
    bool radius = false;
    bool crease = false;     // nx2 ny2 nz2 (needs normal)
    bool creaseFlag = false; // the `crease` flag beside them
};

// Sizes the arrays of `points` for `n` rows of `layout` (and colour when `colour`).
void sizePoints(PointSet& points, const RowLayout& layout, bool colour, std::size_t n);

// Checks row `i` (values by slot; colour apart) and stores it into `data.points`; returns the
// problem ("non-finite coordinate", "zero-length normal", ...), or nullptr when the row is valid.
// Positions are given in the precision the file holds (double where it is written so or as text)
// and kept so in data.farPositions from the first that lies kOriginFrom or farther from 0 on an
// axis on (the rows before it as stored), for settleOrigin. Zero normals are stored while every row before
// has one (settleZeroNormals decides after the last). The crease convention is ply.h's: with the flag, 0 is
// an ordinary point; without it, a point is ordinary when n2 is zero or equal to n.
const char* storeRow(PlyData& data, const RowLayout& layout, std::size_t i,
                     const std::array<double, kRowSlots>& v);

// After the last row: where single precision steps by more than kOriginStep times the mean spacing
// at the points' distance from 0, they are stored less an origin (PlyData::origin: the centre of
// the box where most of them lie, in double, rounded to a multiple of the power of two at or above
// its diagonal; box and spacing leave out a few points far from the rest), from
// the positions kept in double; data.farPositions is released either way. Where the file holds
// them in single precision, rounded so already, and a float's step there exceeds kCoarseStep times
// the spacing, data.roundedBy says by how much.
inline constexpr double kOriginStep = 1e-3;
inline constexpr double kCoarseStep = 1e-2;
void settleOrigin(PlyData& data);

// After the last row: a file whose every normal is zero (an exporter that writes 0 0 0 for no
// normal, a Gaussian-splatting scene) has none, as if it had no normal columns (data.zeroNormals
// says so), or fails where normals are `required`.
Result<void> settleZeroNormals(PlyData& data, bool required, std::string_view file);

// The floats a written row carries, in order: x y z nx ny nz, the radius where the set has radii,
// nx2 ny2 nz2 where it has creases (an ordinary point's second normal repeats its normal, ply.h's
// convention); returns their count.
int rowFloats(const PointSet& points, std::size_t i, std::array<float, 10>& values);

// How many of a written row's first values (x y z) are doubles, origin + position: 3 where the
// points are stored less an origin (PlyData::origin), else 0 (floats, as stored).
inline int doublePositions(glm::dvec3 origin) {
    return origin != glm::dvec3(0.0) ? 3 : 0;
}

// An attribute's value (PointSet::attributes), representable() first, as text: an integer type's as an
// integer, a float's and a double's in the shortest form that reads back exactly as that type.
void appendScalarText(std::string& out, ScalarType type, double value);

// Whether `name` (case ignored) is one that some format reads or writes as a point's position,
// normal, radius, colour or crease (x, nx, normal_x, red, r, rf, rgb, radius, nx2, crease, ...): a
// property of such a name is never an attribute (PointSet::attributes), so that every writer can
// write every attribute and every reader reads it back as one.
bool reservedName(std::string_view name);

// Whether a property, field or column of this name becomes an attribute: a name that is not
// reserved and that every writer can write (see attributeNameProblem).
bool attributeName(std::string_view name);

// An attribute's value (representable() first) as its type's bytes, little-endian.
void appendScalarBinary(std::string& out, ScalarType type, double value);

// Why the attributes of `points` cannot stand in a file's header: a name empty, holding a space, a
// comma or another byte that is not printable ASCII, twice there or reserved (reservedName);
// nothing when they can.
std::optional<std::string> attributeNameProblem(const PointSet& points);

// A whole field of text as a float (a leading '+' allowed), false when it is not a number. Values
// beyond float's range are read as double, then rounded to float (tiny ones to zero or subnormals,
// huge ones to infinity): std::from_chars, so the shortest representation of a float reads back
// bit for bit.
bool parseFloatField(std::string_view field, float& value);
// The same as a double (the positions of text files and of PCD's 8-byte fields: PlyData::origin).
bool parseDoubleField(std::string_view field, double& value);

// Writes `path` whole or not at all (OutputFile): `buffer` (the header), then appendRow(buffer, i)
// for each of `count` rows, in chunks of about a mebibyte.
inline constexpr std::size_t kWriteChunkBytes = std::size_t{1} << 20;
template <typename AppendRow>
Result<void> writeRows(const std::filesystem::path& path, OutputContent content, std::string buffer,
                       std::size_t count, const AppendRow& appendRow) {
    Result<OutputFile> out = OutputFile::open(path, content);
    if (!out) return out.error();
    buffer.reserve(buffer.size() + kWriteChunkBytes + 512);
    for (std::size_t i = 0; i < count; ++i) {
        appendRow(buffer, i);
        if (buffer.size() >= kWriteChunkBytes) {
            if (Result<void> written = out->write(buffer); !written) return written;
            buffer.clear();
        }
    }
    if (Result<void> written = out->write(buffer); !written) return written;
    return out->commit();
}

// run() with allocation failures and other exceptions turned into one-line errors; `doing` is
// "reading" or "writing".
template <typename Run>
auto guarded(std::string_view file, std::string_view doing, const Run& run) -> decltype(run()) {
    try {
        return run();
    } catch (const std::bad_alloc&) {
        return fail(file, fmt::format("out of memory while {}", doing));
    } catch (const std::exception& e) {
        return fail(file, e.what());
    }
}

} // namespace pnsplat::detail
