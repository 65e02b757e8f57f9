// Attributes (PointSet::attributes, issue 27): the other scalar properties of a file are carried
// through reading, the point-set operations, the refinement and writing.
// - representable: rounding and clamping to each type;
// - appendFrom, reserve, resize, removePoints, removeCoincident keep every point's values;
// - PLY: an extra float and an extra uchar property read, written back with the same names and
//   types, values bit for bit, binary and ascii; every scalar type at its extremes; names that
//   cannot be written are refused;
// - refinement: a point on a boundary or crease segment gets the interpolation of its ends' values
//   at its curve parameter, as its colour does (the triangle means are checked with the colour's
//   oracle in refiner_test.cpp, RefinerLocal); the attributes change nothing else and do not
//   depend on the thread count.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "program.h"
#include "temp_dir.h"

namespace pnsplat {
namespace {

using test::sameBits;
using test::TempDir;
namespace fs = std::filesystem;

// Random colours, an `intensity` float in [1, 1000) (any three sum exactly in double) and a
// `quality` uchar for every point of `points`.
void addRandomAttributes(PointSet& points, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> intensity(1.0f, 1000.0f);
    points.colour.clear();
    points.attributes = {Attribute{"intensity", ScalarType::Float32, {}},
                         Attribute{"quality", ScalarType::UInt8, {}}};
    for (std::size_t i = 0; i < points.size(); ++i) {
        points.colour.emplace_back(rng() % 256, rng() % 256, rng() % 256);
        points.attributes[0].values.push_back(intensity(rng));
        points.attributes[1].values.push_back(double(rng() % 256));
    }
}

bool sameAttributeValues(const PointSet& a, const PointSet& b) {
    if (!sameAttributes(a, b)) return false;
    for (std::size_t k = 0; k < a.attributes.size(); ++k)
        if (!sameBits(a.attributes[k].values, b.attributes[k].values)) return false;
    return true;
}

TEST(PointSetAttributes, RepresentableRoundsAndClampsToTheType) {
    EXPECT_EQ(representable(ScalarType::UInt8, 254.5), 255.0);
    EXPECT_EQ(representable(ScalarType::UInt8, 300.7), 255.0);
    EXPECT_EQ(representable(ScalarType::UInt8, -3.0), 0.0);
    EXPECT_EQ(representable(ScalarType::Int8, -128.6), -128.0);
    EXPECT_EQ(representable(ScalarType::Int16, 2.5), 3.0); // halves away from zero
    EXPECT_EQ(representable(ScalarType::Int16, -2.5), -3.0);
    EXPECT_EQ(representable(ScalarType::UInt16, 70000.0), 65535.0);
    EXPECT_EQ(representable(ScalarType::Int32, -3e9), -2147483648.0);
    EXPECT_EQ(representable(ScalarType::UInt32, 4294967295.4), 4294967295.0);
    EXPECT_EQ(representable(ScalarType::UInt8, std::nan("")), 0.0);
    EXPECT_EQ(representable(ScalarType::Float32, 1.0 / 3.0), double(1.0f / 3.0f));
    EXPECT_EQ(representable(ScalarType::Float64, 1.0 / 3.0), 1.0 / 3.0);
    EXPECT_TRUE(std::isnan(representable(ScalarType::Float32, std::nan(""))));
}

// Six points on a line, point i with intensity i + 0.25 and quality 10 i.
PointSet lineWithAttributes() {
    PointSet points;
    points.attributes = {Attribute{"intensity", ScalarType::Float32, {}},
                         Attribute{"quality", ScalarType::UInt8, {}}};
    for (int i = 0; i < 6; ++i) {
        points.position.emplace_back(float(i), 0.0f, 0.0f);
        points.normal.emplace_back(0.0f, 0.0f, 1.0f);
        points.attributes[0].values.push_back(i + 0.25);
        points.attributes[1].values.push_back(10.0 * i);
    }
    return points;
}

TEST(PointSetAttributes, AppendResizeAndRemoveKeepEveryPointsValues) {
    const PointSet line = lineWithAttributes();
    PointSet copy; // empty, without attributes: takes on line's
    for (std::size_t i = line.size(); i-- > 0;) copy.appendFrom(line, i);
    ASSERT_TRUE(sameAttributes(copy, line));
    for (std::size_t k = 0; k < copy.size(); ++k) {
        EXPECT_EQ(copy.attributes[0].values[k], double(line.size() - 1 - k) + 0.25);
        EXPECT_EQ(copy.attributes[1].values[k], 10.0 * double(line.size() - 1 - k));
    }
    copy.reserve(100);
    copy.resize(8);
    EXPECT_EQ(copy.attributes[0].values.size(), 8u);
    EXPECT_EQ(copy.attributes[1].values.size(), 8u);

    PointSet removed = lineWithAttributes();
    const std::vector<std::uint32_t> drop{0, 3, 5};
    removePoints(removed, drop);
    ASSERT_EQ(removed.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
        const int i = std::array{1, 2, 4}[k];
        EXPECT_EQ(removed.attributes[0].values[k], i + 0.25);
        EXPECT_EQ(removed.attributes[1].values[k], 10.0 * i);
    }
    EXPECT_EQ(test::pointSetDefect(removed), "");
}

// Repeats are removed with their values; one whose values differ counts as having other attributes.
TEST(PointSetAttributes, RemoveCoincidentKeepsTheFirstsValues) {
    PointSet points = lineWithAttributes();
    points.appendFrom(points, 2); // the same values
    points.appendFrom(points, 4);
    points.attributes[1].values.back() = 99.0; // another quality
    const CoincidentRemoval removal = removeCoincident(points);
    EXPECT_EQ(removal.points, 2u);
    EXPECT_EQ(removal.withOtherAttributes, 1u);
    ASSERT_EQ(points.size(), 6u);
    EXPECT_TRUE(sameAttributeValues(points, lineWithAttributes()));
}

// ---------------------------------------------------------------------------------------------
// PLY

// An ascii PLY file of three points with an extra float and an extra uchar property between the
// ones pnsplat reads, and a list property, which stays unused.
constexpr const char* kExtraPropertiesPly = "ply\n"
                                            "format ascii 1.0\n"
                                            "element vertex 3\n"
                                            "property float x\n"
                                            "property float y\n"
                                            "property float intensity\n"
                                            "property float z\n"
                                            "property float nx\n"
                                            "property float ny\n"
                                            "property float nz\n"
                                            "property uchar quality\n"
                                            "property list uchar int ids\n"
                                            "end_header\n"
                                            "0 0 0.1 0 0 0 1 0 1 7\n"
                                            "1 0 -2.5e-7 0 0 0 1 255 2 7 8\n"
                                            "0 1 123456.79 0 0 0 1 17 0\n";

TEST(PlyAttributes, ExtraFloatAndUcharPropertiesRoundTripInBothFormats) {
    const Result<PlyData> read = parsePly(kExtraPropertiesPly, "extra.ply");
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->unusedProperties, std::vector<std::string>{"ids"});
    const PointSet& points = read->points;
    ASSERT_EQ(points.attributes.size(), 2u);
    EXPECT_EQ(points.attributes[0].name, "intensity");
    EXPECT_EQ(points.attributes[0].type, ScalarType::Float32);
    EXPECT_EQ(points.attributes[1].name, "quality");
    EXPECT_EQ(points.attributes[1].type, ScalarType::UInt8);
    const std::vector<double> intensity{double(0.1f), double(-2.5e-7f), double(123456.79f)};
    const std::vector<double> quality{0, 255, 17};
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_TRUE(sameBits(points.attributes[0].values[i], intensity[i])) << i;
        EXPECT_EQ(points.attributes[1].values[i], quality[i]) << i;
    }

