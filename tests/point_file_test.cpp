// Tests of the point files besides PLY (point_file.h, point_text.h, pcd.h): bit-exact round trips
// through every kind, columns named by a header (any order, CloudCompare's), by the options and by
// their count, .pts count lines, colour scales, PCD's fields, packed colours, NaN points and LZF
// data, the kind by extension and content, and one-line errors naming the line.
#include "pnsplat/refine/io/point_file.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/refine/io/pcd.h"
#include "pnsplat/refine/io/point_text.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "pnsplat/refine/text.h"
#include "program.h"
#include "temp_dir.h"

namespace pnsplat {
namespace {

using test::sameBits;
using test::TempDir;
namespace fs = std::filesystem;

// Crease points, radii and colours: every attribute a file can carry.
PointSet everyAttribute() {
    PointSet points = sampleCappedCylinder(12, 1.0f, 1.5f);
    EXPECT_TRUE(points.hasCrease());
    points.radius.resize(points.size());
    points.colour.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        points.radius[i] = 0.01f + 0.37f * static_cast<float>(i) / 7.0f;
        points.colour[i] = glm::u8vec3(i * 37 % 256, i * 101 % 256, 255 - i % 256);
    }
    return points;
}

void expectSameBits(const PointSet& a, const PointSet& b, const std::string& what) {
    EXPECT_TRUE(sameBits(a.position, b.position)) << what;
    EXPECT_TRUE(sameBits(a.normal, b.normal)) << what;
    EXPECT_TRUE(sameBits(a.radius, b.radius)) << what;
    EXPECT_TRUE(sameBits(a.colour, b.colour)) << what;
    EXPECT_TRUE(sameBits(a.crease, b.crease)) << what;
}

Result<PointFileData> parseText(const std::string& text, const std::vector<std::string>& columns = {}) {
    PointFileOptions options;
    options.requireNormals = false;
    options.columns = columns;
    return parsePointFile(text, "scan.xyz", PointFileKind::Text, options);
}

// Every kind written and read back gives the same points, bit for bit; the kind follows the name.
TEST(PointFile, RoundTripsBitForBitThroughEveryKind) {
    const TempDir dir;
    PointSet plain = sampleSphereUniform(200, 3.0f);
    plain.position[0] = glm::vec3(1e-30f, -7.0e20f, 0.1f); // extremes of the shortest representation
    for (const PointSet& points : {everyAttribute(), plain}) {
        for (const char* name : {"a.xyz", "a.csv", "a.txt", "a.pts", "a.PCD", "a.ply"}) {
            for (const bool ascii : {false, true}) {
                const fs::path path = dir / name;
                ASSERT_TRUE(writePointFile(path, points, ascii).ok()) << name;
                const Result<PointFileData> read = readPointFile(path);
                ASSERT_TRUE(read.ok()) << name << ": " << read.error().message;
                EXPECT_EQ(read->kind, *pointFileKindOf(path)) << name;
                EXPECT_TRUE(read->data.unusedProperties.empty()) << name;
                expectSameBits(read->data.points, points, std::string(name) + (ascii ? " ascii" : " binary"));
            }
        }
    }
}

// Coordinates far from 0 for their spacing (PlyData::origin): read in the precision the file holds,
// held less an origin near them, written back as doubles, in every kind; near 0 nothing changes.
// Where the file holds them as floats far from 0, they are rounded already, and roundedBy says by how
// much.
TEST(PointFile, FarCoordinatesAreHeldLessAnOrigin) {
    const TempDir dir;
    PointSet points = sampleSphereUniform(200, 1.0f);
    for (glm::vec3& p : points.position) p += glm::vec3(1.5f); // in [0.5, 2.5]: exact beside the origin
    const glm::dvec3 origin(5e5, -2e6, 0.0);
    for (const char* name : {"a.xyz", "a.csv", "a.pcd", "a.ply"}) {
        for (const bool ascii : {false, true}) {
            const fs::path path = dir / name;
            ASSERT_TRUE(writePointFile(path, points, ascii, {}, origin).ok()) << name;
            const Result<PointFileData> read = readPointFile(path);
            ASSERT_TRUE(read.ok()) << name << ": " << read.error().message;
            EXPECT_EQ(read->data.origin, origin) << name;
            EXPECT_EQ(read->data.roundedBy, 0.0) << name;
            EXPECT_TRUE(read->data.farPositions.empty()) << name;
            expectSameBits(read->data.points, points, std::string(name) + (ascii ? " ascii" : " binary"));
            // Written without it, the same points near 0 read as written.
            ASSERT_TRUE(writePointFile(path, points, ascii).ok()) << name;
            const Result<PointFileData> near = readPointFile(path);
            ASSERT_TRUE(near.ok()) << name;
            EXPECT_EQ(near->data.origin, glm::dvec3(0.0)) << name;
            expectSameBits(near->data.points, points, name);
        }
    }
    // Floats far from 0 (a step of 0.125 at 2e6, half the mean spacing): held less the origin too,
    // and a warning's measure says they are rounded.
    PointSet far = points;
    for (glm::vec3& p : far.position) p += glm::vec3(5e5f, -2e6f, 0.0f);
    ASSERT_TRUE(writePointFile(dir / "far.ply", far).ok());
    const Result<PointFileData> read = readPointFile(dir / "far.ply");
    ASSERT_TRUE(read.ok());
    EXPECT_GT(read->data.roundedBy, 0.25);
    EXPECT_EQ(read->data.origin, origin);
    // A first row of 0 0 0 (a scanner's own position, an invalid return) before the far points:
    // the same origin, the rest the same bits, and the stray point less the origin. Fails where
    // only a first far point keeps the doubles, or where the whole box (stray point in) decides.
    // So too with half the rows 0 0 0 (an organised scan's invalid returns), which the middle box
    // leaves out.
    PointSet stray = points, zeros = points;
    stray.position[0] = glm::vec3(-5e5f, 2e6f, 0.0f); // written as origin + position: 0 0 0
    for (std::size_t i = 0; i < zeros.size() / 2; ++i) zeros.position[i] = stray.position[0];
    for (const char* name : {"stray.xyz", "stray.pcd", "stray.ply"})
        for (const PointSet* written : {&stray, &zeros}) {
            ASSERT_TRUE(writePointFile(dir / name, *written, false, {}, origin).ok()) << name;
            const Result<PointFileData> withStray = readPointFile(dir / name);
            ASSERT_TRUE(withStray.ok()) << name;
            EXPECT_EQ(withStray->data.origin, origin) << name;
            expectSameBits(withStray->data.points, *written, name);
        }
    // Another file's points restated less this origin, in double: exact here.
    std::vector<glm::vec3> positions = {glm::vec3(1.5f, -0.25f, 3.0f)};
    moveToOrigin(positions, glm::dvec3(5e5, -2e6, 0.0), glm::dvec3(5e5 + 4.0, -2e6, -8.0));
    EXPECT_EQ(positions[0], glm::vec3(-2.5f, -0.25f, 11.0f));
}

// A place in a file's coordinates, as notes and cameras print it: to about a thousandth of the
// size, and without an exponent where the size is large (a model in millimetres 600,000 across
// printed "2.8733e+05 5006830 -2.4664e+05" before).
TEST(PlaceText, WholeNumbersWithoutAnExponent) {
    EXPECT_EQ(placeText(glm::dvec3(287330.87, 5006830.2, -246640.4), 37390.0, ' '), "287330 5006830 -246640");
    EXPECT_EQ(placeText(glm::dvec3(287336.0, -99999.0, 1.0), 37390.0, ','), "287340,-99999,1");
    EXPECT_EQ(placeText(glm::dvec3(512000.5, 4123000.25, 87.0), 0.3, ','), "512000.5,4123000.25,87");
    EXPECT_EQ(placeText(glm::dvec3(0.0123456, -0.5, 0.0), 0.01, ' '), "0.012346 -0.5 0");
    // Rounding that carries to the next power of ten.
    EXPECT_EQ(placeText(glm::dvec3(9999.7, 99999.7, -99999.7), 37390.0, ' '), "10000 100000 -100000");
    EXPECT_EQ(placeText(glm::dvec3(3e17, 0.0, 0.0), 1e16, ' '), "3e+17 0 0"); // past a double's whole digits
}

TEST(PointFile, TextWritesAHeaderLineNamingTheColumns) {
    const TempDir dir;
    const PointSet points = everyAttribute();
    ASSERT_TRUE(writePointFile(dir / "a.csv", points).ok());
    ASSERT_TRUE(writePointFile(dir / "a.pts", points).ok());
    const std::string csv = test::readText(dir / "a.csv"), pts = test::readText(dir / "a.pts");
    EXPECT_TRUE(csv.starts_with("x,y,z,nx,ny,nz,radius,nx2,ny2,nz2,crease,red,green,blue\n"))
        << csv.substr(0, 80);
    EXPECT_TRUE(pts.starts_with(std::to_string(points.size()) + "\n//x y z nx ny nz radius"))
        << pts.substr(0, 80);
}

TEST(PointText, HeaderNamesColumnsInAnyOrder) {
    const Result<PointFileData> read = parseText("Z,nx,X,intensity,NY,y,nz,blue,green,red\n"
                                                 "3,0,1,77,0,2,1,30,20,10\n"
                                                 "6,1,4,78,0,5,0,60,50,40\n");
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p.position[0], glm::vec3(1, 2, 3));
    EXPECT_EQ(p.position[1], glm::vec3(4, 5, 6));
    EXPECT_EQ(p.normal[0], glm::vec3(0, 0, 1));
    EXPECT_EQ(p.normal[1], glm::vec3(1, 0, 0));
    EXPECT_EQ(p.colour[1], glm::u8vec3(40, 50, 60));
    // Another named column is an attribute, a float (PointSet::attributes).
    EXPECT_TRUE(read->data.unusedProperties.empty());
    ASSERT_EQ(p.attributes.size(), 1u);
    EXPECT_EQ(p.attributes[0].name, "intensity");
    EXPECT_EQ(p.attributes[0].type, ScalarType::Float32);
    EXPECT_EQ(p.attributes[0].values[1], 78.0);
}

