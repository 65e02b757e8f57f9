// What the point-file readers share (point_rows.h): reading a file's bytes, and checking and
// storing a row of values the same way for every format.
#include "point_rows.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <span>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

namespace pnsplat::detail {

namespace {

namespace fs = std::filesystem;

constexpr double kMinNormalLength = 1e-12;
constexpr double kUnitTolerance = 1e-6;
constexpr std::size_t kReadChunkBytes = std::size_t{1} << 20; // first buffer of a stream

std::string errnoMessage(int error) {
    return std::generic_category().message(error);
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

// The bytes of a stream (standard input, a pipe, a character device) up to its end.
Result<FileData> readStream(int fd, std::string_view file) {
    FileData data;
    std::size_t capacity = 0;
    for (;;) {
        if (data.size == capacity) {
            capacity = std::max(kReadChunkBytes, 2 * capacity);
            auto bigger = std::make_unique_for_overwrite<char[]>(capacity + 1);
            if (data.size > 0) std::memcpy(bigger.get(), data.bytes.get(), data.size);
            data.bytes = std::move(bigger);
        }
        const ssize_t n = ::read(fd, data.bytes.get() + data.size, capacity - data.size);
        if (n == 0) return data;
        if (n < 0 && errno != EINTR) return fail(file, fmt::format("cannot read: {}", errnoMessage(errno)));
        if (n > 0) data.size += static_cast<std::size_t>(n);
    }
}

// Whether three values stay finite as floats.
bool finiteFloats(double x, double y, double z) {
    return std::isfinite(static_cast<float>(x)) && std::isfinite(static_cast<float>(y)) &&
           std::isfinite(static_cast<float>(z));
}

} // namespace

std::string printable(std::string_view word) {
    std::string out;
    for (char c : word.substr(0, 40)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    if (word.size() > 40) out += "...";
    return out;
}

Result<FileData> readWholeFile(const fs::path& path, std::string_view file) {
    if (path == "-") return readStream(STDIN_FILENO, file);
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (status.type() == fs::file_type::not_found) return fail(file, "no such file");
    if (ec) return fail(file, fmt::format("cannot read: {}", ec.message()));
    if (status.type() == fs::file_type::directory) return fail(file, "is a directory, not a file");
    if (status.type() == fs::file_type::fifo || status.type() == fs::file_type::character) {
        errno = 0;
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) return fail(file, fmt::format("cannot open: {}", errnoMessage(errno)));
        Result<FileData> data = readStream(fd, file);
        ::close(fd);
        return data;
    }
    if (status.type() != fs::file_type::regular)
        return fail(file, "not a file, a pipe or a character device");

    errno = 0;
    std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
    if (!f) return fail(file, fmt::format("cannot open: {}", errnoMessage(errno)));
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) return fail(file, fmt::format("cannot read: {}", ec.message()));
    if (size > std::numeric_limits<std::size_t>::max() / 2) return fail(file, "file too large");
    FileData data;
    data.bytes = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(size) + 1);
    data.size = std::fread(data.bytes.get(), 1, static_cast<std::size_t>(size), f.get());
    if (std::ferror(f.get())) return fail(file, fmt::format("cannot read: {}", errnoMessage(errno)));
    return data;
}

