// PCD files (pcd.h): a header parser, the fields the points use mapped to the slots of a row
// (point_rows.h), an ascii reader on std::from_chars, a binary reader of rows, an LZF decoder for
// binary_compressed columns, and a writer through OutputFile.
#include "pnsplat/refine/io/pcd.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <optional>
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
using detail::parseCount;
using detail::printable;
using detail::splitWords;

// LZF cannot expand a byte of input into more than this many bytes of output (a back reference of
// 264 bytes in 3 bytes), a bound on what a compressed body may claim.
constexpr std::uint64_t kLzfMaxRatio = 90;

// A field's use: a slot of the row, the packed colour, an attribute, or nothing.
constexpr int kUnused = -1;
constexpr int kRgb = 100;
constexpr int kAttribute = 1000; // kAttribute + a: PointSet::attributes[a]

struct Field {
    std::string name;
    char type = 'F';    // F, I or U
    unsigned size = 4;  // bytes of one value
    unsigned count = 1; // values
    int use = kUnused;
    std::size_t offset = 0; // bytes into a binary row
    std::size_t index = 0;  // values into an ascii line
};

enum class Data { Ascii, Binary, BinaryCompressed };

struct Header {
    std::vector<Field> fields;
    std::uint64_t points = 0;
    std::size_t rowBytes = 0;  // a binary row
    std::size_t rowValues = 0; // an ascii line
    Data data = Data::Ascii;
    std::size_t bodyOffset = 0;
    std::uint64_t bodyLine = 0; // the line number of the body's first line
};

int useOf(std::string_view name) {
    static constexpr std::pair<std::string_view, int> kNames[] = {
        {"x", detail::kX},
        {"y", detail::kY},
        {"z", detail::kZ},
        {"normal_x", detail::kNx},
        {"normal_y", detail::kNy},
        {"normal_z", detail::kNz},
        {"nx", detail::kNx},
        {"ny", detail::kNy},
        {"nz", detail::kNz},
        {"radius", detail::kRadius},
        {"nx2", detail::kNx2},
        {"ny2", detail::kNy2},
        {"nz2", detail::kNz2},
        {"crease", detail::kCreaseFlag},
        {"rgb", kRgb},
        {"rgba", kRgb},
    };
    for (const auto& [known, use] : kNames)
        if (known == name) return use;
    return kUnused;
}

// The header's lines as read, before they are checked against each other.
struct HeaderLines {
    std::vector<std::string_view> sizes, types, counts;
    std::optional<std::uint64_t> width, height, points;
    bool haveFields = false, haveData = false;
};

// Reads one header line's keyword and the words after it into `header` and `lines`; returns
// what is wrong with the line, if anything.
std::optional<std::string_view> readKeyword(std::string_view keyword,
                                            const std::vector<std::string_view>& rest, Header& header,
                                            HeaderLines& lines) {
    const auto number = [&](std::optional<std::uint64_t>& into) -> bool {
        if (rest.size() != 1) return false;
        into = parseCount(rest[0]);
        return into.has_value();
    };
    if (keyword == "VERSION" || keyword == "VIEWPOINT") {
        return std::nullopt;
    } else if (keyword == "FIELDS") {
        if (lines.haveFields) return "second FIELDS line";
        if (rest.empty()) return "no fields";
        lines.haveFields = true;
        for (const std::string_view name : rest) header.fields.push_back(Field{std::string(name)});
    } else if (keyword == "SIZE") {
        lines.sizes = rest;
    } else if (keyword == "TYPE") {
        lines.types = rest;
    } else if (keyword == "COUNT") {
        lines.counts = rest;
    } else if (keyword == "WIDTH") {
        if (!number(lines.width)) return "expected 'WIDTH <count>'";
    } else if (keyword == "HEIGHT") {
        if (!number(lines.height)) return "expected 'HEIGHT <count>'";
    } else if (keyword == "POINTS") {
        if (!number(lines.points)) return "expected 'POINTS <count>'";
    } else if (keyword == "DATA") {
        if (rest.size() != 1) return "expected 'DATA ascii|binary|binary_compressed'";
        if (rest[0] == "ascii")
            header.data = Data::Ascii;
        else if (rest[0] == "binary")
            header.data = Data::Binary;
        else if (rest[0] == "binary_compressed")
            header.data = Data::BinaryCompressed;
        else
            return "unknown DATA encoding";
        lines.haveData = true;
    } else {
        return "unknown keyword";
    }
    return std::nullopt;
}