TEST(PointText, CloudCompareHeaderAfterSlashes) {
    const Result<PointFileData> read = parseText("//X Y Z R G B Nx Ny Nz\n"
                                                 "1.5 2 3 255 128 0 0 1 0\n"
                                                 "// a comment line\n"
                                                 "\n"
                                                 "4\t5\t6\t0 0 9 0 0 -1\r\n");
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p.position[0], glm::vec3(1.5f, 2, 3));
    EXPECT_EQ(p.colour[0], glm::u8vec3(255, 128, 0));
    EXPECT_EQ(p.normal[0], glm::vec3(0, 1, 0));
    EXPECT_EQ(p.normal[1], glm::vec3(0, 0, -1));
}

// Leica's .pts: a count line before each scan, then x y z intensity r g b.
TEST(PointText, PtsCountLinesAndSevenColumns) {
    const Result<PointFileData> read = parseText("2\n1 2 3 -1200 255 0 0\n4 5 6 300 0 255 0\n"
                                                 "1\n7 8 9 0 0 0 255\n");
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 3u);
    EXPECT_FALSE(p.hasNormal());
    EXPECT_EQ(p.position[2], glm::vec3(7, 8, 9));
    EXPECT_EQ(p.colour[0], glm::u8vec3(255, 0, 0));
    EXPECT_EQ(p.colour[2], glm::u8vec3(0, 0, 255));
    EXPECT_TRUE(read->data.unusedProperties.empty());
    ASSERT_EQ(p.attributes.size(), 1u);
    EXPECT_EQ(p.attributes[0].name, "intensity");
    EXPECT_EQ(p.attributes[0].values[0], -1200.0);
    EXPECT_EQ(p.attributes[0].values[2], 0.0);
}

