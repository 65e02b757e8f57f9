// What the point-file readers share (ply.cpp, pcd.cpp, point_text.cpp; not installed): the file's
// bytes, the attributes a row may carry and how a row is checked and stored, so that every format
// gives the same points for the same values.
#pragma once

#include <array>
#include <cstddef>
#include <exception>
#include <filesystem>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <string_view>

#include <fmt/core.h>
#include <glm/vec3.hpp>

#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::detail {

// Header sections of every reader end within this many bytes (a bound on malformed input).
constexpr std::size_t kMaxHeaderBytes = 64 * 1024;

inline Error fail(std::string_view file, std::string_view problem) {
    return Error{fmt::format("{}: {}", file, problem)};
}

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

// Checks row `i` (values by slot; colour apart) and stores it into `points`; returns the problem
// ("non-finite coordinate", "zero-length normal", ...), or nullptr when the row is valid. The
// crease convention is ply.h's: with the flag, 0 is an ordinary point; without it, a point is
// ordinary when n2 is zero or equal to n.
const char* storeRow(PointSet& points, const RowLayout& layout, std::size_t i,
                     const std::array<double, kRowSlots>& v);

// A whole field of text as a float (a leading '+' allowed), false when it is not a number. Values
// beyond float's range are read as double, then rounded to float (tiny ones to zero or subnormals,
// huge ones to infinity): std::from_chars, so the shortest representation of a float reads back
// bit for bit.
bool parseFloatField(std::string_view field, float& value);

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
