// Text point files (point_text.h): a line splitter into a fixed array of fields, the columns named
// by the options, a header line or their count, numbers parsed with std::from_chars (no allocation
// per line), every row checked and stored as the PLY reader stores it (point_rows.h); a writer
// through OutputFile.
#include "pnsplat/refine/io/point_text.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <iterator>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "pnsplat/refine/io/output_file.h"
#include "point_rows.h"

namespace pnsplat {
namespace {

using detail::fail;
using detail::printable;

constexpr std::size_t kMaxFields = 256;

// A column's use: a slot of the row (point_rows.h), a colour channel, an attribute, or nothing.
constexpr int kUnused = -1;
constexpr int kColour = 100;     // kColour + 0, 1, 2: red, green, blue
constexpr int kAttribute = 1000; // kAttribute + a: PointSet::attributes[a]

struct ColumnName {
    std::string_view name;
    int use;
};
// Names as written, lower case; "rf gf bf" mark colours in [0, 1].
constexpr ColumnName kColumnNames[] = {
    {"x", detail::kX},
    {"y", detail::kY},
    {"z", detail::kZ},
    {"nx", detail::kNx},
    {"ny", detail::kNy},
    {"nz", detail::kNz},
    {"normal_x", detail::kNx},
    {"normal_y", detail::kNy},
    {"normal_z", detail::kNz},
    {"r", kColour},
    {"g", kColour + 1},
    {"b", kColour + 2},
    {"red", kColour},
    {"green", kColour + 1},
    {"blue", kColour + 2},
    {"rf", kColour},
    {"gf", kColour + 1},
    {"bf", kColour + 2},
    {"radius", detail::kRadius},
    {"nx2", detail::kNx2},
    {"ny2", detail::kNy2},
    {"nz2", detail::kNz2},
    {"crease", detail::kCreaseFlag},
};

bool isSeparator(char c) {
    return c == ' ' || c == '\t' || c == ',';
}

// Splits a line into `fields`; returns their number (kMaxFields + 1: more than fit).
std::size_t splitFields(std::string_view line, std::array<std::string_view, kMaxFields>& fields) {
    std::size_t count = 0, i = 0;
    const std::size_t n = line.size();
    while (i < n) {
        while (i < n && isSeparator(line[i])) ++i;
        if (i == n) break;
        const std::size_t start = i;
        while (i < n && !isSeparator(line[i])) ++i;
        if (count == kMaxFields) return kMaxFields + 1;
        fields[count++] = line.substr(start, i - start);
    }
    return count;
}

bool isCount(std::string_view field) {
    std::uint64_t count = 0;
    const char* end = field.data() + field.size();
    const auto [ptr, ec] = std::from_chars(field.data(), end, count);
    return ec == std::errc() && ptr == end;
}

char lower(char c) {
    return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

bool startsName(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
}

// The columns of a file and what each is used for.
struct Columns {
    std::vector<int> use;                     // per column
    std::vector<std::pair<int, int>> reading; // (column, use) of the columns read, left to right
    detail::RowLayout layout;
    bool colour = false;
    bool unitColour = false;             // named rf gf bf
    std::string byCount;                 // "(the 6 columns taken as ...)" when named by their count, else ""
    std::vector<std::string> attributes; // the names of the columns read as attributes (floats)
};

Result<Columns> columnsFromNames(const std::vector<std::string>& names, std::string_view file,
                                 std::string_view where, const PointFileOptions& options,
                                 std::vector<std::string>& unused) {
    Columns columns;
    std::array<int, detail::kRowSlots> slotColumn;
    slotColumn.fill(-1);
    std::array<int, 3> colourColumn{-1, -1, -1};
    for (std::size_t c = 0; c < names.size(); ++c) {
        std::string name;
        for (const char ch : names[c]) name += lower(ch);
        int use = kUnused;
        for (const ColumnName& known : kColumnNames)
            if (known.name == name) use = known.use;
        if (use >= kColour) {
            int& column = colourColumn[static_cast<std::size_t>(use - kColour)];
            if (column >= 0)
                return fail(file, fmt::format("{}: two colour columns '{}' and '{}'", where,
                                              printable(names[static_cast<std::size_t>(column)]),
                                              printable(names[c])));
            column = static_cast<int>(c);
            if (name.size() == 2 && name[1] == 'f') columns.unitColour = true;
        } else if (use != kUnused) {
            int& column = slotColumn[static_cast<std::size_t>(use)];
            if (column >= 0)
                return fail(file, fmt::format("{}: two columns for '{}' ('{}' and '{}')", where, name,
                                              printable(names[static_cast<std::size_t>(column)]),
                                              printable(names[c])));
            column = static_cast<int>(c);
        }
        columns.use.push_back(use);
    }
    const auto has = [&](int slot) { return slotColumn[static_cast<std::size_t>(slot)] >= 0; };
    for (const int slot : {detail::kX, detail::kY, detail::kZ})
        if (!has(slot))
            return fail(file,
                        fmt::format("{}: no '{}' column", where, "xyz"[static_cast<std::size_t>(slot)]));
    const int normals = has(detail::kNx) + has(detail::kNy) + has(detail::kNz);
    if (normals != 0 && normals != 3)
        return fail(file, fmt::format("{}: some of the normal columns nx ny nz but not all", where));
    if (normals == 0 && options.requireNormals)
        return fail(file, fmt::format("{}: no normal columns (nx ny nz)", where));
    columns.layout.normal = normals == 3;
    columns.layout.radius = has(detail::kRadius);
    columns.layout.crease =
        columns.layout.normal && has(detail::kNx2) && has(detail::kNy2) && has(detail::kNz2);
    columns.layout.creaseFlag = columns.layout.crease && has(detail::kCreaseFlag);
    columns.colour = colourColumn[0] >= 0 && colourColumn[1] >= 0 && colourColumn[2] >= 0;
    // Partial colours and crease normals are unused, as in PLY files.
    for (std::size_t c = 0; c < names.size(); ++c) {
        int& use = columns.use[c];
        if ((use >= kColour && !columns.colour) ||
            ((use == detail::kNx2 || use == detail::kNy2 || use == detail::kNz2) && !columns.layout.crease) ||
            (use == detail::kCreaseFlag && !columns.layout.creaseFlag))
            use = kUnused;
        // Any other named column is an attribute (the first of a name; point_rows.h, attributeName).
        const auto& attributes = columns.attributes;
        if (use == kUnused && detail::attributeName(names[c]) &&
            std::find(attributes.begin(), attributes.end(), names[c]) == attributes.end()) {
            use = kAttribute + static_cast<int>(attributes.size());
            columns.attributes.push_back(names[c]);
        }
        if (use == kUnused)
            unused.push_back(names[c].empty() ? fmt::format("column {}", c + 1) : printable(names[c]));
        else
            columns.reading.emplace_back(static_cast<int>(c), use);
    }
    return columns;
}

// Names for the columns of a file without a header, by their number (point_text.h).
std::vector<std::string> namesByCount(std::size_t count) {
    std::vector<std::string> names;
    if (count == 7)
        names = {"x", "y", "z", "intensity", "r", "g", "b"};
    else if (count >= 9)
        names = {"x", "y", "z", "nx", "ny", "nz", "r", "g", "b"};
    else if (count >= 6)
        names = {"x", "y", "z", "nx", "ny", "nz"};
    else
        names = {"x", "y", "z"};
    names.resize(std::max(count, names.size())); // unnamed: "column N"
    return names;
}

std::uint8_t colourByte(float value, bool unit) {
    const double v =
        unit ? std::round(static_cast<double>(value) * 255.0) : std::round(static_cast<double>(value));
    return static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
}

class TextReader {
  public:
    TextReader(std::string_view bytes, std::string_view file, const PointFileOptions& options)
        : bytes_(bytes), file_(file), options_(options) {}

    Result<PlyData> read() {
        if (bytes_.starts_with("\xEF\xBB\xBF")) bytes_.remove_prefix(3); // a UTF-8 byte order mark
        // Every point takes a line: an upper bound on the points, for one allocation.
        const std::size_t lines =
            static_cast<std::size_t>(std::count(bytes_.begin(), bytes_.end(), '\n')) + 1;
        std::size_t pos = 0, n = 0;
        std::uint64_t lineNumber = 0;
        bool haveColumns = false, sawHeader = false;
        std::vector<std::string> headerNames;
        std::array<std::string_view, kMaxFields> fields;
        PlyData out;
        while (pos < bytes_.size()) {
            const std::size_t newline = std::min(bytes_.find('\n', pos), bytes_.size());
            std::string_view line = bytes_.substr(pos, newline - pos);
            pos = newline + 1;
            ++lineNumber;
            if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
            if (line.starts_with('#')) continue;
            const bool slashes = line.starts_with("//");
            if (slashes && (haveColumns || sawHeader)) continue; // a comment
            if (slashes) line.remove_prefix(2);
            const std::size_t count = splitFields(line, fields);
            if (count == 0) continue;
            if (count > kMaxFields)
                return lineError(lineNumber, fmt::format("more than {} fields", kMaxFields));
            if (count == 1 && isCount(fields[0])) continue; // a point count (.pts)
            if (!haveColumns) {
                const bool header = slashes || startsName(fields[0][0]);
                if (header && sawHeader) return lineError(lineNumber, "a second header line");
                if (header) {
                    sawHeader = true;
                    for (std::size_t c = 0; c < count; ++c) headerNames.emplace_back(fields[c]);
                    if (!options_.columns.empty()) headerNames.clear(); // named by the options instead
                    continue;
                }
                Result<void> named = nameColumns(headerNames, count, lineNumber, out);
                if (!named) return named.error();
                haveColumns = true;
                sizePoints(out, lines);
            }
            Result<void> row = readRow(std::span(fields.data(), count), lineNumber, n, out);
            if (!row) return row.error();
            ++n;
        }
        if (!haveColumns && !sawHeader) return fail(file_, "empty file (no points)");
        if (n == 0) return fail(file_, "no points");
        out.points.resize(n);
        if (columns_.colour) storeColours(out.points);
        detail::settleOrigin(out);
        if (Result<void> normals = detail::settleZeroNormals(out, options_.requireNormals, file_); !normals)
            return normals.error();
        return out;
    }

  private:
    // The error of line `lineNumber`, with how the columns were named when by their count.
    Error lineError(std::uint64_t lineNumber, const std::string& problem) const {
        return fail(file_, fmt::format("line {}: {}{}", lineNumber, problem, columns_.byCount));
    }

    // Room for `lines` points (an upper bound) once the columns are known.
    void sizePoints(PlyData& out, std::size_t lines) {
        for (const std::string& name : columns_.attributes)
            out.points.attributes.push_back(Attribute{name, ScalarType::Float32, {}});
        detail::sizePoints(out.points, columns_.layout, false, lines);
        for (Attribute& a : out.points.attributes) a.values.resize(lines);
        if (columns_.colour) colours_.resize(lines);
    }

    // Reads the `fields` of line `lineNumber` into point n of `out`, checked as every reader does.
    Result<void> readRow(std::span<const std::string_view> fields, std::uint64_t lineNumber, std::size_t n,
                         PlyData& out) {
        if (fields.size() != columns_.use.size())
            return lineError(lineNumber,
                             fmt::format("{} field(s), expected {}", fields.size(), columns_.use.size()));
        for (const auto& [column, use] : columns_.reading) {
            const std::string_view field = fields[static_cast<std::size_t>(column)];
            // Positions in the precision they are written with (PlyData::origin), the rest as floats.
            const bool position = use >= 0 && use <= detail::kZ;
            float value = 0.0f;
            double exact = 0.0;
            if (!detail::parseFloatField(field, value) ||
                (position && !detail::parseDoubleField(field, exact)))
                return lineError(lineNumber, fmt::format("'{}' is not a number (column {})", printable(field),
                                                         column + 1));
            if (!std::isfinite(value))
                return lineError(lineNumber, fmt::format("non-finite value '{}' (column {})",
                                                         printable(field), column + 1));
            if (position) {
                // The float the text names where the double rounds to another (of all floats' shortest
                // forms, only 7.038531e-26 does): positions without an origin are the floats read.
                values_[static_cast<std::size_t>(use)] =
                    static_cast<float>(exact) == value ? exact : double(value);
                continue;
            }
            if (use >= kAttribute) {
                out.points.attributes[static_cast<std::size_t>(use - kAttribute)].values[n] = value;
            } else if (use >= kColour) {
                colours_[n][use - kColour] = value;
                maxColour_ = std::max(maxColour_, value);
                fraction_ = fraction_ || field.find_first_of(".eE") != std::string_view::npos;
            } else {
                values_[static_cast<std::size_t>(use)] = value;
            }
        }
        if (const char* problem = detail::storeRow(out, columns_.layout, n, values_))
            return lineError(lineNumber, problem);
        return {};
    }

    // Stores the colours as read, taken as in [0, 1] when named rf gf bf or written as fractions
    // no larger than 1, else as in [0, 255].
    void storeColours(PointSet& points) const {
        const std::size_t n = points.size();
        const bool unit = columns_.unitColour || (fraction_ && maxColour_ <= 1.0f);
        points.colour.resize(n);
        for (std::size_t i = 0; i < n; ++i)
            points.colour[i] = glm::u8vec3(colourByte(colours_[i].x, unit), colourByte(colours_[i].y, unit),
                                           colourByte(colours_[i].z, unit));
    }

    // Names the columns of the first point line (`count` fields, at line `lineNumber`).
    Result<void> nameColumns(const std::vector<std::string>& headerNames, std::size_t count,
                             std::uint64_t lineNumber, PlyData& out) {
        std::string where;
        std::vector<std::string> names;
        if (!options_.columns.empty()) {
            names = options_.columns;
            where = "the columns named by the options";
        } else if (!headerNames.empty()) {
            names = headerNames;
            where = "the header line";
        } else {
            names = namesByCount(count);
            where = fmt::format("line {}", lineNumber);
        }
        Result<Columns> columns = columnsFromNames(names, file_, where, options_, out.unusedProperties);
        if (!columns) return columns.error();
        columns_ = std::move(*columns);
        if (options_.columns.empty() && headerNames.empty()) {
            std::string taken;
            for (std::size_t c = 0; c < std::min<std::size_t>(count, 9); ++c)
                taken += (c ? " " : "") + (names[c].empty() ? std::string("-") : names[c]);
            columns_.byCount = fmt::format(" (the {} columns taken as {}{} by their number; a header line or "
                                           "--columns names them)",
                                           count, taken, count > 9 ? " ..." : "");
        }
        return {};
    }

    std::string_view bytes_;
    std::string_view file_;
    const PointFileOptions& options_;
    Columns columns_;
    std::vector<glm::vec3> colours_;                 // as read, converted once the file shows their scale
    std::array<double, detail::kRowSlots> values_{}; // the row being read, by slot
    float maxColour_ = 0.0f;
    bool fraction_ = false;
};

// ---------------------------------------------------------------------------------------------
// Writing

void appendFloat(std::string& out, float value) {
    char buffer[32];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
    out.append(buffer, end);
}

Result<void> writeTextFile(const std::filesystem::path& path, const PointSet& points, glm::dvec3 origin,
                           std::string_view file) {
    assert(points.normal.size() == points.size());
    if (const std::optional<std::string> problem = detail::attributeNameProblem(points))
        return fail(file, *problem);
    std::string extension = path.extension().string();
    for (char& c : extension) c = lower(c);
    const bool csv = extension == ".csv";
    const char separator = csv ? ',' : ' ';
    std::vector<std::string_view> names = {"x", "y", "z", "nx", "ny", "nz"};
    if (points.hasRadius()) names.push_back("radius");
    if (points.hasCrease()) names.insert(names.end(), {"nx2", "ny2", "nz2", "crease"});
    if (points.hasColour()) names.insert(names.end(), {"red", "green", "blue"});
    for (const Attribute& a : points.attributes) names.emplace_back(a.name);
    std::string buffer;
    if (extension == ".pts") buffer = fmt::format("{}\n", points.size());
    if (!csv) buffer += "//";
    buffer += fmt::format("{}\n", fmt::join(names, std::string_view(&separator, 1)));

    const int doubles = detail::doublePositions(origin);
    return detail::writeRows(
        path, OutputContent::Text, std::move(buffer), points.size(), [&](std::string& rows, std::size_t i) {
            std::array<float, 10> values{};
            const int floats = detail::rowFloats(points, i, values);
            const bool crease = points.isCrease(i);
            for (int k = 0; k < floats; ++k) {
                if (k > 0) rows += separator;
                if (k < doubles)
                    detail::appendScalarText(rows, ScalarType::Float64, origin[k] + double(values[k]));
                else
                    appendFloat(rows, values[k]);
            }
            if (points.hasCrease()) {
                rows += separator;
                rows += crease ? '1' : '0';
            }
            if (points.hasColour())
                fmt::format_to(std::back_inserter(rows), "{}{}{}{}{}{}", separator, points.colour[i].x,
                               separator, points.colour[i].y, separator, points.colour[i].z);
            for (const Attribute& a : points.attributes) {
                rows += separator;
                detail::appendScalarText(rows, a.type, a.values[i]);
            }
            rows += '\n';
        });
}

} // namespace

Result<PlyData> parsePointText(std::string_view bytes, std::string_view name,
                               const PointFileOptions& options) {
    return detail::guarded(name, "reading", [&] { return TextReader(bytes, name, options).read(); });
}

Result<void> writePointText(const std::filesystem::path& path, const PointSet& points, glm::dvec3 origin) {
    const std::string file = outputName(path);
    return detail::guarded(file, "writing", [&] { return writeTextFile(path, points, origin, file); });
}

} // namespace pnsplat