// Reads the header's lines up to and including DATA; sets the body's offset and first line.
Result<HeaderLines> readHeaderLines(std::string_view bytes, std::string_view file, Header& header) {
    HeaderLines lines;
    std::size_t pos = 0;
    std::uint64_t lineNumber = 0;
    while (!lines.haveData) {
        const std::size_t newline = bytes.find('\n', pos);
        if (newline == std::string_view::npos || newline >= detail::kMaxHeaderBytes)
            return fail(file, newline == std::string_view::npos && bytes.size() < detail::kMaxHeaderBytes
                                  ? "malformed PCD header: no DATA line"
                                  : fmt::format("malformed PCD header: no DATA line within the first {} KiB",
                                                detail::kMaxHeaderBytes / 1024));
        std::string_view line = bytes.substr(pos, newline - pos);
        pos = newline + 1;
        ++lineNumber;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.starts_with('#')) continue;
        const std::vector<std::string_view> words = splitWords(line);
        if (words.empty()) continue;
        const std::vector<std::string_view> rest(words.begin() + 1, words.end());
        if (const std::optional<std::string_view> what = readKeyword(words[0], rest, header, lines))
            return fail(file, fmt::format("malformed PCD header line {}: {} ('{}')", lineNumber, *what,
                                          printable(line)));
    }
    header.bodyOffset = pos;
    header.bodyLine = lineNumber + 1;
    return lines;
}

// Checks the fields' SIZE, TYPE and COUNT and lays them out in a row.
Result<void> layOutFields(Header& header, const HeaderLines& lines, std::string_view file) {
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
        Field& field = header.fields[f];
        const std::optional<std::uint64_t> size = parseCount(lines.sizes[f]);
        const std::optional<std::uint64_t> count =
            lines.counts.empty() ? std::uint64_t{1} : parseCount(lines.counts[f]);
        const std::string_view type = lines.types[f];
        const bool validType = type.size() == 1 && (type[0] == 'F' || type[0] == 'I' || type[0] == 'U');
        const bool validSize =
            size && (validType && type[0] == 'F' ? (*size == 4 || *size == 8)
                                                 : (*size == 1 || *size == 2 || *size == 4 || *size == 8));
        if (!validType || !validSize || !count || *count == 0 || *count > 65536)
            return fail(file, fmt::format("malformed PCD header: field '{}' of SIZE {} TYPE {} COUNT {}",
                                          printable(field.name), printable(lines.sizes[f]), printable(type),
                                          lines.counts.empty() ? "1" : printable(lines.counts[f])));
        field.type = type[0];
        field.size = static_cast<unsigned>(*size);
        field.count = static_cast<unsigned>(*count);
        field.offset = header.rowBytes;
        field.index = header.rowValues;
        header.rowBytes += field.size * field.count;
        header.rowValues += field.count;
        field.use = useOf(field.name);
    }
    return {};
}

Result<Header> parseHeader(std::string_view bytes, std::string_view file) {
    if (bytes.empty()) return fail(file, "empty file");
    Header header;
    Result<HeaderLines> read = readHeaderLines(bytes, file, header);
    if (!read) return read.error();
    const HeaderLines& lines = *read;

    const std::size_t n = header.fields.size();
    if (!lines.haveFields) return fail(file, "malformed PCD header: no FIELDS line");
    if (lines.sizes.size() != n || lines.types.size() != n ||
        (!lines.counts.empty() && lines.counts.size() != n))
        return fail(file,
                    fmt::format("malformed PCD header: {} FIELDS but {} SIZE, {} TYPE and {} COUNT values", n,
                                lines.sizes.size(), lines.types.size(),
                                lines.counts.empty() ? n : lines.counts.size()));
    if (!lines.width) return fail(file, "malformed PCD header: no WIDTH line");
    const std::uint64_t width = *lines.width, h = lines.height.value_or(1);
    if (width > (std::uint64_t{1} << 31) || h > (std::uint64_t{1} << 31) ||
        (lines.points && *lines.points != width * h))
        return fail(file, fmt::format("malformed PCD header: POINTS {} is not WIDTH {} x HEIGHT {}",
                                      lines.points ? *lines.points : 0, width, h));
    header.points = width * h;
    if (Result<void> laid = layOutFields(header, lines, file); !laid) return laid.error();
    return header;
}

