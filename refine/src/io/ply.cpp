// PLY input and output of oriented point sets: a header parser, a binary reader (either byte
// order) that walks rows through a precomputed offset/type table, an ascii reader on
// std::from_chars, validation of every point, and a writer through OutputFile (output_file.h).
#include "pnsplat/refine/io/ply.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iterator>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

#include <fmt/core.h>

#include "pnsplat/refine/io/output_file.h"
#include "point_rows.h"

namespace pnsplat {
namespace {

namespace fs = std::filesystem;

using detail::fail;
using detail::FileData;
using detail::guarded;
using detail::kMaxHeaderBytes;
using detail::parseCount;
using detail::printable;
using detail::readWholeFile;
using detail::splitWords;
using detail::unitDirection; // normals: kept bit for bit within 1e-6 of unit length, else normalised

// ---------------------------------------------------------------------------------------------
// Header model

bool isFloating(ScalarType type) {
    return type == ScalarType::Float32 || type == ScalarType::Float64;
}

std::optional<ScalarType> parseScalarType(std::string_view name) {
    static constexpr std::pair<std::string_view, ScalarType> kNames[] = {
        {"char", ScalarType::Int8},       {"int8", ScalarType::Int8},       {"uchar", ScalarType::UInt8},
        {"uint8", ScalarType::UInt8},     {"short", ScalarType::Int16},     {"int16", ScalarType::Int16},
        {"ushort", ScalarType::UInt16},   {"uint16", ScalarType::UInt16},   {"int", ScalarType::Int32},
        {"int32", ScalarType::Int32},     {"uint", ScalarType::UInt32},     {"uint32", ScalarType::UInt32},
        {"float", ScalarType::Float32},   {"float32", ScalarType::Float32}, {"double", ScalarType::Float64},
        {"float64", ScalarType::Float64},
    };
    for (const auto& [spelling, type] : kNames)
        if (spelling == name) return type;
    return std::nullopt;
}

// The name a header gives a type (writing).
std::string_view scalarTypeName(ScalarType type) {
    static constexpr std::string_view kNames[] = {"char", "uchar", "short", "ushort",
                                                  "int",  "uint",  "float", "double"};
    return kNames[static_cast<std::size_t>(type)];
}

struct Property {
    std::string name;
    ScalarType type = ScalarType::Float32; // the item type for lists
    bool isList = false;
    ScalarType countType = ScalarType::UInt8; // lists only
};

struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;