    const TempDir dir;
    for (const PlyFormat format : {PlyFormat::BinaryLittleEndian, PlyFormat::Ascii}) {
        const fs::path path = dir / "out.ply";
        ASSERT_TRUE(writePly(path, points, format).ok());
        const Result<PlyData> back = readPly(path);
        ASSERT_TRUE(back.ok()) << back.error().message;
        EXPECT_TRUE(sameAttributeValues(back->points, points));
        EXPECT_TRUE(sameBits(back->points.position, points.position));
        EXPECT_TRUE(back->unusedProperties.empty());
        const std::string bytes = test::readText(path);
        EXPECT_NE(bytes.find("property float intensity\nproperty uchar quality\nend_header\n"),
                  std::string::npos);
    }
}

// Every scalar type at its extremes (and a double no float holds) reads back bit for bit, in both
// formats; a value beyond its type is written clamped.
TEST(PlyAttributes, EveryScalarTypeRoundTripsExactly) {
    struct Case {
        const char* name;
        ScalarType type;
        std::array<double, 3> values;
    };
    const std::array<Case, 8> cases{{
        {"a_char", ScalarType::Int8, {-128, 127, 0}},
        {"a_uchar", ScalarType::UInt8, {0, 255, 1}},
        {"a_short", ScalarType::Int16, {-32768, 32767, -1}},
        {"a_ushort", ScalarType::UInt16, {0, 65535, 12345}},
        {"a_int", ScalarType::Int32, {-2147483648.0, 2147483647.0, -7}},
        {"a_uint", ScalarType::UInt32, {0, 4294967295.0, 16777217}},
        {"a_float", ScalarType::Float32, {double(std::numeric_limits<float>::max()), double(1e-45f), -0.0}},
        {"a_double", ScalarType::Float64, {1.0 / 3.0, -1e300, 1234567890.123456789}},
    }};
    PointSet points;
    for (int i = 0; i < 3; ++i) {
        points.position.emplace_back(float(i), 0.0f, 0.0f);
        points.normal.emplace_back(0.0f, 0.0f, 1.0f);
    }
    for (const Case& c : cases) {
        Attribute& a = points.attributes.emplace_back(Attribute{c.name, c.type, {}});
        a.values.resize(c.values.size());
        std::copy(c.values.begin(), c.values.end(), a.values.begin());
    }
    const TempDir dir;
    for (const PlyFormat format : {PlyFormat::BinaryLittleEndian, PlyFormat::Ascii}) {
        const fs::path path = dir / "types.ply";
        ASSERT_TRUE(writePly(path, points, format).ok());
        const Result<PlyData> back = readPly(path);
        ASSERT_TRUE(back.ok()) << back.error().message;
        EXPECT_TRUE(sameAttributeValues(back->points, points))
            << (format == PlyFormat::Ascii ? "ascii" : "binary");
    }
    points.attributes[1].values[0] = 300.7; // a uchar beyond its range
    points.attributes[0].values[0] = std::nan("");
    ASSERT_TRUE(writePly(dir / "clamped.ply", points).ok());
    const Result<PlyData> clamped = readPly(dir / "clamped.ply");
    ASSERT_TRUE(clamped.ok());
    EXPECT_EQ(clamped->points.attributes[1].values[0], 255.0);
    EXPECT_EQ(clamped->points.attributes[0].values[0], 0.0);
}