TEST(PointText, ColumnsByTheirNumber) {
    const Result<PointFileData> three = parseText("0 0 0\n1 0 0\n");
    ASSERT_TRUE(three.ok()) << three.error().message;
    EXPECT_FALSE(three->data.points.hasNormal());
    EXPECT_FALSE(three->data.points.hasColour());
    const Result<PointFileData> six = parseText("0 0 0 0 0 2\n1 0 0 0 3 0\n");
    ASSERT_TRUE(six.ok()) << six.error().message;
    EXPECT_EQ(six->data.points.normal[0], glm::vec3(0, 0, 1)); // normalised
    EXPECT_EQ(six->data.points.normal[1], glm::vec3(0, 1, 0));
    const Result<PointFileData> ten = parseText("0 0 0 0 0 1 9 8 7 5\n");
    ASSERT_TRUE(ten.ok()) << ten.error().message;
    EXPECT_EQ(ten->data.points.colour[0], glm::u8vec3(9, 8, 7));
    EXPECT_EQ(ten->data.unusedProperties, std::vector<std::string>{"column 10"});
}

// --columns names the columns instead of the header line and of their number.
TEST(PointText, ColumnsFromTheOptions) {
    const Result<PointFileData> read = parseText("a b c d\n1 2 3 4\n", {"i", "x", "y", "z"});
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->data.points.position[0], glm::vec3(2, 3, 4));
    ASSERT_EQ(read->data.points.attributes.size(), 1u);
    EXPECT_EQ(read->data.points.attributes[0].name, "i");
    EXPECT_EQ(read->data.points.attributes[0].values[0], 1.0);
    const Result<PointFileData> six = parseText("1 2 3 10 20 30\n", {"x", "y", "z", "r", "g", "b"});
    ASSERT_TRUE(six.ok()) << six.error().message;
    EXPECT_FALSE(six->data.points.hasNormal());
    EXPECT_EQ(six->data.points.colour[0], glm::u8vec3(10, 20, 30));
    const Result<PointFileData> noX = parseText("1 2 3\n", {"a", "y", "z"});
    ASSERT_FALSE(noX.ok());
    EXPECT_NE(noX.error().message.find("no 'x' column"), std::string::npos) << noX.error().message;
}