// The scalar type of a field of one value, or nothing: 64-bit integers, which a double does not
// hold exactly (PointSet::attributes), stay unused.
std::optional<ScalarType> scalarTypeOf(const Field& field) {
    if (field.type == 'F') return field.size == 4 ? ScalarType::Float32 : ScalarType::Float64;
    const bool isSigned = field.type == 'I';
    switch (field.size) {
    case 1:
        return isSigned ? ScalarType::Int8 : ScalarType::UInt8;
    case 2:
        return isSigned ? ScalarType::Int16 : ScalarType::UInt16;
    case 4:
        return isSigned ? ScalarType::Int32 : ScalarType::UInt32;
    default:
        return std::nullopt;
    }
}

// The SIZE and TYPE of a field written for an attribute of `type`.
std::pair<std::string_view, std::string_view> fieldOf(ScalarType type) {
    static constexpr std::pair<std::string_view, std::string_view> kFields[] = {
        {"1", "I"}, {"1", "U"}, {"2", "I"}, {"2", "U"}, {"4", "I"}, {"4", "U"}, {"4", "F"}, {"8", "F"}};
    return kFields[static_cast<std::size_t>(type)];
}

// Maps the fields to the row's slots and to `attributes` (every other field of one value, of a
// type a double holds, of a detail::attributeName; the first of a name; not PCL's padding `_`);
// names the others, but padding, in `unused`.
Result<detail::RowLayout> layoutOf(Header& header, std::string_view file, const PointFileOptions& options,
                                   bool& colour, std::vector<Attribute>& attributes,
                                   std::vector<std::string>& unused) {
    std::array<int, detail::kRowSlots> fieldOf;
    fieldOf.fill(-1);
    int rgb = -1;
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
        Field& field = header.fields[f];
        if (field.use == kUnused) continue;
        int& seen = field.use == kRgb ? rgb : fieldOf[static_cast<std::size_t>(field.use)];
        if (seen >= 0)
            return fail(file, fmt::format("fields '{}' and '{}' give the same attribute",
                                          printable(header.fields[static_cast<std::size_t>(seen)].name),
                                          printable(field.name)));
        if (field.count != 1)
            return fail(
                file, fmt::format("field '{}' has COUNT {}; 1 expected", printable(field.name), field.count));
        if (field.use == kRgb && field.size != 4)
            return fail(file,
                        fmt::format("field '{}' has SIZE {}; 4 expected", printable(field.name), field.size));
        seen = static_cast<int>(f);
    }
    const auto has = [&](int slot) { return fieldOf[static_cast<std::size_t>(slot)] >= 0; };
    for (const int slot : {detail::kX, detail::kY, detail::kZ})
        if (!has(slot))
            return fail(file, fmt::format("no field '{}'", "xyz"[static_cast<std::size_t>(slot)]));
    const int normals = has(detail::kNx) + has(detail::kNy) + has(detail::kNz);
    if (normals != 0 && normals != 3)
        return fail(file, "some of the fields normal_x normal_y normal_z but not all");
    if (normals == 0 && options.requireNormals)
        return fail(file, "no normal fields (normal_x normal_y normal_z)");
    detail::RowLayout layout;
    layout.normal = normals == 3;
    layout.radius = has(detail::kRadius);
    layout.crease = layout.normal && has(detail::kNx2) && has(detail::kNy2) && has(detail::kNz2);
    layout.creaseFlag = layout.crease && has(detail::kCreaseFlag);
    colour = rgb >= 0;
    for (Field& field : header.fields) {
        if ((field.use == detail::kNx2 || field.use == detail::kNy2 || field.use == detail::kNz2) &&
            !layout.crease)
            field.use = kUnused;
        if (field.use == detail::kCreaseFlag && !layout.creaseFlag) field.use = kUnused;
        const std::optional<ScalarType> type = scalarTypeOf(field);
        const auto named = [&](const Attribute& a) { return a.name == field.name; };
        if (field.use == kUnused && field.count == 1 && type && field.name != "_" && // "_": padding
            detail::attributeName(field.name) && std::none_of(attributes.begin(), attributes.end(), named)) {
            field.use = kAttribute + static_cast<int>(attributes.size());
            attributes.push_back(Attribute{field.name, *type, {}});
        }
        if (field.use == kUnused && field.name != "_") unused.push_back(printable(field.name));
    }
    return layout;
}