// A partial colour stays unused (as before); names a header cannot hold, or that pnsplat writes
// itself, are refused on writing with one line.
TEST(PlyAttributes, ReservedAndUnwritableNames) {
    const Result<PlyData> partial = parsePly("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                             "property float y\nproperty float z\nproperty uchar red\n"
                                             "property float nx\nproperty float ny\nproperty float nz\n"
                                             "end_header\n0 0 0 9 0 0 1\n",
                                             "partial.ply");
    ASSERT_TRUE(partial.ok()) << partial.error().message;
    EXPECT_EQ(partial->unusedProperties, std::vector<std::string>{"red"});
    EXPECT_FALSE(partial->points.hasAttributes());

    const TempDir dir;
    for (const std::string name : {"red", "two words", "", "nx2"}) {
        PointSet points = lineWithAttributes();
        points.attributes[1].name = name;
        const Result<void> written = writePly(dir / "bad.ply", points);
        ASSERT_FALSE(written.ok()) << "'" << name << "'";
        std::cout << "[attribute '" << name << "'] " << written.error().message << "\n";
        EXPECT_FALSE(fs::exists(dir / "bad.ply"));
    }
    PointSet twice = lineWithAttributes();
    twice.attributes[1].name = "intensity";
    EXPECT_FALSE(writePly(dir / "bad.ply", twice).ok());
}

// ---------------------------------------------------------------------------------------------
// PCD and text