TEST(PointText, ColoursAsFractionsOrBytes) {
    const auto colours = [](const std::string& text) {
        const Result<PointFileData> read = parseText("x y z r g b\n" + text);
        EXPECT_TRUE(read.ok()) << read.error().message;
        return read.ok() ? std::vector<glm::u8vec3>(read->data.points.colour.begin(),
                                                    read->data.points.colour.end())
                         : std::vector<glm::u8vec3>{};
    };
    using C = std::vector<glm::u8vec3>;
    EXPECT_EQ(colours("0 0 0 0.5 0.25 1.0\n1 0 0 0 1 0\n"), (C{{128, 64, 255}, {0, 255, 0}}));
    EXPECT_EQ(colours("0 0 0 128 64 255\n1 0 0 0 1 0\n"), (C{{128, 64, 255}, {0, 1, 0}}));
    EXPECT_EQ(colours("0 0 0 1.0 1.0 1.0\n"), (C{{255, 255, 255}})); // white as fractions
    EXPECT_EQ(colours("0 0 0 255.0 0.0 12.4\n"), (C{{255, 0, 12}})); // bytes written as floats
    EXPECT_EQ(colours("0 0 0 300 -4 1e0\n"), (C{{255, 0, 1}}));      // bytes, clamped
    const Result<PointFileData> rf = parseText("x y z rf gf bf\n0 0 0 1 0 1\n");
    ASSERT_TRUE(rf.ok());
    EXPECT_EQ(rf->data.points.colour[0], glm::u8vec3(255, 0, 255));
}