// A word of an ascii body as the value of an attribute field of `type`: a float's read as a float
// (as the other fields), others' as a double, then representable; false when it is not a number.
bool parseAttributeValue(std::string_view word, ScalarType type, double& value) {
    if (type == ScalarType::Float32) {
        float single = 0.0f;
        if (!detail::parseFloatField(word, single)) return false;
        value = single;
        return true;
    }
    if (word.size() > 1 && word[0] == '+' && word[1] != '-') word.remove_prefix(1);
    const char* end = word.data() + word.size();
    const auto [ptr, ec] = std::from_chars(word.data(), end, value);
    if (word.empty() || ptr != end || ec != std::errc()) return false;
    value = representable(type, value);
    return true;
}

glm::u8vec3 unpackRgb(std::uint32_t bits) {
    return {static_cast<std::uint8_t>(bits >> 16), static_cast<std::uint8_t>(bits >> 8),
            static_cast<std::uint8_t>(bits)};
}

// A value of `field` at `p` (little-endian), as double.
double loadValue(const unsigned char* p, const Field& field) {
    const auto load = [p]<typename T>(T) {
        T value;
        std::memcpy(&value, p, sizeof value);
        return static_cast<double>(value);
    };
    switch (field.type) {
    case 'F':
        return field.size == 4 ? load(float{}) : load(double{});
    case 'I':
        switch (field.size) {
        case 1:
            return load(std::int8_t{});
        case 2:
            return load(std::int16_t{});
        case 4:
            return load(std::int32_t{});
        default:
            return load(std::int64_t{});
        }
    default:
        switch (field.size) {
        case 1:
            return load(std::uint8_t{});
        case 2:
            return load(std::uint16_t{});
        case 4:
            return load(std::uint32_t{});
        default:
            return load(std::uint64_t{});
        }
    }
}

// LZF (liblzf's format, as PCL writes it): `in` into exactly `out`; false for corrupt data.
bool lzfDecompress(const unsigned char* in, std::size_t inSize, unsigned char* out, std::size_t outSize) {
    std::size_t ip = 0, op = 0;
    while (ip < inSize) {
        const unsigned ctrl = in[ip++];
        if (ctrl < 32) { // a run of ctrl + 1 literal bytes
            const std::size_t length = ctrl + 1;
            if (length > inSize - ip || length > outSize - op) return false;
            std::memcpy(out + op, in + ip, length);
            ip += length;
            op += length;
            continue;
        }
        std::size_t length = ctrl >> 5; // a back reference
        if (length == 7) {
            if (ip == inSize) return false;
            length += in[ip++];
        }
        if (ip == inSize) return false;
        const std::size_t back = ((ctrl & 0x1fu) << 8) + in[ip++] + 1;
        length += 2;
        if (back > op || length > outSize - op) return false;
        for (std::size_t k = 0; k < length; ++k, ++op) out[op] = out[op - back]; // may overlap
    }
    return op == outSize;
}

class PcdReader {
  public:
    PcdReader(std::string_view bytes, std::string_view file, const PointFileOptions& options)
        : bytes_(bytes), file_(file), options_(options) {}

    Result<PlyData> read(std::size_t& skipped) {
        Result<Header> header = parseHeader(bytes_, file_);
        if (!header) return header.error();
        header_ = std::move(*header);
        PlyData out;
        Result<detail::RowLayout> layout =
            layoutOf(header_, file_, options_, colour_, out.points.attributes, out.unusedProperties);
        if (!layout) return layout.error();
        layout_ = *layout;
        if (header_.points == 0) return fail(file_, "no points");
        const std::string_view body = bytes_.substr(header_.bodyOffset);
        for (const Field& field : header_.fields)
            if (field.use != kUnused) used_.push_back(&field);
        Result<void> read = header_.data == Data::Ascii ? readAscii(body, out) : readBinary(body, out);
        if (!read) return read.error();
        if (n_ == 0) return fail(file_, fmt::format("no points ({} with a NaN position left out)", skipped_));
        out.points.resize(n_);
        detail::settleOrigin(out);
        if (Result<void> normals = detail::settleZeroNormals(out, options_.requireNormals, file_); !normals)
            return normals.error();
        skipped = skipped_;
        return out;
    }