// Every kind of point file carries an extra float and an extra uchar through, values bit for bit:
// PLY and PCD with their types, text as floats (text has no types).
TEST(PointFileAttributes, EveryKindCarriesThemThrough) {
    const TempDir dir;
    PointSet points = sampleSphereUniform(50, 1.0f);
    addRandomAttributes(points, 3);
    points.attributes[0].values[7] = -0.0;
    for (const char* name : {"a.ply", "a.pcd", "a.xyz", "a.csv", "a.txt", "a.pts"}) {
        for (const bool ascii : {false, true}) {
            const fs::path path = dir / name;
            const std::string what = std::string(name) + (ascii ? " ascii" : " binary");
            ASSERT_TRUE(writePointFile(path, points, ascii).ok()) << what;
            const Result<PointFileData> read = readPointFile(path);
            ASSERT_TRUE(read.ok()) << what << ": " << read.error().message;
            EXPECT_TRUE(read->data.unusedProperties.empty()) << what;
            const PointSet& back = read->data.points;
            ASSERT_EQ(back.attributes.size(), 2u) << what;
            const bool typed = read->kind != PointFileKind::Text;
            for (std::size_t a = 0; a < 2; ++a) {
                EXPECT_EQ(back.attributes[a].name, points.attributes[a].name) << what;
                EXPECT_EQ(back.attributes[a].type, typed ? points.attributes[a].type : ScalarType::Float32)
                    << what;
                EXPECT_TRUE(sameBits(back.attributes[a].values, points.attributes[a].values)) << what;
            }
        }
    }
}

// PCD: a field of one value of any type but 64-bit integers is an attribute, of its type; fields of
// several values, 64-bit integers and padding are not.
TEST(PointFileAttributes, PcdFieldsOfEveryType) {
    const std::string bytes =
        "VERSION 0.7\nFIELDS x y z i8 u16 i32 f64 big hist _\n"
        "SIZE 4 4 4 1 2 4 8 8 4 4\nTYPE F F F I U I F U F U\nCOUNT 1 1 1 1 1 1 1 1 2 1\n"
        "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n"
        "0 0 0 -128 65535 -2147483648 0.1 7 1 2 0\n"
        "1 0 0 127 0 2147483647 1e300 8 3 4 0\n";
    PointFileOptions options;
    options.requireNormals = false;
    const Result<PointFileData> read = parsePointFile(bytes, "fields.pcd", std::nullopt, options);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->data.unusedProperties, (std::vector<std::string>{"big", "hist"}));
    const PointSet& p = read->data.points;
    ASSERT_EQ(p.attributes.size(), 4u);
    const std::array<ScalarType, 4> types{ScalarType::Int8, ScalarType::UInt16, ScalarType::Int32,
                                          ScalarType::Float64};
    const std::array<std::array<double, 2>, 4> values{
        {{-128, 127}, {65535, 0}, {-2147483648.0, 2147483647.0}, {0.1, 1e300}}};
    for (std::size_t a = 0; a < 4; ++a) {
        EXPECT_EQ(p.attributes[a].type, types[a]) << p.attributes[a].name;
        EXPECT_EQ(p.attributes[a].values[0], values[a][0]) << p.attributes[a].name;
        EXPECT_EQ(p.attributes[a].values[1], values[a][1]) << p.attributes[a].name;
    }
}

// ---------------------------------------------------------------------------------------------
// Refinement

// Whether the values of new point c equal those of a point on the segment (p, b) at t, as colour
// computes them (refiner.cpp, splitSegments) and the attributes do in double.
bool segmentValues(const PointSet& out, std::size_t c, std::size_t p, std::size_t b, float t) {
    const glm::u8vec3 colour(glm::round(glm::mix(glm::vec3(out.colour[p]), glm::vec3(out.colour[b]), t)));
    if (out.colour[c] != colour) return false;
    const auto& v = out.attributes[0].values;
    const auto& q = out.attributes[1].values;
    const double u = double(t);
    return v[c] == double(float(v[p] * (1.0 - u) + v[b] * u)) &&
           q[c] == std::clamp(std::round(q[p] * (1.0 - u) + q[b] * u), 0.0, 255.0);
}

// Whether they are the means of (p, i, j), as colour's (the oracle of refiner_test.cpp).
bool triangleValues(const PointSet& out, std::size_t c, std::size_t p, std::size_t i, std::size_t j) {
    const glm::uvec3 sum = glm::uvec3(out.colour[p]) + glm::uvec3(out.colour[i]) + glm::uvec3(out.colour[j]);
    if (out.colour[c] != glm::u8vec3((sum + glm::uvec3(1)) / 3u)) return false;
    const auto& v = out.attributes[0].values;
    const auto& q = out.attributes[1].values;
    const auto qualitySum = unsigned(q[p]) + unsigned(q[i]) + unsigned(q[j]);
    return v[c] == double(float((v[p] + v[i] + v[j]) / 3.0)) && q[c] == double((qualitySum + 1) / 3);
}