// Every malformed text file is one line naming the file and, where there is one, the line.
TEST(PointText, ErrorsNameTheFileAndTheLine) {
    struct Case {
        std::string text, says;
    };
    const std::vector<Case> cases = {
        {"", "scan.xyz: empty file"},
        {"\n\n# only a comment\n", "scan.xyz: empty file"},
        {"x y z\n", "scan.xyz: no points"},
        {"0 0 0\n1 0 0\n1 q 0\n", "scan.xyz: line 3: 'q' is not a number (column 2)"},
        {"0 0 0\n1 0 0\n1 1.0.0 0\n", "scan.xyz: line 3: '1.0.0' is not a number"},
        {"0 0 0\n1 0 0 0\n", "scan.xyz: line 2: 4 field(s), expected 3"},
        {"x,y,z\n0,0,0\n\n0,0\n", "scan.xyz: line 4: 2 field(s), expected 3"},
        {"0 0 0\n0 nan 0\n", "scan.xyz: line 2: non-finite value 'nan'"},
        {"0 0 0\n0 0 1e39\n", "scan.xyz: line 2: non-finite value '1e39'"},
        {"0 0 0 0 0 1\n1 0 0 0 0 0\n",
         "scan.xyz: line 2: zero-length normal (the 6 columns taken as x y z nx ny nz"},
        {"a b c\n0 0 0\n", "scan.xyz: the header line: no 'x' column"},
        {"x y z x\n0 0 0 0\n", "two columns for 'x'"},
        {"x y z nx\n0 0 0 0\n", "some of the normal columns"},
        {"x y z\ny x z\n", "scan.xyz: line 2: a second header line"},
        {"1,2,3\n4,5,6,\n7,8\n", "scan.xyz: line 3: 2 field(s), expected 3"},
    };
    for (const Case& c : cases) {
        const Result<PointFileData> read = parseText(c.text);
        ASSERT_FALSE(read.ok()) << c.text;
        const std::string& message = read.error().message;
        EXPECT_NE(message.find(c.says), std::string::npos) << c.text << "-> " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
}

// ---------------------------------------------------------------------------------------------
// PCD

std::string pcdHeader(const std::string& fields, const std::string& sizes, const std::string& types,
                      std::size_t points, const std::string& data) {
    std::string count;
    for (char c : types)
        if (c != ' ') count += count.empty() ? "1" : " 1";
    return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes +
           "\nTYPE " + types + "\nCOUNT " + count + "\nWIDTH " + std::to_string(points) +
           "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points) + "\nDATA " + data + "\n";
}

template <typename T>
void put(std::string& out, T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    out.append(bytes, sizeof(T));
}

Result<PointFileData> parsePcdText(const std::string& bytes) {
    PointFileOptions options;
    options.requireNormals = false;
    return parsePointFile(bytes, "cloud.pcd", std::nullopt, options);
}

TEST(Pcd, AsciiFieldsPackedColourAndNaNPoints) {
    const float packed = std::bit_cast<float>(std::uint32_t{0x00ff8010});
    char packedText[32];
    std::snprintf(packedText, sizeof packedText, "%.9g", double(packed));
    const std::string bytes = pcdHeader("x y z rgb normal_x normal_y normal_z curvature", "4 4 4 4 4 4 4 4",
                                        "F F F F F F F F", 3, "ascii") +
                              "1 2 3 " + packedText + " 0 0 1 0.5\n" +
                              "nan nan nan 0 0 0 0 nan\n"      // a hole of an organised cloud
                              "4 5 6 4278256128 1 0 0 0.25\n"; // rgb as the integer of its bits (alpha FF)
    const Result<PointFileData> read = parsePcdText(bytes);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->kind, PointFileKind::Pcd);
    EXPECT_EQ(read->skippedPoints, 1u);
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p.position[1], glm::vec3(4, 5, 6));
    EXPECT_EQ(p.normal[1], glm::vec3(1, 0, 0));
    EXPECT_EQ(p.colour[0], glm::u8vec3(0xff, 0x80, 0x10));
    EXPECT_EQ(p.colour[1], glm::u8vec3(0x01, 0x02, 0x00)); // 0xFF010200
    EXPECT_TRUE(read->data.unusedProperties.empty());
    ASSERT_EQ(p.attributes.size(), 1u); // the NaN point's value left out with it
    EXPECT_EQ(p.attributes[0].name, "curvature");
    EXPECT_EQ(p.attributes[0].type, ScalarType::Float32);
    EXPECT_EQ(p.attributes[0].values[0], 0.5);
    EXPECT_EQ(p.attributes[0].values[1], 0.25);
}