    bool hasLists() const {
        return std::any_of(properties.begin(), properties.end(), [](const Property& p) { return p.isList; });
    }
    int find(std::string_view propertyName) const {
        for (std::size_t i = 0; i < properties.size(); ++i)
            if (properties[i].name == propertyName) return static_cast<int>(i);
        return -1;
    }
};

enum class Encoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct Header {
    Encoding encoding = Encoding::Ascii;
    std::vector<Element> elements;
    std::vector<std::string> comments; // `comment` and `obj_info` lines, from the keyword on
    std::size_t bodyOffset = 0;
};

// The vertex attributes the reader keeps, as slots of one row of values.
// Crease points (ALGORITHM.md §6.1), in the convention of ../shared/data's fandisk files: `nx2 ny2 nz2` the
// second normal and an optional `crease` flag (0 an ordinary point, whose n2 repeats n; 1 a crease
// point; 2 a corner, given as the crease of its two largest sectors). Without the flag a point is
// ordinary when n2 is zero or equal to n.
enum Slot : int {
    kX,
    kY,
    kZ,
    kNx,
    kNy,
    kNz,
    kRed,
    kGreen,
    kBlue,
    kRadius,
    kNx2,
    kNy2,
    kNz2,
    kCreaseFlag,
    kSlotCount
};
constexpr std::array<std::string_view, kSlotCount> kSlotNames = {
    "x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "radius", "nx2", "ny2", "nz2", "crease"};
// Other names of a slot, read where the file has none of the name above: PCL's normals.
constexpr std::array<std::string_view, kSlotCount> kSlotAliases = {
    "", "", "", "normal_x", "normal_y", "normal_z", "", "", "", "", "", "", "", ""};

// What is wrong with a header line, if anything (the reader names the line).
using LineProblem = std::optional<std::string_view>;

// A `format <type> 1.0` line.
LineProblem readFormat(const std::vector<std::string_view>& words, Header& header, bool& haveFormat) {
    if (haveFormat) return "second format line";
    if (words.size() != 3) return "expected 'format <type> 1.0'";
    if (words[1] == "ascii")
        header.encoding = Encoding::Ascii;
    else if (words[1] == "binary_little_endian")
        header.encoding = Encoding::BinaryLittleEndian;
    else if (words[1] == "binary_big_endian")
        header.encoding = Encoding::BinaryBigEndian;
    else
        return "unknown format";
    if (words[2] != "1.0") return "unsupported format version";
    haveFormat = true;
    return std::nullopt;
}

// An `element <name> <count>` line.
LineProblem readElement(const std::vector<std::string_view>& words, Header& header) {
    if (words.size() != 3) return "expected 'element <name> <count>'";
    const auto count = parseCount(words[2]);
    if (!count) return "element count is not a non-negative integer";
    for (const Element& e : header.elements)
        if (e.name == words[1]) return "second element of the same name";
    header.elements.push_back(Element{std::string(words[1]), *count, {}});
    return std::nullopt;
}

// A `property <type> <name>` or `property list <type> <type> <name>` line, of the last element.
LineProblem readProperty(const std::vector<std::string_view>& words, Header& header) {
    if (header.elements.empty()) return "property before any element";
    Property property;
    if (words.size() == 3) {
        const auto type = parseScalarType(words[1]);
        if (!type) return "unknown property type";
        property.type = *type;
        property.name = std::string(words[2]);
    } else if (words.size() == 5 && words[1] == "list") {
        const auto countType = parseScalarType(words[2]);
        const auto itemType = parseScalarType(words[3]);
        if (!countType || !itemType) return "unknown property type";
        if (isFloating(*countType)) return "list count type must be an integer type";
        property.isList = true;
        property.countType = *countType;
        property.type = *itemType;
        property.name = std::string(words[4]);
    } else {
        return "expected 'property <type> <name>' or 'property list <type> <type> <name>'";
    }
    Element& element = header.elements.back();
    if (element.find(property.name) >= 0) return "second property of the same name";
    element.properties.push_back(std::move(property));
    return std::nullopt;
}

Result<Header> parseHeader(std::string_view data, std::string_view file) {
    if (data.empty()) return fail(file, "empty file");
    if (data.size() < 4 || data.substr(0, 3) != "ply" || (data[3] != '\n' && data[3] != '\r'))
        return fail(file, "not a PLY file (does not start with 'ply')");

    Header header;
    bool haveFormat = false;
    std::size_t pos = 0;
    int lineNumber = 0;
    while (true) {
        const std::size_t newline = data.find('\n', pos);
        if (newline == std::string_view::npos || newline >= kMaxHeaderBytes) {
            if (newline == std::string_view::npos && data.size() < kMaxHeaderBytes)
                return fail(file, "malformed header: no end_header line");
            return fail(file, fmt::format("malformed header: no end_header within the first {} KiB",
                                          kMaxHeaderBytes / 1024));
        }
        std::string_view line = data.substr(pos, newline - pos);
        pos = newline + 1;
        ++lineNumber;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        const auto words = splitWords(line);
        const auto bad = [&](std::string_view what) {
            return fail(
                file, fmt::format("malformed header line {}: {} ('{}')", lineNumber, what, printable(line)));
        };
        if (lineNumber == 1) {
            if (words.size() != 1 || words[0] != "ply") return bad("expected 'ply'");
            continue;
        }
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "comment" || keyword == "obj_info") {
            header.comments.emplace_back(line.substr(static_cast<std::size_t>(keyword.data() - line.data())));
            continue;
        }
        if (keyword == "end_header") {
            if (words.size() != 1) return bad("unexpected words after end_header");
            break;
        }
        LineProblem problem = "unknown keyword";
        if (keyword == "format")
            problem = readFormat(words, header, haveFormat);
        else if (keyword == "element")
            problem = readElement(words, header);
        else if (keyword == "property")
            problem = readProperty(words, header);
        if (problem) return bad(*problem);
    }
    if (!haveFormat) return fail(file, "malformed header: no format line");
    header.bodyOffset = pos;
    return header;
}

// ---------------------------------------------------------------------------------------------
// Storing and checking one vertex

// A vertex row's values: the slots, then one per attribute (slot kSlotCount + a).
using RowValues = std::vector<double>;

struct VertexLayout {
    std::array<int, kSlotCount> property{}; // index of the property of each slot, or -1
    std::array<ScalarType, kSlotCount> type{};
    // The scalar properties that become attributes (PointSet::attributes), in file order: every
    // one of a detail::attributeName (not reserved: not a slot's name, so that a partial colour or
    // crease normal stays unused, nor another format's such name; printable, no space or comma).
    std::vector<int> attributeProperty;
    bool hasNormal = false;
    bool hasColour = false;
    bool hasRadius = false;
    bool hasCrease = false;
};

Result<VertexLayout> vertexLayout(const Element& vertex, const PlyReadOptions& options,
                                  std::string_view file) {
    VertexLayout layout;
    for (int s = 0; s < kSlotCount; ++s) {
        int p = vertex.find(kSlotNames[s]);
        if (p < 0 && !kSlotAliases[s].empty()) p = vertex.find(kSlotAliases[s]);
        layout.property[s] = p;
        if (p < 0) continue;
        if (vertex.properties[p].isList)
            return fail(file, fmt::format("vertex property '{}' is a list", vertex.properties[p].name));
        layout.type[s] = vertex.properties[p].type;
    }
    const auto has = [&](int s) { return layout.property[s] >= 0; };
    const auto missing = [&](int s) {
        return fail(file, kSlotAliases[s].empty()
                              ? fmt::format("vertex element has no '{}' property", kSlotNames[s])
                              : fmt::format("vertex element has no '{}' (or '{}') property", kSlotNames[s],
                                            kSlotAliases[s]));
    };
    for (int s : {kX, kY, kZ})
        if (!has(s)) return missing(s);
    layout.hasNormal = has(kNx) && has(kNy) && has(kNz);
    const bool normalsOptional = options.readFaces || !options.requireNormals;
    if (!layout.hasNormal && !(normalsOptional && !has(kNx) && !has(kNy) && !has(kNz))) {
        for (int s : {kNx, kNy, kNz})
            if (!has(s)) return missing(s);
    }
    layout.hasColour = has(kRed) && has(kGreen) && has(kBlue);
    layout.hasRadius = has(kRadius);
    layout.hasCrease = layout.hasNormal && has(kNx2) && has(kNy2) && has(kNz2);
    if (!layout.hasCrease)
        layout.property[kNx2] = layout.property[kNy2] = layout.property[kNz2] = layout.property[kCreaseFlag] =
            -1;
    if (!layout.hasNormal) layout.property[kNx] = layout.property[kNy] = layout.property[kNz] = -1;
    if (!layout.hasColour) layout.property[kRed] = layout.property[kGreen] = layout.property[kBlue] = -1;
    for (std::size_t p = 0; p < vertex.properties.size(); ++p)
        if (!vertex.properties[p].isList && detail::attributeName(vertex.properties[p].name))
            layout.attributeProperty.push_back(static_cast<int>(p));
    return layout;
}

std::uint8_t toColourByte(double value, ScalarType type) {
    if (isFloating(type)) value = std::round(value * 255.0);
    return static_cast<std::uint8_t>(std::clamp(value, 0.0, 255.0));
}

// The attributes of a vertex row as every reader stores them (point_rows.h).
detail::RowLayout rowLayout(const VertexLayout& layout) {
    return {layout.hasNormal, layout.hasRadius, layout.hasCrease, layout.property[kCreaseFlag] >= 0};
}

// Stores row `i` (values by slot) into `points`: the checks every reader shares (detail::storeRow),
// then the colour and the attributes (any value, NaN too); returns the problem, or nullptr when valid.
const char* storeVertex(PlyData& data, const VertexLayout& layout, std::size_t i, const RowValues& v) {
    const std::array<double, detail::kRowSlots> row = {
        v[kX], v[kY], v[kZ], v[kNx], v[kNy], v[kNz], v[kRadius], v[kNx2], v[kNy2], v[kNz2], v[kCreaseFlag]};
    PointSet& points = data.points;
    if (const char* problem = detail::storeRow(data, rowLayout(layout), i, row)) return problem;
    if (layout.hasColour) {
        if (!std::isfinite(v[kRed]) || !std::isfinite(v[kGreen]) || !std::isfinite(v[kBlue]))
            return "non-finite colour";
        points.colour[i] = glm::u8vec3(toColourByte(v[kRed], layout.type[kRed]),
                                       toColourByte(v[kGreen], layout.type[kGreen]),
                                       toColourByte(v[kBlue], layout.type[kBlue]));
    }
    for (std::size_t a = 0; a < points.attributes.size(); ++a)
        points.attributes[a].values[i] = v[kSlotCount + a];
    return nullptr;
}

// Sizes `points` for n vertices of `vertex` read through `layout`, attributes included.
void sizePoints(PointSet& points, const Element& vertex, const VertexLayout& layout, std::size_t n) {
    detail::sizePoints(points, rowLayout(layout), layout.hasColour, n);
    points.attributes.clear();
    for (const int p : layout.attributeProperty)
        points.attributes.push_back(
            Attribute{std::string(vertex.properties[p].name), vertex.properties[p].type, {}});
    for (Attribute& a : points.attributes) a.values.resize(n);
}

// The values of a row of `layout`.
RowValues rowValues(const VertexLayout& layout) {
    return RowValues(kSlotCount + layout.attributeProperty.size(), 0.0);
}

// The property of a face element that lists its vertices, or -1.
int faceListIndex(const Element& face) {
    for (std::string_view name : {"vertex_indices", "vertex_index"}) {
        const int p = face.find(name);
        if (p >= 0 && face.properties[p].isList) return p;
    }
    return -1;
}

// The rows of an element read property by property (binary elements with lists, every ascii one).
struct Rows {
    std::size_t count = 0;
    int faceList = -1;       // the property of a face's vertex indices; -1 unless faces are read
    std::vector<int> slotOf; // per property, its vertex slot (-1 for properties that are skipped)
};

// Checks that the rows of `element` fit: at most `available` remain in the file's `encoding`
// ("binary", "ascii") body, and a face element read has its index list. Then sizes the outputs
// for them and maps the properties to vertex slots.
Result<Rows> prepareRows(std::string_view file, std::string_view encoding, const Element& element,
                         std::uint64_t available, bool isVertex, bool isFace, const VertexLayout& layout,
                         PlyData& out) {
    if (element.count > available)
        return fail(file, fmt::format("truncated {} data ({} element of {} rows, room for at most {})",
                                      encoding, printable(element.name), element.count, available));
    Rows rows;
    rows.count = static_cast<std::size_t>(element.count);
    rows.faceList = isFace ? faceListIndex(element) : -1;
    if (isFace && rows.faceList < 0) return fail(file, "face element has no vertex_indices list");
    if (isVertex) sizePoints(out.points, element, layout, rows.count);
    if (isFace) out.triangles.reserve(out.triangles.size() + rows.count);
    rows.slotOf.assign(element.properties.size(), -1);
    if (isVertex) {
        for (int s = 0; s < kSlotCount; ++s)
            if (layout.property[s] >= 0) rows.slotOf[layout.property[s]] = s;
        for (std::size_t a = 0; a < layout.attributeProperty.size(); ++a)
            rows.slotOf[layout.attributeProperty[a]] = kSlotCount + static_cast<int>(a);
    }
    return rows;
}

// Face lists: fan-triangulates one polygon, checking its indices fit in 32 bits (their range
// against the vertex count is checked once every element has been read).
const char* addPolygon(std::vector<glm::u32vec3>& triangles, const double* indices, std::size_t n) {
    if (n < 3) return "fewer than 3 vertices";
    for (std::size_t k = 0; k < n; ++k) {
        const double index = indices[k];
        if (!(index >= 0.0) || index > 4294967295.0 || index != std::floor(index))
            return "invalid vertex index";
    }
    const auto at = [&](std::size_t k) { return static_cast<std::uint32_t>(indices[k]); };
    for (std::size_t k = 1; k + 1 < n; ++k) triangles.emplace_back(at(0), at(k), at(k + 1));
    return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Binary body

template <typename T>
T byteSwap(T value) {
    if constexpr (sizeof(T) == 2)
        return static_cast<T>(__builtin_bswap16(value));
    else if constexpr (sizeof(T) == 4)
        return __builtin_bswap32(value);
    else
        return __builtin_bswap64(value);
}

template <bool kSwap, typename Bits>
Bits loadBits(const unsigned char* p) {
    Bits bits;
    std::memcpy(&bits, p, sizeof bits);
    if constexpr (kSwap) bits = byteSwap(bits);
    return bits;
}

template <bool kSwap>
double loadScalar(const unsigned char* p, ScalarType type) {
    switch (type) {
    case ScalarType::Int8:
        return static_cast<std::int8_t>(p[0]);
    case ScalarType::UInt8:
        return p[0];
    case ScalarType::Int16:
        return static_cast<std::int16_t>(loadBits<kSwap, std::uint16_t>(p));
    case ScalarType::UInt16:
        return loadBits<kSwap, std::uint16_t>(p);
    case ScalarType::Int32:
        return static_cast<std::int32_t>(loadBits<kSwap, std::uint32_t>(p));
    case ScalarType::UInt32:
        return loadBits<kSwap, std::uint32_t>(p);
    case ScalarType::Float32:
        return std::bit_cast<float>(loadBits<kSwap, std::uint32_t>(p));
    case ScalarType::Float64:
        return std::bit_cast<double>(loadBits<kSwap, std::uint64_t>(p));
    }
    return 0.0;
}

struct Field {
    int slot;
    std::size_t offset; // within a fixed-layout row
    ScalarType type;
};

// White space between ascii values, and after a body.
bool isSpace(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

// "vertex 3, face 1": each element and its count.
std::string declaredRows(const Header& header) {
    std::string rows;
    for (const Element& element : header.elements)
        rows += fmt::format("{}{} {}", rows.empty() ? "" : ", ", printable(element.name), element.count);
    return rows;
}

class BinaryReader {
  public:
    BinaryReader(std::string_view body, std::string_view file, const PlyReadOptions& options)
        : data_(reinterpret_cast<const unsigned char*>(body.data())), size_(body.size()), file_(file),
          options_(options) {}

    template <bool kSwap>
    Result<void> read(const Header& header, const VertexLayout& layout, PlyData& out) {
        for (const Element& element : header.elements) {
            const bool isVertex = element.name == "vertex";
            const bool isFace = element.name == "face" && options_.readFaces;
            Result<void> result = element.hasLists()
                                      ? readRows<kSwap>(element, isVertex, isFace, layout, out)
                                      : readFixed<kSwap>(element, isVertex, isFace, layout, out);
            if (!result) return result;
        }
        // Rows beyond the header's counts (a count not updated) would be lost unseen, as in ascii
        // bodies; white space or zero bytes after the data, which some writers leave (a line
        // break, padding), are no rows.
        const auto isPadding = [](unsigned char c) { return c == 0 || isSpace(static_cast<char>(c)); };
        if (!std::all_of(data_ + pos_, data_ + size_, isPadding))
            return fail(file_, fmt::format("{} bytes after the last row the header declares ({})",
                                           remaining(), declaredRows(header)));
        return {};
    }

  private:
    std::size_t remaining() const { return size_ - pos_; }

    Error truncated(const Element& element, std::uint64_t row) const {
        return fail(file_, fmt::format("truncated binary data ({} {} of {})", printable(element.name), row,
                                       element.count));
    }

    // Elements of scalars only: one stride, offsets known in advance.
    template <bool kSwap>
    Result<void> readFixed(const Element& element, bool isVertex, bool isFace, const VertexLayout& layout,
                           PlyData& out) {
        if (isFace) return fail(file_, "face element has no vertex_indices list");
        std::size_t stride = 0;
        std::vector<std::size_t> offsets;
        for (const Property& p : element.properties) {
            offsets.push_back(stride);
            stride += scalarTypeBytes(p.type);
        }
        if (stride == 0) return {};
        const std::uint64_t available = remaining() / stride;
        if (element.count > available) return truncated(element, available);
        const auto count = static_cast<std::size_t>(element.count);
        if (isVertex) {
            std::vector<Field> fields;
            for (int s = 0; s < kSlotCount; ++s)
                if (layout.property[s] >= 0)
                    fields.push_back({s, offsets[layout.property[s]], layout.type[s]});
            for (std::size_t a = 0; a < layout.attributeProperty.size(); ++a) {
                const int p = layout.attributeProperty[a];
                fields.push_back({kSlotCount + static_cast<int>(a), offsets[p], element.properties[p].type});
            }
            sizePoints(out.points, element, layout, count);
            RowValues values = rowValues(layout);
            for (std::size_t i = 0; i < count; ++i) {
                const unsigned char* row = data_ + pos_ + i * stride;
                for (const Field& f : fields) values[f.slot] = loadScalar<kSwap>(row + f.offset, f.type);
                if (const char* problem = storeVertex(out, layout, i, values))
                    return fail(file_, fmt::format("{} at vertex {}", problem, i));
            }
        }
        pos_ += count * stride;
        return {};
    }

    // Elements with lists: each row is walked property by property.
    template <bool kSwap>
    Result<void> readRows(const Element& element, bool isVertex, bool isFace, const VertexLayout& layout,
                          PlyData& out) {
        // Every row holds at least its list counts and scalars: bound the count before allocating.
        std::size_t minRow = 0;
        for (const Property& p : element.properties)
            minRow += scalarTypeBytes(p.isList ? p.countType : p.type);
        const Result<Rows> rows =
            prepareRows(file_, "binary", element, remaining() / minRow, isVertex, isFace, layout, out);
        if (!rows) return rows.error();
        const auto& [count, faceList, slotOf] = *rows;
        RowValues values = rowValues(layout);
        for (std::size_t i = 0; i < count; ++i) {
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.isList) {
                    const std::size_t size = scalarTypeBytes(property.type);
                    if (remaining() < size) return truncated(element, i);
                    if (slotOf[p] >= 0) values[slotOf[p]] = loadScalar<kSwap>(data_ + pos_, property.type);
                    pos_ += size;
                    continue;
                }
                const std::size_t countSize = scalarTypeBytes(property.countType);
                if (remaining() < countSize) return truncated(element, i);
                const double n = loadScalar<kSwap>(data_ + pos_, property.countType);
                pos_ += countSize;
                if (n < 0.0)
                    return fail(file_,
                                fmt::format("negative list length ({} {})", printable(element.name), i));
                const auto length = static_cast<std::size_t>(n);
                const std::size_t itemSize = scalarTypeBytes(property.type);
                if (length > remaining() / itemSize) return truncated(element, i);
                if (static_cast<int>(p) == faceList) {
                    indices_.resize(length);
                    for (std::size_t k = 0; k < length; ++k)
                        indices_[k] = loadScalar<kSwap>(data_ + pos_ + k * itemSize, property.type);
                    if (const char* problem = addPolygon(out.triangles, indices_.data(), length))
                        return fail(file_, fmt::format("{} in face {}", problem, i));
                }
                pos_ += length * itemSize;
            }
            if (isVertex)
                if (const char* problem = storeVertex(out, layout, i, values))
                    return fail(file_, fmt::format("{} at vertex {}", problem, i));
        }
        return {};
    }

    const unsigned char* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
    std::string_view file_;
    const PlyReadOptions& options_;
    std::vector<double> indices_;
};

// ---------------------------------------------------------------------------------------------
// Ascii body

class AsciiReader {
  public:
    AsciiReader(std::string_view body, std::string_view file, const PlyReadOptions& options,
                std::uint64_t firstLine)
        : p_(body.data()), end_(body.data() + body.size()), file_(file), options_(options), line_(firstLine) {
    }