  private:
    // Stores one point from `values` (by slot) and `rgb`; a NaN position skips it.
    const char* store(const std::array<double, detail::kRowSlots>& values, std::uint32_t rgb, PlyData& out) {
        if (std::isnan(values[detail::kX]) || std::isnan(values[detail::kY]) ||
            std::isnan(values[detail::kZ])) {
            ++skipped_;
            return nullptr;
        }
        if (const char* problem = detail::storeRow(out, layout_, n_, values)) return problem;
        if (colour_) out.points.colour[n_] = unpackRgb(rgb);
        ++n_;
        return nullptr;
    }

    void size(PlyData& out, std::uint64_t points) {
        detail::sizePoints(out.points, layout_, colour_, static_cast<std::size_t>(points));
        for (Attribute& a : out.points.attributes) a.values.resize(static_cast<std::size_t>(points));
    }

    // The value of attribute field `use` of the point being read (that of the next point stored;
    // a point left out is overwritten by the next).
    double& attributeValue(PlyData& out, int use) {
        return out.points.attributes[static_cast<std::size_t>(use - kAttribute)].values[n_];
    }

    Result<void> readAscii(std::string_view body, PlyData& out) {
        // Every point takes a line: bound the count by the lines before allocating.
        const auto lines = static_cast<std::uint64_t>(std::count(body.begin(), body.end(), '\n')) + 1;
        if (header_.points > lines)
            return fail(file_,
                        fmt::format("truncated ascii data ({} lines for {} points)", lines, header_.points));
        size(out, header_.points);
        std::vector<std::string_view> words;
        words.reserve(header_.rowValues + 1);
        std::array<double, detail::kRowSlots> values{};
        std::uint64_t point = 0, lineNumber = header_.bodyLine - 1;
        std::size_t pos = 0;
        while (point < header_.points) {
            if (pos >= body.size())
                return fail(file_,
                            fmt::format("truncated ascii data ({} of {} points)", point, header_.points));
            const std::size_t newline = std::min(body.find('\n', pos), body.size());
            std::string_view line = body.substr(pos, newline - pos);
            pos = newline + 1;
            ++lineNumber;
            words.clear();
            for (std::size_t i = 0; i < line.size() && words.size() <= header_.rowValues;) {
                while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
                const std::size_t start = i;
                while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
                if (i > start) words.push_back(line.substr(start, i - start));
            }
            if (words.empty()) continue;
            const auto lineError = [&](const std::string& problem) {
                return fail(file_, fmt::format("line {}: {}", lineNumber, problem));
            };
            if (words.size() != header_.rowValues)
                return lineError(fmt::format(
                    "{}{} values, expected {}", words.size() > header_.rowValues ? "more than " : "",
                    words.size() > header_.rowValues ? header_.rowValues : words.size(), header_.rowValues));
            std::uint32_t rgb = 0;
            for (const Field* field : used_) {
                const std::string_view word = words[field->index];
                const char* end = word.data() + word.size();
                if (field->use == kRgb) {
                    // PCL writes a packed rgb as the float it is, or as the integer of its bits.
                    std::uint32_t bits = 0;
                    float asFloat = 0.0f;
                    if (const auto [ptr, ec] = std::from_chars(word.data(), end, bits);
                        ec == std::errc() && ptr == end)
                        rgb = bits;
                    else if (detail::parseFloatField(word, asFloat))
                        rgb = std::bit_cast<std::uint32_t>(asFloat);
                    else
                        return lineError(fmt::format("'{}' is not a colour (field {})", printable(word),
                                                     printable(field->name)));
                    continue;
                }
                if (field->use >= kAttribute) {
                    if (!parseAttributeValue(word, *scalarTypeOf(*field), attributeValue(out, field->use)))
                        return lineError(fmt::format("'{}' is not a number (field {})", printable(word),
                                                     printable(field->name)));
                    continue;
                }
                // A position of 8 bytes or an integer in the precision it is written with
                // (PlyData::origin), as the binary reader takes it.
                double& value = values[static_cast<std::size_t>(field->use)];
                float single = 0.0f;
                const bool position = field->use <= detail::kZ && (field->size == 8 || field->type != 'F');
                if (position ? !detail::parseDoubleField(word, value)
                             : !detail::parseFloatField(word, single))
                    return lineError(fmt::format("'{}' is not a number (field {})", printable(word),
                                                 printable(field->name)));
                if (!position) value = single;
            }
            if (const char* problem = store(values, rgb, out)) return lineError(problem);
            ++point;
        }
        // Lines beyond POINTS (a count not updated by hand) would be lost unseen.
        while (pos < body.size()) {
            const std::size_t newline = std::min(body.find('\n', pos), body.size());
            ++lineNumber;
            if (body.substr(pos, newline - pos).find_first_not_of(" \t\r") != std::string_view::npos)
                return fail(file_, fmt::format("line {}: a row after the {} points the header declares",
                                               lineNumber, header_.points));
            pos = newline + 1;
        }
        return {};
    }