TEST(Pcd, BinaryRowsWithPaddingAndOtherTypes) {
    std::string bytes = pcdHeader("x y z _ intensity rgba", "8 4 2 4 1 4", "F F I U U U", 2, "binary");
    for (int i = 0; i < 2; ++i) {
        put(bytes, double(0.1 * i));
        put(bytes, float(2.5f));
        put(bytes, std::int16_t(-3 - i));
        put(bytes, std::uint32_t{0xdeadbeef}); // padding
        put(bytes, std::uint8_t(9));
        put(bytes, std::uint32_t{0x80102030});
    }
    const Result<PointFileData> read = parsePcdText(bytes);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 2u);
    EXPECT_FALSE(p.hasNormal());
    EXPECT_EQ(p.position[1], glm::vec3(float(0.1), 2.5f, -4.0f));
    EXPECT_EQ(p.colour[1], glm::u8vec3(0x10, 0x20, 0x30));
    EXPECT_TRUE(read->data.unusedProperties.empty()); // the padding is not named
    ASSERT_EQ(p.attributes.size(), 1u);
    EXPECT_EQ(p.attributes[0].name, "intensity");
    EXPECT_EQ(p.attributes[0].type, ScalarType::UInt8);
    EXPECT_EQ(p.attributes[0].values[1], 9.0);
}

// binary_compressed: each field's values in turn, LZF-coded: literal runs and a back reference.
TEST(Pcd, BinaryCompressedLzf) {
    // Three points x y z: x = 1, 1, 1 (a run the back reference repeats), y = 0, 1, 2, z = 5, 5, 5.
    std::string columns;
    for (float v : {1.0f, 1.0f, 1.0f, 0.0f, 1.0f, 2.0f, 5.0f, 5.0f, 5.0f}) put(columns, v);
    std::string lzf;
    lzf += char(3); // 4 literal bytes: the first x
    lzf.append(columns, 0, 4);
    lzf += char((6 << 5) | 0); // a back reference of 6 + 2 = 8 bytes, 4 back (overlapping)
    lzf += char(3);
    lzf += char(23); // the remaining 24 bytes as literals
    lzf.append(columns, 12, 24);
    ASSERT_EQ(columns.size(), 36u);
    std::string bytes = pcdHeader("x y z", "4 4 4", "F F F", 3, "binary_compressed");
    put(bytes, std::uint32_t(lzf.size()));
    put(bytes, std::uint32_t(columns.size()));
    bytes += lzf;
    const Result<PointFileData> read = parsePcdText(bytes);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.size(), 3u);
    EXPECT_EQ(p.position[0], glm::vec3(1, 0, 5));
    EXPECT_EQ(p.position[2], glm::vec3(1, 2, 5));
    // A reference before the start is corrupt data, not a crash.
    std::string corrupt = bytes;
    corrupt[corrupt.size() - lzf.size() + 6] = char(200);
    const Result<PointFileData> bad = parsePcdText(corrupt);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("corrupt binary_compressed"), std::string::npos)
        << bad.error().message;
}