std::optional<glm::vec3> unitDirection(double x, double y, double z) {
    const glm::vec3 n(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    const double nx = n.x, ny = n.y, nz = n.z;
    const double length = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (!(length >= kMinNormalLength)) return std::nullopt;
    if (std::abs(length - 1.0) <= kUnitTolerance) return n;
    return glm::vec3(static_cast<float>(nx / length), static_cast<float>(ny / length),
                     static_cast<float>(nz / length));
}

bool parseFloatField(std::string_view field, float& value) {
    if (field.size() > 1 && field[0] == '+' && field[1] != '-') field.remove_prefix(1);
    const char* end = field.data() + field.size();
    const auto [ptr, ec] = std::from_chars(field.data(), end, value);
    if (field.empty() || ptr != end) return false;
    if (ec == std::errc()) return true;
    if (ec != std::errc::result_out_of_range) return false;
    double wide = 0.0;
    const auto [wideEnd, wideError] = std::from_chars(field.data(), end, wide);
    value = wideError == std::errc() ? static_cast<float>(wide)
                                     : (field[0] == '-' ? -std::numeric_limits<float>::infinity()
                                                        : std::numeric_limits<float>::infinity());
    return true;
}

bool parseDoubleField(std::string_view field, double& value) {
    if (field.size() > 1 && field[0] == '+' && field[1] != '-') field.remove_prefix(1);
    const char* end = field.data() + field.size();
    const auto [ptr, ec] = std::from_chars(field.data(), end, value);
    if (field.empty() || ptr != end) return false;
    if (ec == std::errc::result_out_of_range) // beyond double's range: infinity, refused by the readers
        value = field[0] == '-' ? -std::numeric_limits<double>::infinity()
                                : std::numeric_limits<double>::infinity();
    return ec == std::errc() || ec == std::errc::result_out_of_range;
}

std::vector<std::string_view> splitWords(std::string_view line) {
    std::vector<std::string_view> words;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
        const std::size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
    return words;
}

std::optional<std::uint64_t> parseCount(std::string_view word) {
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
    if (ec != std::errc() || end != word.data() + word.size()) return std::nullopt;
    return value;
}

int rowFloats(const PointSet& points, std::size_t i, std::array<float, 10>& values) {
    const glm::vec3 p = points.position[i], n = points.normal[i];
    values = {p.x, p.y, p.z, n.x, n.y, n.z};
    int floats = 6;
    if (points.hasRadius()) values[static_cast<std::size_t>(floats++)] = points.radius[i];
    if (points.hasCrease()) {
        const glm::vec3 second = points.isCrease(i) ? points.crease[i] : n;
        for (int k = 0; k < 3; ++k) values[static_cast<std::size_t>(floats++)] = second[k];
    }
    return floats;
}

void appendScalarText(std::string& out, ScalarType type, double value) {
    value = representable(type, value); // integers: no conversion out of range
    char buffer[32];
    std::to_chars_result written{};
    if (type == ScalarType::Float32)
        written = std::to_chars(buffer, buffer + sizeof buffer, static_cast<float>(value));
    else if (type == ScalarType::Float64)
        written = std::to_chars(buffer, buffer + sizeof buffer, value);
    else
        written = std::to_chars(buffer, buffer + sizeof buffer, static_cast<std::int64_t>(value));
    out.append(buffer, written.ptr);
}

bool reservedName(std::string_view name) {
    static constexpr std::string_view kReserved[] = {
        "x", "y", "z",  "nx", "ny", "nz",  "normal_x", "normal_y", "normal_z", "red", "green", "blue",  "r",
        "g", "b", "rf", "gf", "bf", "rgb", "rgba",     "radius",   "nx2",      "ny2", "nz2",   "crease"};
    const auto lower = [](char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; };
    return std::any_of(std::begin(kReserved), std::end(kReserved), [&](std::string_view reserved) {
        return reserved.size() == name.size() && std::equal(reserved.begin(), reserved.end(), name.begin(),
                                                            [&](char a, char b) { return a == lower(b); });
    });
}

namespace {
bool writableName(std::string_view name) {
    return !name.empty() &&
           std::none_of(name.begin(), name.end(), [](char c) { return c <= 0x20 || c >= 0x7f || c == ','; });
}
} // namespace

bool attributeName(std::string_view name) {
    return writableName(name) && !reservedName(name);
}

void appendScalarBinary(std::string& out, ScalarType type, double value) {
    value = representable(type, value); // integers: no conversion out of range
    const auto put = [&](auto typed) {
        auto bits = std::bit_cast<std::array<char, sizeof typed>>(typed);
        if constexpr (std::endian::native == std::endian::big) std::reverse(bits.begin(), bits.end());
        out.append(bits.data(), bits.size());
    };
    switch (type) {
    case ScalarType::Int8:
        return put(static_cast<std::int8_t>(value));
    case ScalarType::UInt8:
        return put(static_cast<std::uint8_t>(value));
    case ScalarType::Int16:
        return put(static_cast<std::int16_t>(value));
    case ScalarType::UInt16:
        return put(static_cast<std::uint16_t>(value));
    case ScalarType::Int32:
        return put(static_cast<std::int32_t>(value));
    case ScalarType::UInt32:
        return put(static_cast<std::uint32_t>(value));
    case ScalarType::Float32:
        return put(static_cast<float>(value));
    case ScalarType::Float64:
        return put(value);
    }
}

std::optional<std::string> attributeNameProblem(const PointSet& points) {
    for (std::size_t a = 0; a < points.attributes.size(); ++a) {
        const std::string& name = points.attributes[a].name;
        if (name.empty()) return std::string("an attribute has no name");
        if (!writableName(name))
            return fmt::format(
                "attribute '{}': a name of spaces, commas or bytes that are not printable ASCII",
                printable(name));
        if (reservedName(name))
            return fmt::format("attribute '{}': the name of a position, normal, radius, colour or crease",
                               printable(name));
        for (std::size_t b = 0; b < a; ++b)
            if (points.attributes[b].name == name)
                return fmt::format("attribute '{}' twice", printable(name));
    }
    return std::nullopt;
}

void sizePoints(PointSet& points, const RowLayout& layout, bool colour, std::size_t n) {
    points.position.resize(n);
    if (layout.normal) points.normal.resize(n);
    if (layout.radius) points.radius.resize(n);
    if (colour) points.colour.resize(n);
    if (layout.crease) points.crease.resize(n);
}

Result<void> settleZeroNormals(PlyData& data, bool required, std::string_view file) {
    PointSet& points = data.points;
    if (points.normal.empty() || points.normal[0] != glm::vec3(0.0f)) return {};
    if (required) return fail(file, "every normal is zero (0 0 0)");
    points.normal.clear();
    points.crease.clear(); // second normals without a first
    data.zeroNormals = true;
    return {};
}

namespace {

// Where most of the points lie: per axis, the median ± the interquartile range (the whole range of
// an even spread is twice it), from every ceil(n / kMiddleSample)-th point, those at exactly 0 0 0
// left out (invalid returns, as organised scans write them, may be a quarter of the rows or more;
// settleOrigin runs only where some point lies far from 0). A few points far from the rest (a
// scanner's own position) move neither the box nor the origin settleOrigin takes from it; the
// whole box would put them inside and estimate the spacing from its diagonal.
constexpr std::size_t kMiddleSample = 1 << 16;
std::pair<glm::dvec3, glm::dvec3> middleBox(std::span<const glm::dvec3> exact) {
    const std::size_t stride = (exact.size() + kMiddleSample - 1) / kMiddleSample;
    std::vector<double> axis;
    axis.reserve(exact.size() / stride + 1);
    glm::dvec3 lo{0.0}, hi{0.0};
    for (int a = 0; a < 3; ++a) {
        axis.clear();
        for (std::size_t i = 0; i < exact.size(); i += stride)
            if (exact[i] != glm::dvec3(0.0)) axis.push_back(exact[i][a]);
        if (axis.empty()) return {};
        std::sort(axis.begin(), axis.end());
        const std::size_t m = axis.size();
        const double quartiles = axis[3 * m / 4] - axis[m / 4];
        lo[a] = axis[m / 2] - quartiles;
        hi[a] = axis[m / 2] + quartiles;
    }
    return {lo, hi};
}

} // namespace

void settleOrigin(PlyData& data) {
    const std::vector<glm::dvec3> exact = std::move(data.farPositions);
    data.farPositions = {};
    PointSet& points = data.points;
    const std::size_t n = points.size();
    if (n < 2 || exact.size() < n) return;
    const auto [lo, hi] = middleBox(std::span(exact).first(n));
    const double diagonal = glm::length(hi - lo);
    const double largest = std::max(
        {std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x), std::abs(hi.y), std::abs(hi.z)});
    int exponent = 0;
    std::frexp(largest, &exponent);                     // largest in [2^(exponent-1), 2^exponent)
    const double step = std::ldexp(1.0, exponent - 24); // a float's step there
    const double spacing = diagonal / std::sqrt(static_cast<double>(n)); // about, for a surface
    if (!(diagonal > 0.0) || !(step > kOriginStep * spacing)) return;
    // Single precision in the file itself: rounded so already.
    const bool singles = std::all_of(exact.begin(), exact.begin() + static_cast<std::ptrdiff_t>(n),
                                     [](const glm::dvec3& p) { return glm::dvec3(glm::vec3(p)) == p; });
    if (singles && step > kCoarseStep * spacing) data.roundedBy = step / spacing;
    // A multiple of the power of two at or above the diagonal: mostly the same origin for the model
    // and for what is made of it (a refinement's centre moves far less than that, unless it lies
    // near a multiple's boundary or its diagonal crosses a power of two).
    const double grid = std::exp2(std::ceil(std::log2(diagonal)));
    data.origin = glm::round(0.5 * (lo + hi) / grid) * grid;
    for (std::size_t i = 0; i < n; ++i) points.position[i] = glm::vec3(exact[i] - data.origin);
}