    Result<void> read(const Header& header, const VertexLayout& layout, PlyData& out) {
        for (const Element& element : header.elements) {
            Result<void> result = readElement(element, layout, out);
            if (!result) return result;
        }
        // Rows beyond the header's counts (a count not updated by hand) would be lost unseen.
        if (const std::string_view token = nextToken(); !token.empty())
            return fail(file_, fmt::format("line {}: '{}' after the last row the header declares ({})", line_,
                                           printable(token), declaredRows(header)));
        return {};
    }

  private:
    std::size_t remaining() const { return static_cast<std::size_t>(end_ - p_); }

    std::string_view nextToken() {
        while (p_ < end_ && isSpace(*p_)) {
            if (*p_ == '\n') ++line_;
            ++p_;
        }
        const char* start = p_;
        while (p_ < end_ && !isSpace(*p_)) ++p_;
        return {start, static_cast<std::size_t>(p_ - start)};
    }

    // Parses one value of `type`; false when the token is not such a number.
    static bool parseValue(std::string_view token, ScalarType type, double& value) {
        const char* first = token.data();
        const char* last = token.data() + token.size();
        if (first != last && *first == '+') ++first;
        if (type == ScalarType::Float32) {
            float f = 0.0f;
            const auto [end, ec] = std::from_chars(first, last, f);
            if (ec != std::errc() || end != last) return false;
            value = f;
            return true;
        }
        if (type == ScalarType::Float64) {
            const auto [end, ec] = std::from_chars(first, last, value);
            return ec == std::errc() && end == last;
        }
        std::int64_t i = 0;
        const auto [end, ec] = std::from_chars(first, last, i);
        if (ec != std::errc() || end != last) return false;
        // The range of each integer type, in the order of ScalarType.
        constexpr std::array<std::pair<std::int64_t, std::int64_t>, 6> kRange{{{INT8_MIN, INT8_MAX},
                                                                               {0, UINT8_MAX},
                                                                               {INT16_MIN, INT16_MAX},
                                                                               {0, UINT16_MAX},
                                                                               {INT32_MIN, INT32_MAX},
                                                                               {0, UINT32_MAX}}};
        const auto [lo, hi] = kRange[static_cast<std::size_t>(type)];
        if (i < lo || i > hi) return false;
        value = static_cast<double>(i);
        return true;
    }