    Result<void> readBinary(std::string_view body, PlyData& out) {
        const auto* data = reinterpret_cast<const unsigned char*>(body.data());
        const std::uint64_t need = header_.points * header_.rowBytes; // checked below where it matters
        std::unique_ptr<unsigned char[]> decompressed;
        if (header_.data == Data::BinaryCompressed) {
            if (body.size() < 8) return fail(file_, "truncated binary_compressed data (no sizes)");
            std::uint32_t compressedSize = 0, size = 0;
            std::memcpy(&compressedSize, data, 4);
            std::memcpy(&size, data + 4, 4);
            if (compressedSize > body.size() - 8)
                return fail(file_, fmt::format("truncated binary_compressed data ({} bytes of {})",
                                               body.size() - 8, compressedSize));
            if (header_.points > UINT64_MAX / header_.rowBytes || size != need ||
                need > compressedSize * kLzfMaxRatio)
                return fail(file_,
                            fmt::format("corrupt binary_compressed data ({} bytes for {} points of {} bytes)",
                                        size, header_.points, header_.rowBytes));
            decompressed = std::make_unique_for_overwrite<unsigned char[]>(size + 1);
            if (!lzfDecompress(data + 8, compressedSize, decompressed.get(), size))
                return fail(file_, "corrupt binary_compressed data (LZF)");
        } else if (body.size() / header_.rowBytes < header_.points) {
            return fail(file_, fmt::format("truncated binary data (room for {} of {} points)",
                                           body.size() / header_.rowBytes, header_.points));
        }
        size(out, header_.points);
        std::array<double, detail::kRowSlots> values{};
        const auto points = static_cast<std::size_t>(header_.points);
        for (std::size_t i = 0; i < points; ++i) {
            std::uint32_t rgb = 0;
            for (const Field* field : used_) {
                // Rows (binary), or columns (binary_compressed: each field's values in turn).
                const unsigned char* p = decompressed
                                             ? decompressed.get() + field->offset * points + i * field->size
                                             : data + i * header_.rowBytes + field->offset;
                if (field->use == kRgb)
                    std::memcpy(&rgb, p, 4);
                else if (field->use >= kAttribute)
                    attributeValue(out, field->use) = loadValue(p, *field);
                else
                    values[static_cast<std::size_t>(field->use)] = loadValue(p, *field);
            }
            if (const char* problem = store(values, rgb, out))
                return fail(file_, fmt::format("{} at point {}", problem, i));
        }
        return {};
    }