const char* storeRow(PlyData& data, const RowLayout& layout, std::size_t i,
                     const std::array<double, kRowSlots>& v) {
    PointSet& points = data.points;
    // Kept in double from the first point that lies far from 0 on, for settleOrigin; the rows
    // before it, near 0, as the floats they were stored as (a scanner's own position, or invalid
    // returns written as 0 0 0, before the scan).
    if (data.farPositions.empty() &&
        std::max({std::abs(v[kX]), std::abs(v[kY]), std::abs(v[kZ])}) >= kOriginFrom) {
        data.farPositions.resize(points.size());
        std::copy(points.position.begin(), points.position.begin() + static_cast<std::ptrdiff_t>(i),
                  data.farPositions.begin());
    }
    if (!data.farPositions.empty()) data.farPositions[i] = glm::dvec3(v[kX], v[kY], v[kZ]);
    const auto x = static_cast<float>(v[kX]);
    const auto y = static_cast<float>(v[kY]);
    const auto z = static_cast<float>(v[kZ]);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return "non-finite coordinate";
    points.position[i] = glm::vec3(x, y, z);
    if (layout.normal) {
        if (!finiteFloats(v[kNx], v[kNy], v[kNz])) return "non-finite normal";
        const auto n = unitDirection(v[kNx], v[kNy], v[kNz]);
        // Zero normals are kept while every row before has one too (settleZeroNormals).
        const bool noneBefore = i == 0 || points.normal[i - 1] == glm::vec3(0.0f);
        if (!n && !noneBefore) return "zero-length normal";
        if (n && i > 0 && noneBefore) return "a normal after rows whose normals are zero";
        points.normal[i] = n ? *n : glm::vec3(0.0f);
    }
    if (layout.crease) {
        if (!finiteFloats(v[kNx2], v[kNy2], v[kNz2])) return "non-finite crease normal";
        const auto n = unitDirection(v[kNx2], v[kNy2], v[kNz2]);
        bool ordinary = false;
        if (layout.creaseFlag) {
            if (!std::isfinite(v[kCreaseFlag])) return "non-finite crease flag";
            ordinary = v[kCreaseFlag] == 0.0;
        } else {
            ordinary = (v[kNx2] == 0.0 && v[kNy2] == 0.0 && v[kNz2] == 0.0) || (n && *n == points.normal[i]);
        }
        if (!ordinary && !n) return "crease normal of a crease point is not a direction";
        points.crease[i] = ordinary ? glm::vec3(0.0f) : *n;
    }
    if (layout.radius) {
        const auto r = static_cast<float>(v[kRadius]);
        if (!std::isfinite(r) || r < 0.0f) return "negative or non-finite radius";
        points.radius[i] = r;
    }
    return nullptr;
}

} // namespace pnsplat::detail