    Error truncated(const Element& element, std::uint64_t row) const {
        return fail(file_, fmt::format("truncated ascii data ({} {} of {})", printable(element.name), row,
                                       element.count));
    }

    // A row's values lie on one line (rowLine_, the line of its first value), so that a line with
    // a value too few or too many is an error there, not a shift of every value after it.
    Error shortRow(const Element& element, std::uint64_t row) const {
        return fail(file_, fmt::format("line {}: fewer values than {} {} has properties ({})", rowLine_,
                                       printable(element.name), row, element.properties.size()));
    }

    Result<void> readValue(const Element& element, std::size_t row, ScalarType type, double& value) {
        const std::string_view token = nextToken();
        if (token.empty()) return truncated(element, row);
        if (firstOfRow_) {
            rowLine_ = line_;
            firstOfRow_ = false;
        } else if (line_ != rowLine_) {
            return shortRow(element, row);
        }
        if (!parseValue(token, type, value))
            return fail(file_, fmt::format("bad number '{}' at line {} ({} {})", printable(token), line_,
                                           printable(element.name), row));
        return {};
    }

    Result<void> readElement(const Element& element, const VertexLayout& layout, PlyData& out) {
        const bool isVertex = element.name == "vertex";
        const bool isFace = element.name == "face" && options_.readFaces;
        if (element.properties.empty()) return {};
        // n values need at least 2n - 1 characters: bound the count before allocating.
        const std::uint64_t available = (remaining() / 2 + 1) / element.properties.size();
        const Result<Rows> rows =
            prepareRows(file_, "ascii", element, available, isVertex, isFace, layout, out);
        if (!rows) return rows.error();
        const auto& [count, faceList, slotOf] = *rows;
        RowValues values = rowValues(layout);
        double scratch = 0.0;
        for (std::size_t i = 0; i < count; ++i) {
            firstOfRow_ = true;
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.isList) {
                    Result<void> r =
                        readValue(element, i, property.type, slotOf[p] >= 0 ? values[slotOf[p]] : scratch);
                    if (!r) return r;
                    continue;
                }
                double n = 0.0;
                Result<void> r = readValue(element, i, property.countType, n);
                if (!r) return r;
                if (n < 0.0)
                    return fail(file_, fmt::format("negative list length at line {} ({} {})", line_,
                                                   printable(element.name), i));
                const auto length = static_cast<std::size_t>(n);
                if (length > remaining() / 2 + 1) return truncated(element, i);
                const bool keep = static_cast<int>(p) == faceList;
                if (keep) indices_.resize(length);
                for (std::size_t k = 0; k < length; ++k) {
                    Result<void> rk = readValue(element, i, property.type, keep ? indices_[k] : scratch);
                    if (!rk) return rk;
                }
                if (keep)
                    if (const char* problem = addPolygon(out.triangles, indices_.data(), length))
                        return fail(file_, fmt::format("{} in face {} (line {})", problem, i, line_));
            }
            if (!atEndOfLine())
                return fail(file_,
                            fmt::format("line {}: more values than {} {} has properties ({})", rowLine_,
                                        printable(element.name), i, element.properties.size()));
            if (isVertex)
                if (const char* problem = storeVertex(out, layout, i, values))
                    return fail(file_, fmt::format("{} at vertex {} (line {})", problem, i, line_));
        }
        return {};
    }

    // Whether only blanks follow on the current line (or the body ends).
    bool atEndOfLine() {
        while (p_ < end_ && isSpace(*p_) && *p_ != '\n') ++p_;
        return p_ == end_ || *p_ == '\n';
    }

    const char* p_;
    const char* end_;
    std::string_view file_;
    const PlyReadOptions& options_;
    std::uint64_t line_;
    std::uint64_t rowLine_ = 0;
    bool firstOfRow_ = true;
    std::vector<double> indices_;
};