    std::string_view bytes_;
    std::string_view file_;
    const PointFileOptions& options_;
    Header header_;
    detail::RowLayout layout_;
    bool colour_ = false;
    std::vector<const Field*> used_;
    std::size_t n_ = 0, skipped_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Writing

void appendFloatText(std::string& out, float value) {
    char buffer[32];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
    out.append(buffer, end);
}

template <typename T>
void appendBinary(std::string& out, T value) {
    static_assert(std::endian::native == std::endian::little, "PCD binary data is written little-endian");
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    out.append(bytes, sizeof(T));
}

Result<void> writePcdFile(const std::filesystem::path& path, const PointSet& points, bool ascii,
                          glm::dvec3 origin, std::string_view file) {
    assert(points.normal.size() == points.size());
    if (const std::optional<std::string> problem = detail::attributeNameProblem(points))
        return fail(file, *problem);
    std::vector<std::string_view> names = {"x", "y", "z", "normal_x", "normal_y", "normal_z"};
    std::vector<std::string_view> sizes(6, "4"), types(6, "F");
    const int doubles = detail::doublePositions(origin);
    std::fill_n(sizes.begin(), doubles, "8");
    if (points.hasRadius()) names.push_back("radius"), sizes.push_back("4"), types.push_back("F");
    if (points.hasCrease()) {
        names.insert(names.end(), {"nx2", "ny2", "nz2", "crease"});
        sizes.insert(sizes.end(), {"4", "4", "4", "1"});
        types.insert(types.end(), {"F", "F", "F", "U"});
    }
    if (points.hasColour()) names.push_back("rgb"), sizes.push_back("4"), types.push_back("F");
    for (const Attribute& a : points.attributes) {
        names.emplace_back(a.name);
        sizes.push_back(fieldOf(a.type).first);
        types.push_back(fieldOf(a.type).second);
    }
    std::string buffer = fmt::format(
        "# .PCD v0.7 - Point Cloud Data file format (written by pnsplat)\nVERSION 0.7\nFIELDS {}\nSIZE {}\n"
        "TYPE {}\nCOUNT {}\nWIDTH {}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {}\n",
        fmt::join(names, " "), fmt::join(sizes, " "), fmt::join(types, " "),
        fmt::join(std::vector<std::string_view>(names.size(), "1"), " "), points.size(), points.size(),
        ascii ? "ascii" : "binary");

    return detail::writeRows(
        path, ascii ? OutputContent::Text : OutputContent::Binary, std::move(buffer), points.size(),
        [&](std::string& rows, std::size_t i) {
            std::array<float, 10> values{};
            const int floats = detail::rowFloats(points, i, values);
            const bool crease = points.isCrease(i);
            const glm::u8vec3 c = points.hasColour() ? points.colour[i] : glm::u8vec3(0);
            const std::uint32_t rgb = (std::uint32_t{c.x} << 16) | (std::uint32_t{c.y} << 8) | c.z;
            if (ascii) {
                for (int k = 0; k < floats; ++k) {
                    if (k > 0) rows += ' ';
                    if (k < doubles)
                        detail::appendScalarText(rows, ScalarType::Float64, origin[k] + double(values[k]));
                    else
                        appendFloatText(rows, values[k]);
                }
                if (points.hasCrease()) rows += crease ? " 1" : " 0";
                if (points.hasColour())
                    fmt::format_to(std::back_inserter(rows), " {}", rgb); // the bits, as PCL
                for (const Attribute& a : points.attributes) {
                    rows += ' ';
                    detail::appendScalarText(rows, a.type, a.values[i]);
                }
                rows += '\n';
            } else {
                for (int k = 0; k < doubles; ++k) appendBinary(rows, origin[k] + double(values[k]));
                for (int k = doubles; k < floats; ++k) appendBinary(rows, values[k]);
                if (points.hasCrease()) appendBinary(rows, static_cast<std::uint8_t>(crease ? 1 : 0));
                if (points.hasColour()) appendBinary(rows, rgb);
                for (const Attribute& a : points.attributes)
                    detail::appendScalarBinary(rows, a.type, a.values[i]);
            }
        });
}

} // namespace

Result<PlyData> parsePcd(std::string_view bytes, std::string_view name, const PointFileOptions& options,
                         std::size_t& skipped) {
    skipped = 0;
    return detail::guarded(name, "reading", [&] { return PcdReader(bytes, name, options).read(skipped); });
}

Result<void> writePcd(const std::filesystem::path& path, const PointSet& points, bool ascii,
                      glm::dvec3 origin) {
    const std::string file = outputName(path);
    return detail::guarded(file, "writing", [&] { return writePcdFile(path, points, ascii, origin, file); });
}

} // namespace pnsplat