// One level on an open cap (boundary segments) and on a capped cylinder (crease segments): every
// new point has the values of a segment (p, b) at t = 1/3 or 2/3, exactly as many as were inserted
// on segments, or the means of a triangle of p and two points within 2 r_p; colour agrees with
// the attributes in each.
TEST(RefinerAttributes, SegmentPointsInterpolateTheirEndsLikeColour) {
    PointSet cap;
    const PointSet sphere = sampleSphereRandom(3000, 1.0f, 5);
    for (std::size_t i = 0; i < sphere.size(); ++i)
        if (sphere.position[i].z >= 0.5f) cap.appendFrom(sphere, i);
    PointSet cylinder = sampleCappedCylinder(48, 1.0f, 1.5f);
    for (PointSet* input : {&cap, &cylinder}) {
        const std::string name = input == &cap ? "cap" : "cylinder";
        estimateRadii(*input, 2);
        addRandomAttributes(*input, 77);
        RefineOptions options;
        options.threads = 2;
        Refiner refiner(*input, options);
        const std::vector<float> radius(refiner.points().radius.begin(), refiner.points().radius.end());
        const LevelStats stats = refiner.refineLevel();
        const PointSet& out = refiner.points();
        const std::size_t n0 = refiner.levelEnd(0);
        std::size_t children = 0, onSegments = 0, inTriangles = 0;
        std::vector<std::size_t> near;
        for (std::size_t p = 0; p < n0; ++p) {
            near.clear();
            for (std::size_t i = 0; i < n0; ++i)
                if (i != p && glm::length(out.position[i] - out.position[p]) < 2.0f * radius[p])
                    near.push_back(i);
            for (std::size_t c = refiner.childBegin(0, p); c < refiner.childEnd(0, p); ++c) {
                ++children;
                bool segment = false, triangle = false;
                for (std::size_t b = 0; b < n0 && !segment; ++b)
                    segment = b != p && (segmentValues(out, c, p, b, 1.0f / 3.0f) ||
                                         segmentValues(out, c, p, b, 2.0f / 3.0f));
                for (std::size_t u = 0; u < near.size() && !segment && !triangle; ++u)
                    for (std::size_t w = u + 1; w < near.size() && !triangle; ++w)
                        triangle = triangleValues(out, c, p, near[u], near[w]);
                onSegments += segment;
                inTriangles += triangle;
            }
        }
        std::cout << "[" << name << ", level 1] " << children << " new points: " << onSegments
                  << " with the values of a segment point (" << stats.boundaryInserted
                  << " inserted on segments), " << inTriangles << " the means of a triangle\n";
        EXPECT_GT(stats.boundaryInserted, 20u);
        EXPECT_EQ(onSegments, stats.boundaryInserted);
        EXPECT_EQ(onSegments + inTriangles, children);
    }
}

// Attributes change nothing else, bit for bit, and do not depend on the thread count.
TEST(RefinerAttributes, ChangeNothingElseAndAreTheSameForAnyThreadCount) {
    PointSet cylinder = sampleCappedCylinder(48, 1.0f, 1.5f);
    estimateRadii(cylinder, 2);
    addRandomAttributes(cylinder, 5);
    PointSet plain = cylinder;
    plain.attributes.clear();
    const auto refined = [](const PointSet& input, unsigned threads) {
        RefineOptions options;
        options.threads = threads;
        Refiner refiner(input, options);
        for (int l = 0; l < 3; ++l) refiner.refineLevel();
        return std::move(refiner).takePoints();
    };
    const PointSet one = refined(cylinder, 1), four = refined(cylinder, 4), without = refined(plain, 2);
    EXPECT_EQ(test::pointSetDefect(one, test::kRefined), "");
    EXPECT_TRUE(sameAttributeValues(one, four));
    EXPECT_TRUE(sameBits(one.position, without.position) && sameBits(one.normal, without.normal) &&
                sameBits(one.radius, without.radius) && sameBits(one.colour, without.colour) &&
                sameBits(one.crease, without.crease));
    EXPECT_FALSE(without.hasAttributes());
}

} // namespace
} // namespace pnsplat