// ---------------------------------------------------------------------------------------------
Result<PlyData> parseBytes(std::string_view bytes, const PlyReadOptions& options, std::string_view file) {
    Result<Header> header = parseHeader(bytes, file);
    if (!header) return header.error();

    const Element* vertex = nullptr;
    for (const Element& e : header->elements)
        if (e.name == "vertex") vertex = &e;
    if (!vertex) return fail(file, "no vertex element");
    Result<VertexLayout> layout = vertexLayout(*vertex, options, file);
    if (!layout) return layout.error();
    if (vertex->count == 0) return fail(file, "no points");

    PlyData out;
    out.comments = std::move(header->comments);
    for (std::size_t p = 0; p < vertex->properties.size(); ++p)
        if (std::find(layout->property.begin(), layout->property.end(), static_cast<int>(p)) ==
                layout->property.end() &&
            std::find(layout->attributeProperty.begin(), layout->attributeProperty.end(),
                      static_cast<int>(p)) == layout->attributeProperty.end())
            out.unusedProperties.push_back(printable(vertex->properties[p].name));
    for (const Element& e : header->elements)
        if (e.name != "vertex" && !(e.name == "face" && options.readFaces))
            out.unusedElements.push_back({printable(e.name), e.count});
    const std::string_view body = bytes.substr(header->bodyOffset);
    Result<void> read;
    switch (header->encoding) {
    case Encoding::Ascii: {
        const auto headerLines = std::count(bytes.begin(), bytes.begin() + header->bodyOffset, '\n');
        read = AsciiReader(body, file, options, static_cast<std::uint64_t>(headerLines) + 1)
                   .read(*header, *layout, out);
        break;
    }
    case Encoding::BinaryLittleEndian:
    case Encoding::BinaryBigEndian: {
        const bool swap =
            (header->encoding == Encoding::BinaryBigEndian) == (std::endian::native == std::endian::little);
        BinaryReader reader(body, file, options);
        read = swap ? reader.read<true>(*header, *layout, out) : reader.read<false>(*header, *layout, out);
        break;
    }
    }
    if (!read) return read.error();
    detail::settleOrigin(out);
    if (Result<void> normals =
            detail::settleZeroNormals(out, options.requireNormals && !options.readFaces, file);
        !normals)
        return normals.error();

    const std::size_t n = out.points.size();
    for (std::size_t t = 0; t < out.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
            if (out.triangles[t][k] >= n)
                return fail(file, fmt::format("a face refers to vertex {} but there are only {} vertices",
                                              out.triangles[t][k], n));
    return out;
}

// ---------------------------------------------------------------------------------------------
// Writing

std::string plyHeader(const PointSet& points, PlyFormat format, std::span<const std::string> comments,
                      bool doublePositions) {
    std::string header =
        fmt::format("ply\nformat {} 1.0\n", format == PlyFormat::Ascii ? "ascii" : "binary_little_endian");
    for (const std::string& line : comments) {
        assert((line.starts_with("comment") || line.starts_with("obj_info")) &&
               line.find('\n') == std::string::npos);
        header += line + '\n';
    }
    header += fmt::format("{}\nelement vertex {}\n", kWrittenByPnsplat, points.size());
    for (const char* name : {"x", "y", "z"})
        header += fmt::format("property {} {}\n", doublePositions ? "double" : "float", name);
    for (const char* name : {"nx", "ny", "nz"}) header += fmt::format("property float {}\n", name);
    if (points.hasRadius()) header += "property float radius\n";
    if (points.hasCrease())
        header += "property float nx2\nproperty float ny2\nproperty float nz2\nproperty uchar crease\n";
    if (points.hasColour()) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    for (const Attribute& a : points.attributes)
        header += fmt::format("property {} {}\n", scalarTypeName(a.type), a.name);
    header += "end_header\n";
    return header;
}

void appendFloatBinary(std::string& out, float value) {
    std::uint32_t bits = std::bit_cast<std::uint32_t>(value);
    if constexpr (std::endian::native == std::endian::big) bits = byteSwap(bits);
    char bytes[4];
    std::memcpy(bytes, &bits, 4);
    out.append(bytes, 4);
}

void appendFloatAscii(std::string& out, float value, char separator) {
    char buffer[32];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
    out.append(buffer, end);
    out += separator;
}

void appendRow(std::string& out, const PointSet& points, std::size_t i, PlyFormat format, glm::dvec3 origin) {
    std::array<float, 10> values{};
    const int floats = detail::rowFloats(points, i, values);
    const int first = detail::doublePositions(origin);
    const bool crease = points.isCrease(i);
    // The bytes after the floats: the crease flag, then the colour.
    std::uint8_t bytes[4];
    int byteCount = 0;
    if (points.hasCrease()) bytes[byteCount++] = crease ? 1 : 0;
    if (points.hasColour())
        for (int k = 0; k < 3; ++k) bytes[byteCount++] = points.colour[i][k];
    if (format == PlyFormat::BinaryLittleEndian) {
        for (int k = 0; k < first; ++k)
            detail::appendScalarBinary(out, ScalarType::Float64, origin[k] + double(values[k]));
        for (int k = first; k < floats; ++k) appendFloatBinary(out, values[k]);
        out.append(reinterpret_cast<const char*>(bytes), static_cast<std::size_t>(byteCount));
        for (const Attribute& a : points.attributes) detail::appendScalarBinary(out, a.type, a.values[i]);
        return;
    }
    const bool more = !points.attributes.empty();
    for (int k = 0; k < first; ++k) {
        detail::appendScalarText(out, ScalarType::Float64, origin[k] + double(values[k]));
        out += ' ';
    }
    for (int k = first; k < floats; ++k)
        appendFloatAscii(out, values[k], (k + 1 < floats || byteCount > 0 || more) ? ' ' : '\n');
    for (int k = 0; k < byteCount; ++k)
        fmt::format_to(std::back_inserter(out), "{}{}", bytes[k], k + 1 < byteCount || more ? ' ' : '\n');
    for (std::size_t a = 0; a < points.attributes.size(); ++a) {
        if (a > 0) out += ' ';
        detail::appendScalarText(out, points.attributes[a].type, points.attributes[a].values[i]);
    }
    if (more) out += '\n';
}

Result<void> writePlyFile(const fs::path& path, const PointSet& points, PlyFormat format,
                          std::span<const std::string> comments, glm::dvec3 origin, std::string_view file) {
    assert(points.normal.size() == points.size());
    assert(!points.hasRadius() || points.radius.size() == points.size());
    assert(!points.hasColour() || points.colour.size() == points.size());
    assert(!points.hasCrease() || points.crease.size() == points.size());
    for ([[maybe_unused]] const Attribute& a : points.attributes) assert(a.values.size() == points.size());
    if (const std::optional<std::string> problem = detail::attributeNameProblem(points))
        return fail(file, *problem);

    std::string buffer = plyHeader(points, format, comments, detail::doublePositions(origin) > 0);
    if (buffer.size() > kMaxHeaderBytes)
        return fail(file, fmt::format("the header comments to carry over take {} KiB, more than a header "
                                      "of {} KiB readPly reads",
                                      (buffer.size() + 1023) / 1024, kMaxHeaderBytes / 1024));
    return detail::writeRows(
        path, format == PlyFormat::Ascii ? OutputContent::Text : OutputContent::Binary, std::move(buffer),
        points.size(), [&](std::string& rows, std::size_t i) { appendRow(rows, points, i, format, origin); });
}

} // namespace