TEST(Pcd, ErrorsNameTheFileAndTheLine) {
    const std::string xyz = pcdHeader("x y z", "4 4 4", "F F F", 2, "ascii");
    std::string binary = pcdHeader("x y z", "4 4 4", "F F F", 2, "binary");
    put(binary, 1.0f);
    struct Case {
        std::string bytes, says;
    };
    const std::vector<Case> cases = {
        {"VERSION 0.7\n", "cloud.pcd: malformed PCD header: no DATA line"},
        {"VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n", "2 SIZE"},
        {"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 1\nDATA ascii\n",
         "field 'z' of SIZE 4 TYPE Q"},
        {"VERSION 0.7\nBOGUS 1\n", "cloud.pcd: malformed PCD header line 2: unknown keyword"},
        {pcdHeader("x y", "4 4", "F F", 1, "ascii") + "1 2\n", "no field 'z'"},
        {xyz + "1 2 3\n", "truncated ascii data"},
        {xyz + "1 2 3\n4 5\n", "cloud.pcd: line 13: 2 values, expected 3"},
        {xyz + "1 2 3\n4 five 6\n", "cloud.pcd: line 13: 'five' is not a number (field y)"},
        {xyz + "1 2 3\n4 inf 6\n", "cloud.pcd: line 13: non-finite coordinate"},
        {xyz + "1 2 3\n4 5 6\n \n7 8 9\n",
         "cloud.pcd: line 15: a row after the 2 points the header declares"},
        {binary, "truncated binary data (room for 0 of 2 points)"},
        {pcdHeader("x y z", "4 4 4", "F F F", 0, "ascii"), "no points"},
    };
    for (const Case& c : cases) {
        const Result<PointFileData> read = parsePcdText(c.bytes);
        ASSERT_FALSE(read.ok()) << c.bytes;
        const std::string& message = read.error().message;
        EXPECT_NE(message.find(c.says), std::string::npos) << c.bytes << "-> " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
}

// Names without a known extension, and standard input, are read by their content.
TEST(PointFile, KindByExtensionThenContent) {
    const TempDir dir;
    const PointSet points = sampleSphereUniform(50, 1.0f);
    for (const char* name : {"a.ply", "a.pcd", "a.xyz"}) {
        ASSERT_TRUE(writePointFile(dir / name, points).ok());
        fs::copy_file(dir / name, dir / (std::string(name) + ".data"));
        const Result<PointFileData> read = readPointFile(dir / (std::string(name) + ".data"));
        ASSERT_TRUE(read.ok()) << name << ": " << read.error().message;
        EXPECT_EQ(read->kind, *pointFileKindOf(dir / name)) << name;
        expectSameBits(read->data.points, points, name);
    }
    EXPECT_EQ(pointFileKindOf("scan.CSV"), PointFileKind::Text);
    EXPECT_EQ(pointFileKindOf("scan.e57"), std::nullopt);
    EXPECT_EQ(sniffPointFile("FIELDS x y z\n"), PointFileKind::Pcd);
    EXPECT_EQ(sniffPointFile("plyx"), PointFileKind::Text);
    // A text file named .ply is not PLY: the extension decides.
    test::writeText(dir / "text.ply", "0 0 0\n");
    const Result<PointFileData> wrong = readPointFile(dir / "text.ply");
    ASSERT_FALSE(wrong.ok());
    EXPECT_NE(wrong.error().message.find("not a PLY file"), std::string::npos) << wrong.error().message;
    // A file of no point-file name is read by its content; where that fails, the error says how it
    // was read, with the line that failed. A point file's own errors stay as they were.
    test::writeText(dir / "notes.log", "# Notes\nSome words here\nand more words\n");
    const Result<PointFileData> notes = readPointFile(dir / "notes.log");
    ASSERT_FALSE(notes.ok());
    EXPECT_EQ(notes.error().message,
              (dir / "notes.log").string() +
                  ": read by its content as a text point file: line 3: a second header line");
    test::writeText(dir / "notes.xyz", "Some words here\nand more words\n");
    const Result<PointFileData> named = readPointFile(dir / "notes.xyz");
    ASSERT_FALSE(named.ok());
    EXPECT_EQ(named.error().message, (dir / "notes.xyz").string() + ": line 2: a second header line");
}

// A failed write leaves nothing (OutputFile), whatever the kind.
TEST(PointFile, WritesAreWholeOrNothing) {
    const TempDir dir;
    for (const char* name : {"missing/a.xyz", "missing/a.pcd"}) {
        const Result<void> written = writePointFile(dir / name, sampleSphereUniform(10, 1.0f));
        ASSERT_FALSE(written.ok()) << name;
        EXPECT_EQ(written.error().message.find('\n'), std::string::npos);
    }
    EXPECT_TRUE(dir.entries().empty());
}

} // namespace
} // namespace pnsplat