bool writtenByPnsplat(std::span<const std::string> comments) {
    return std::ranges::find(comments, kWrittenByPnsplat) != comments.end();
}

std::string inputName(const std::filesystem::path& path) {
    return path == "-" ? std::string("standard input") : path.string();
}

Result<PlyData> readPly(const std::filesystem::path& path, const PlyReadOptions& options) {
    const std::string file = inputName(path);
    return guarded(file, "reading", [&]() -> Result<PlyData> {
        Result<FileData> data = readWholeFile(path, file);
        if (!data) return data.error();
        return parseBytes(data->view(), options, file);
    });
}

Result<PlyData> parsePly(std::string_view bytes, std::string_view name, const PlyReadOptions& options) {
    return guarded(name, "reading", [&] { return parseBytes(bytes, options, name); });
}

Result<void> writePly(const std::filesystem::path& path, const PointSet& points, PlyFormat format,
                      std::span<const std::string> comments, glm::dvec3 origin) {
    const std::string file = outputName(path);
    return guarded(file, "writing",
                   [&] { return writePlyFile(path, points, format, comments, origin, file); });
}

void moveToOrigin(std::span<glm::vec3> positions, glm::dvec3 from, glm::dvec3 to) {
    if (from == to) return;
    const glm::dvec3 shift = from - to;
    for (glm::vec3& p : positions) p = glm::vec3(glm::dvec3(p) + shift);
}

} // namespace pnsplat
