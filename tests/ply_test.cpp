// Tests of PLY reading and writing: bit-exact round trips, property order and types, byte orders,
// faces, every rejected input, and atomic writes.
#include "pnsplat/refine/io/ply.h"

#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/refiner.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "test_data.h"

namespace pnsplat {
namespace {

using test::sameBits;

namespace fs = std::filesystem;

// A fresh folder under the system's temporary folder, removed with everything in it.
class PlyTest : public ::testing::Test {
  protected:
    void SetUp() override {
        static std::atomic<int> counter{0};
        dir_ = fs::temp_directory_path() /
               ("pnsplat-ply-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ec);
        fs::remove_all(dir_, ec);
    }

    fs::path file(const std::string& name) const { return dir_ / name; }

    fs::path writeFile(const std::string& name, const std::string& bytes) const {
        const fs::path path = file(name);
        std::ofstream out(path, std::ios::binary);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        EXPECT_TRUE(out.good());
        return path;
    }

    std::vector<std::string> entries() const {
        std::vector<std::string> names;
        for (const auto& entry : fs::directory_iterator(dir_))
            names.push_back(entry.path().filename().string());
        return names;
    }

    fs::path dir_;
};

// Bytes of a binary body in either byte order.
class Bytes {
  public:
    explicit Bytes(bool bigEndian) : bigEndian_(bigEndian) {}

    template <typename T>
    Bytes& put(T value) {
        char raw[sizeof(T)];
        std::memcpy(raw, &value, sizeof(T));
        if (bigEndian_ == (std::endian::native == std::endian::little))
            for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
        data_.append(raw, sizeof(T));
        return *this;
    }
    const std::string& str() const { return data_; }

  private:
    bool bigEndian_;
    std::string data_;
};

std::string binaryHeader(int n) {
    return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) +
           "\nproperty float x\nproperty float y\nproperty float z\n"
           "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
}

std::string binaryBody(const std::vector<std::array<float, 6>>& rows) {
    Bytes bytes(false);
    for (const auto& row : rows)
        for (float v : row) bytes.put(v);
    return bytes.str();
}

std::string asciiHeader(int n) {
    return "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n) +
           "\nproperty float x\nproperty float y\nproperty float z\n"
           "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
}

// An ascii header of n vertices with float x y z and then float properties of these names.
std::string asciiHeaderWith(int n, std::initializer_list<const char*> names) {
    std::string header = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n) +
                         "\nproperty float x\nproperty float y\nproperty float z\n";
    for (const char* name : names) header += std::string("property float ") + name + "\n";
    return header + "end_header\n";
}

PointSet randomPoints(std::size_t n, bool withRadius, bool withColour, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-1000.0f, 1000.0f);
    std::normal_distribution<float> gaussian(0.0f, 1.0f);
    std::uniform_real_distribution<float> radius(0.0f, 3.0f);
    std::uniform_int_distribution<int> byte(0, 255);
    PointSet points;
    for (std::size_t i = 0; i < n; ++i) {
        glm::vec3 p(coordinate(rng), coordinate(rng), coordinate(rng));
        // Awkward values for the shortest-representation printer.
        if (i == 0)
            p = glm::vec3(std::numeric_limits<float>::max(), std::numeric_limits<float>::denorm_min(), -0.0f);
        if (i == 1) p = glm::vec3(1e-30f, -3.4e38f, 0.1f);
        glm::vec3 normal;
        do {
            normal = glm::vec3(gaussian(rng), gaussian(rng), gaussian(rng));
        } while (glm::length(normal) < 0.1f);
        normal /= glm::length(normal);
        points.position.push_back(p);
        points.normal.push_back(normal);
        if (withRadius) points.radius.push_back(i == 2 ? 0.0f : radius(rng));
        if (withColour)
            points.colour.emplace_back(static_cast<std::uint8_t>(byte(rng)),
                                       static_cast<std::uint8_t>(byte(rng)),
                                       static_cast<std::uint8_t>(byte(rng)));
    }
    return points;
}

// --- Round trips -----------------------------------------------------------------------------

struct RoundTripCase {
    PlyFormat format;
    bool radius;
    bool colour;
};

class PlyRoundTrip : public PlyTest, public ::testing::WithParamInterface<RoundTripCase> {};

TEST_P(PlyRoundTrip, IsBitExact) {
    const RoundTripCase c = GetParam();
    const PointSet points = randomPoints(2000, c.radius, c.colour, 1234u);
    const fs::path path = file("round.ply");
    ASSERT_TRUE(writePly(path, points, c.format).ok());
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& back = read->points;
    EXPECT_TRUE(sameBits(back.position, points.position));
    EXPECT_TRUE(sameBits(back.normal, points.normal));
    EXPECT_TRUE(sameBits(back.radius, points.radius));
    EXPECT_TRUE(sameBits(back.colour, points.colour));
    EXPECT_EQ(back.hasRadius(), c.radius);
    EXPECT_EQ(back.hasColour(), c.colour);
    EXPECT_TRUE(read->triangles.empty());
    EXPECT_EQ(entries(), std::vector<std::string>{"round.ply"}); // no temporary file left
}

INSTANTIATE_TEST_SUITE_P(Formats, PlyRoundTrip,
                         ::testing::Values(RoundTripCase{PlyFormat::BinaryLittleEndian, false, false},
                                           RoundTripCase{PlyFormat::BinaryLittleEndian, true, false},
                                           RoundTripCase{PlyFormat::BinaryLittleEndian, false, true},
                                           RoundTripCase{PlyFormat::BinaryLittleEndian, true, true},
                                           RoundTripCase{PlyFormat::Ascii, false, false},
                                           RoundTripCase{PlyFormat::Ascii, true, false},
                                           RoundTripCase{PlyFormat::Ascii, false, true},
                                           RoundTripCase{PlyFormat::Ascii, true, true}),
                         [](const ::testing::TestParamInfo<RoundTripCase>& testInfo) {
                             const RoundTripCase& c = testInfo.param;
                             return std::string(c.format == PlyFormat::Ascii ? "Ascii" : "Binary") +
                                    (c.radius ? "Radius" : "") + (c.colour ? "Colour" : "");
                         });

// parsePly reads bytes in memory as readPly reads the file holding them, and names its `name`
// in errors.
TEST_F(PlyTest, BytesInMemoryReadAsTheirFile) {
    const PointSet points = randomPoints(500, true, true, 99u);
    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        const fs::path path = file("memory.ply");
        ASSERT_TRUE(writePly(path, points, format).ok());
        std::string bytes(fs::file_size(path), '\0');
        std::ifstream(path, std::ios::binary).read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        const Result<PlyData> fromFile = readPly(path), fromBytes = parsePly(bytes, "in memory");
        ASSERT_TRUE(fromFile.ok() && fromBytes.ok());
        EXPECT_TRUE(sameBits(fromBytes->points.position, fromFile->points.position));
        EXPECT_TRUE(sameBits(fromBytes->points.normal, fromFile->points.normal));
        EXPECT_TRUE(sameBits(fromBytes->points.radius, fromFile->points.radius));
        EXPECT_TRUE(sameBits(fromBytes->points.colour, fromFile->points.colour));
        bytes.resize(bytes.size() - 5);
        const Result<PlyData> cut = parsePly(bytes, "in memory");
        ASSERT_FALSE(cut.ok());
        EXPECT_EQ(cut.error().message.rfind("in memory: ", 0), 0u) << cut.error().message;
    }
}

// A binary body may end with white space or zero bytes, which some writers leave after the data
// (a line break, padding); anything else there is rows the header does not count
// (PlyBadFile.BinaryMoreRowsThanDeclared).
TEST_F(PlyTest, BinaryBodyMayEndWithALineBreakOrPadding) {
    const std::string row = binaryBody({{1, 2, 3, 0, 0, 1}});
    for (const std::string& end :
         {std::string("\n"), std::string("\r\n"), std::string(" \n\f\v\t"), std::string(16, '\0')}) {
        const Result<PlyData> read = parsePly(binaryHeader(2) + row + row + end, "in memory");
        ASSERT_TRUE(read.ok()) << read.error().message;
        EXPECT_EQ(read->points.size(), 2u);
    }
    const Result<PlyData> extra = parsePly(binaryHeader(2) + row + row + "\n\x01", "in memory");
    ASSERT_FALSE(extra.ok());
    EXPECT_EQ(extra.error().message, "in memory: 2 bytes after the last row the header declares (vertex 2)");
}

TEST_F(PlyTest, WrittenBinaryHeaderIsAsSpecified) {
    PointSet points = randomPoints(3, true, true, 7u);
    const fs::path path = file("header.ply");
    ASSERT_TRUE(writePly(path, points).ok());
    std::string text(fs::file_size(path), '\0');
    std::ifstream(path, std::ios::binary).read(text.data(), static_cast<std::streamsize>(text.size()));
    const std::size_t end = text.find("end_header\n");
    ASSERT_NE(end, std::string::npos);
    EXPECT_EQ(text.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
    EXPECT_NE(text.find("\nelement vertex 3\n"
                        "property float x\nproperty float y\nproperty float z\n"
                        "property float nx\nproperty float ny\nproperty float nz\n"
                        "property float radius\n"
                        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"),
              std::string::npos);
    EXPECT_EQ(text.size(), end + 11 + 3 * (7 * 4 + 3));
}

// A file whose every normal is 0 0 0 (a Gaussian-splatting scene; exporters that write no normal
// so) has none: its normals are estimated where they may be, and it fails where they are required.
// One zero normal among others stays an error (ZeroNormal, TinyNormal among the bad files).
TEST_F(PlyTest, AFileOfZeroNormalsHasNone) {
    const fs::path path = writeFile("zeros.ply", asciiHeader(3) + "0 0 0 0 0 0\n1 0 0 0 0 0\n0 1 0 0 0 0\n");
    const Result<PlyData> optional = readPly(path, {.requireNormals = false});
    ASSERT_TRUE(optional.ok()) << optional.error().message;
    EXPECT_EQ(optional->points.size(), 3u);
    EXPECT_TRUE(optional->points.normal.empty());
    EXPECT_TRUE(optional->zeroNormals);
    const Result<PlyData> required = readPly(path);
    ASSERT_FALSE(required.ok());
    EXPECT_NE(required.error().message.find("every normal is zero"), std::string::npos);
    const Result<PlyData> given =
        readPly(writeFile("given.ply", asciiHeader(2) + "0 0 0 0 0 1\n1 0 0 0 1 0\n"));
    ASSERT_TRUE(given.ok()) << given.error().message;
    EXPECT_FALSE(given->zeroNormals);
}

// --- Layouts and types -----------------------------------------------------------------------

TEST_F(PlyTest, AsciiWithShuffledPropertiesExtrasListsAndFaces) {
    const std::string text = "ply\r\n"
                             "format ascii 1.0\r\n"
                             "comment made by hand\r\n"
                             "obj_info anything at all\r\n"
                             "element face 2\r\n"
                             "property list uchar int vertex_indices\r\n"
                             "property uchar flags\r\n"
                             "element vertex 3\r\n"
                             "property float nz\r\n"
                             "property double x\r\n"
                             "property float confidence\r\n"
                             "property list uchar float samples\r\n"
                             "property int16 ny\r\n"
                             "property float32 y\r\n"
                             "property uchar blue\r\n"
                             "property float z\r\n"
                             "property uint8 green\r\n"
                             "property float nx\r\n"
                             "property uchar red\r\n"
                             "property float radius\r\n"
                             "element edge 1\r\n"
                             "property int vertex1\r\n"
                             "property list int uint extra\r\n"
                             "end_header\r\n"
                             "3 0 1 2 7\r\n"
                             "4 0 1 2 0 9\r\n"
                             "\r\n" // blank lines and blanks around a row's values are allowed
                             // nz x confidence [samples] ny y blue z green nx red radius
                             "0 1.5 0.25 2 1.0 -2.5 2 -2.5 20 3 0 0 10 0.5\r\n"
                             "  0 -4 nan 0 -7 0 50 4 40 0 30 0 \t\r\n"
                             "-1 1e3 1 1 0 1 1e-2 1 255 255\t1 255 +2.5\r\n"
                             "0 2 11 12\r\n";
    const fs::path path = writeFile("shuffled.ply", text);
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->points;
    ASSERT_EQ(p.size(), 3u);
    EXPECT_EQ(p.position[0], glm::vec3(1.5f, -2.5f, 3.0f));
    EXPECT_EQ(p.normal[0], glm::vec3(0.0f, 1.0f, 0.0f));
    EXPECT_EQ(p.colour[0], glm::u8vec3(10, 0, 20));
    EXPECT_EQ(p.radius[0], 0.5f);
    EXPECT_EQ(p.position[1], glm::vec3(-4.0f, 0.0f, 4.0f));
    EXPECT_EQ(p.normal[1], glm::vec3(0.0f, -1.0f, 0.0f));
    EXPECT_EQ(p.colour[1], glm::u8vec3(30, 40, 50));
    EXPECT_EQ(p.radius[1], 0.0f);
    EXPECT_EQ(p.position[2], glm::vec3(1000.0f, 0.01f, 255.0f));
    const float third = 1.0f / std::sqrt(3.0f);
    EXPECT_NEAR(p.normal[2].x, third, 1e-7f);
    EXPECT_NEAR(p.normal[2].y, third, 1e-7f);
    EXPECT_NEAR(p.normal[2].z, -third, 1e-7f);
    EXPECT_EQ(p.colour[2], glm::u8vec3(255, 255, 1));
    EXPECT_EQ(p.radius[2], 2.5f);
    EXPECT_TRUE(read->triangles.empty()); // faces not asked for

    const Result<PlyData> withFaces = readPly(path, {.readFaces = true});
    ASSERT_TRUE(withFaces.ok()) << withFaces.error().message;
    const std::vector<glm::u32vec3> expected = {{0, 1, 2}, {0, 1, 2}, {0, 2, 0}};
    EXPECT_EQ(withFaces->triangles, expected);
}

TEST_F(PlyTest, BinaryWithListsInVertexAndFacesFirst) {
    Bytes b(false);
    // face: uchar flags, list uchar uint vertex_indices (a quad and a triangle)
    b.put<std::uint8_t>(1)
        .put<std::uint8_t>(4)
        .put<std::uint32_t>(0)
        .put<std::uint32_t>(1)
        .put<std::uint32_t>(2)
        .put<std::uint32_t>(3);
    b.put<std::uint8_t>(2)
        .put<std::uint8_t>(3)
        .put<std::uint32_t>(3)
        .put<std::uint32_t>(2)
        .put<std::uint32_t>(1);
    // vertex: double x, list ushort short junk, float y z, uchar pad, float nx ny nz
    for (int i = 0; i < 4; ++i) {
        b.put<double>(i + 0.5).put<std::uint16_t>(static_cast<std::uint16_t>(i));
        for (int k = 0; k < i; ++k) b.put<std::int16_t>(-1);
        b.put<float>(10.0f * static_cast<float>(i)).put<float>(-1.0f).put<std::uint8_t>(9);
        b.put<float>(0.0f).put<float>(0.0f).put<float>(-3.0f);
    }
    const std::string header =
        "ply\nformat binary_little_endian 1.0\n"
        "element face 2\nproperty uchar flags\nproperty list uchar uint vertex_indices\n"
        "element vertex 4\nproperty double x\nproperty list ushort short junk\n"
        "property float y\nproperty float z\nproperty uchar pad\n"
        "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
    const fs::path path = writeFile("lists.ply", header + b.str());
    const Result<PlyData> read = readPly(path, {.readFaces = true});
    ASSERT_TRUE(read.ok()) << read.error().message;
    ASSERT_EQ(read->points.size(), 4u);
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(read->points.position[i],
                  glm::vec3(static_cast<float>(i) + 0.5f, 10.0f * static_cast<float>(i), -1.0f));
        EXPECT_EQ(read->points.normal[i], glm::vec3(0.0f, 0.0f, -1.0f));
    }
    const std::vector<glm::u32vec3> expected = {{0, 1, 2}, {0, 2, 3}, {3, 2, 1}};
    EXPECT_EQ(read->triangles, expected);
}

TEST_F(PlyTest, BigEndianWithMixedTypes) {
    Bytes b(true);
    b.put<std::int32_t>(-7).put<double>(0.25).put<float>(1e-3f);            // x (int), y (double), z
    b.put<float>(3.0f).put<float>(4.0f).put<float>(0.0f);                   // normal, to be normalised
    b.put<float>(1.0f).put<float>(0.5f).put<float>(0.0f).put<float>(0.75f); // float colour, radius
    b.put<std::int32_t>(65536).put<double>(-1e10).put<float>(-2.0f);
    b.put<float>(0.0f).put<float>(0.0f).put<float>(1e-6f);
    b.put<float>(-0.5f).put<float>(2.0f).put<float>(0.2f).put<float>(0.0f);
    const std::string header = "ply\nformat binary_big_endian 1.0\nelement vertex 2\n"
                               "property int x\nproperty double y\nproperty float z\n"
                               "property float nx\nproperty float ny\nproperty float nz\n"
                               "property float red\nproperty float green\nproperty float blue\n"
                               "property float radius\nend_header\n";
    const fs::path path = writeFile("big.ply", header + b.str());
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& p = read->points;
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p.position[0], glm::vec3(-7.0f, 0.25f, 1e-3f));
    EXPECT_NEAR(p.normal[0].x, 0.6f, 1e-7f);
    EXPECT_NEAR(p.normal[0].y, 0.8f, 1e-7f);
    EXPECT_EQ(p.normal[0].z, 0.0f);
    EXPECT_EQ(p.colour[0], glm::u8vec3(255, 128, 0));
    EXPECT_EQ(p.radius[0], 0.75f);
    EXPECT_EQ(p.position[1], glm::vec3(65536.0f, -1e10f, -2.0f));
    EXPECT_EQ(p.normal[1], glm::vec3(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(p.colour[1], glm::u8vec3(0, 255, 51)); // clamped, 0.2 * 255 rounded
    EXPECT_EQ(p.radius[1], 0.0f);
}

TEST_F(PlyTest, IntegerColoursAreClampedAndPartialColourIgnored) {
    const fs::path wide =
        writeFile("wide.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property float nx\nproperty float ny\nproperty float nz\n"
                              "property ushort red\nproperty short green\nproperty int blue\n"
                              "end_header\n0 0 0 1 0 0 1000 -5 77\n");
    const Result<PlyData> read = readPly(wide);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->points.colour.at(0), glm::u8vec3(255, 0, 77));

    const fs::path partial =
        writeFile("partial.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "property float nx\nproperty float ny\nproperty float nz\n"
                                 "property uchar red\nend_header\n0 0 0 1 0 0 9\n");
    const Result<PlyData> partialRead = readPly(partial);
    ASSERT_TRUE(partialRead.ok()) << partialRead.error().message;
    EXPECT_FALSE(partialRead->points.hasColour());
}

TEST_F(PlyTest, MeshWithoutNormalsNeedsReadFaces) {
    const fs::path path = writeFile("mesh.ply", "ply\nformat ascii 1.0\nelement vertex 4\n"
                                                "property float x\nproperty float y\nproperty float z\n"
                                                "element face 1\nproperty list uchar int vertex_index\n"
                                                "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
    const Result<PlyData> withFaces = readPly(path, {.readFaces = true});
    ASSERT_TRUE(withFaces.ok()) << withFaces.error().message;
    EXPECT_EQ(withFaces->points.size(), 4u);
    EXPECT_TRUE(withFaces->points.normal.empty());
    const std::vector<glm::u32vec3> expected = {{0, 1, 2}, {0, 2, 3}};
    EXPECT_EQ(withFaces->triangles, expected);

    const Result<PlyData> pointsOnly = readPly(path);
    ASSERT_FALSE(pointsOnly.ok());
    EXPECT_NE(pointsOnly.error().message.find("'nx'"), std::string::npos) << pointsOnly.error().message;
}

// Positions only (a scan for estimateNormals): accepted when normals are not required; some of
// nx ny nz alone stay an error either way.
TEST_F(PlyTest, NormalsMayBeAbsentWhenNotRequired) {
    const fs::path path = writeFile("positions.ply", "ply\nformat ascii 1.0\nelement vertex 2\n"
                                                     "property float x\nproperty float y\nproperty float z\n"
                                                     "property float radius\nend_header\n0 0 0 1\n1 2 3 1\n");
    const Result<PlyData> optional = readPly(path, {.requireNormals = false});
    ASSERT_TRUE(optional.ok()) << optional.error().message;
    EXPECT_EQ(optional->points.size(), 2u);
    EXPECT_FALSE(optional->points.hasNormal());
    EXPECT_EQ(optional->points.position[1], glm::vec3(1, 2, 3));
    EXPECT_TRUE(optional->points.hasRadius());
    const Result<PlyData> required = readPly(path);
    ASSERT_FALSE(required.ok());
    EXPECT_NE(required.error().message.find("'nx'"), std::string::npos) << required.error().message;

    const fs::path partial = writeFile("nz-only.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                                                      "property float x\nproperty float y\nproperty float z\n"
                                                      "property float nz\nend_header\n0 0 0 1\n");
    const Result<PlyData> partialRead = readPly(partial, {.requireNormals = false});
    ASSERT_FALSE(partialRead.ok());
    EXPECT_NE(partialRead.error().message.find("'nx'"), std::string::npos) << partialRead.error().message;
}

// PCL's normal_x normal_y normal_z are normals; a file with both spellings reads nx ny nz and
// names the others among the unused properties.
TEST_F(PlyTest, PclNormalsAreRead) {
    const fs::path pcl =
        writeFile("pcl.ply", asciiHeaderWith(2, {"normal_x", "normal_y", "normal_z", "curvature"}) +
                                 "0 0 0 0 0 1 0.5\n1 2 3 0 -1 0 0.25\n");
    const Result<PlyData> read = readPly(pcl);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->points.normal[0], glm::vec3(0, 0, 1));
    EXPECT_EQ(read->points.normal[1], glm::vec3(0, -1, 0));
    EXPECT_TRUE(read->unusedProperties.empty()); // curvature: an attribute
    ASSERT_EQ(read->points.attributes.size(), 1u);
    EXPECT_EQ(read->points.attributes[0].name, "curvature");

    const fs::path both =
        writeFile("both.ply", asciiHeaderWith(1, {"normal_x", "normal_y", "normal_z", "nx", "ny", "nz"}) +
                                  "0 0 0 0 0 1 1 0 0\n");
    const Result<PlyData> bothRead = readPly(both);
    ASSERT_TRUE(bothRead.ok()) << bothRead.error().message;
    EXPECT_EQ(bothRead->points.normal[0], glm::vec3(1, 0, 0));
    EXPECT_EQ(bothRead->unusedProperties, (std::vector<std::string>{"normal_x", "normal_y", "normal_z"}));

    const fs::path partial =
        writeFile("partial.ply", asciiHeaderWith(1, {"normal_x", "normal_y"}) + "0 0 0 0 1\n");
    const Result<PlyData> partialRead = readPly(partial, {.requireNormals = false});
    ASSERT_FALSE(partialRead.ok());
    EXPECT_NE(partialRead.error().message.find("no 'nz' (or 'normal_z') property"), std::string::npos)
        << partialRead.error().message;
}

// What a file holds beyond the points is named (unused vertex properties in file order: a partial
// colour; other elements with their counts; a face element only when faces are not read), other
// scalar properties are attributes, and header comments are kept as written.
TEST_F(PlyTest, UnusedPropertiesElementsAndCommentsAreReported) {
    const fs::path path = writeFile("extras.ply", "ply\nformat ascii 1.0\n"
                                                  "comment scanned 2024\n"
                                                  "obj_info  sensor: A\r\n"
                                                  "element vertex 3\n"
                                                  "property float x\nproperty float y\nproperty float z\n"
                                                  "property float confidence\nproperty float nx\n"
                                                  "property float ny\nproperty float nz\n"
                                                  "property float scalar_Intensity\nproperty uchar red\n"
                                                  "property uchar alpha\n"
                                                  "element face 1\nproperty list uchar int vertex_indices\n"
                                                  "element camera 2\nproperty float f\n"
                                                  "end_header\n"
                                                  "0 0 0 0.9 0 0 1 7 255 128\n1 0 0 0.9 0 0 1 7 255 128\n"
                                                  "0 1 0 0.9 0 0 1 7 255 128\n3 0 1 2\n1\n2\n");
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->unusedProperties, std::vector<std::string>{"red"});
    ASSERT_EQ(read->points.attributes.size(), 3u);
    EXPECT_EQ(read->points.attributes[0].name, "confidence");
    EXPECT_EQ(read->points.attributes[1].name, "scalar_Intensity");
    EXPECT_EQ(read->points.attributes[2].name, "alpha");
    ASSERT_EQ(read->unusedElements.size(), 2u);
    EXPECT_EQ(read->unusedElements[0].name, "face");
    EXPECT_EQ(read->unusedElements[0].count, 1u);
    EXPECT_EQ(read->unusedElements[1].name, "camera");
    EXPECT_EQ(read->unusedElements[1].count, 2u);
    EXPECT_EQ(read->comments, (std::vector<std::string>{"comment scanned 2024", "obj_info  sensor: A"}));

    const Result<PlyData> withFaces = readPly(path, {.readFaces = true});
    ASSERT_TRUE(withFaces.ok()) << withFaces.error().message;
    ASSERT_EQ(withFaces->unusedElements.size(), 1u);
    EXPECT_EQ(withFaces->unusedElements[0].name, "camera");

    ASSERT_TRUE(writePly(file("plain.ply"), read->points).ok());
    const Result<PlyData> written = readPly(file("plain.ply"));
    ASSERT_TRUE(written.ok()) << written.error().message;
    EXPECT_TRUE(written->unusedProperties.empty());
    EXPECT_TRUE(written->unusedElements.empty());
    EXPECT_EQ(written->comments, std::vector<std::string>{"comment written by pnsplat"});
}

// writePly carries comments on, before its own, in both formats; a header they would take past
// what readPly reads is an error that leaves no file.
TEST_F(PlyTest, CommentsAreCarriedOn) {
    const PointSet points = randomPoints(20, true, true, 3u);
    const std::vector<std::string> comments = {"comment source: scan 12", "obj_info  sensor: A", "comment"};
    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        const fs::path path = file("commented.ply");
        ASSERT_TRUE(writePly(path, points, format, comments).ok());
        const Result<PlyData> read = readPly(path);
        ASSERT_TRUE(read.ok()) << read.error().message;
        std::vector<std::string> expected = comments;
        expected.push_back("comment written by pnsplat");
        EXPECT_EQ(read->comments, expected);
        EXPECT_TRUE(sameBits(read->points.position, points.position));
    }
    const std::vector<std::string> many(2000, "comment " + std::string(30, 'x'));
    const fs::path tooMany = file("too-many.ply");
    const Result<void> written = writePly(tooMany, points, PlyFormat::BinaryLittleEndian, many);
    ASSERT_FALSE(written.ok());
    EXPECT_NE(written.error().message.find("header comments"), std::string::npos) << written.error().message;
    EXPECT_FALSE(fs::exists(tooMany));
    EXPECT_TRUE(
        writePly(tooMany, points, PlyFormat::BinaryLittleEndian, std::span(many).first(many.size() / 2))
            .ok());
}

TEST_F(PlyTest, NormalsAreNormalised) {
    const fs::path path =
        writeFile("normals.ply", asciiHeader(3) + "0 0 0 0 0 2\n0 0 0 3 4 0\n0 0 0 1e-9 0 0\n");
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    for (const glm::vec3& n : read->points.normal) EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f);
    EXPECT_EQ(read->points.normal[0], glm::vec3(0.0f, 0.0f, 1.0f));
    EXPECT_EQ(read->points.normal[2], glm::vec3(1.0f, 0.0f, 0.0f));
}

// --- Rejected inputs -------------------------------------------------------------------------

struct BadFile {
    const char* name;
    std::string bytes;
    const char* expected; // a part of the message
    bool readFaces = false;
};

std::vector<BadFile> badFiles() {
    const std::string ascii = asciiHeader(2);
    const std::string binary = binaryHeader(2);
    const std::string goodRow = binaryBody({{1, 2, 3, 0, 0, 1}});
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const std::string vertexProps = "property float x\nproperty float y\nproperty float z\n"
                                    "property float nx\nproperty float ny\nproperty float nz\n";
    std::string hugeHeader = "ply\nformat ascii 1.0\n";
    while (hugeHeader.size() < 70 * 1024) hugeHeader += "comment padding padding padding padding padding\n";
    hugeHeader += "element vertex 1\n" + vertexProps + "end_header\n0 0 0 0 0 1\n";
    const std::string radiusHeader =
        "ply\nformat ascii 1.0\nelement vertex 1\n" + vertexProps + "property float radius\nend_header\n";
    const std::string faceHeader = "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + vertexProps +
                                   "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const std::string asciiFaceHeader =
        "ply\nformat ascii 1.0\nelement vertex 3\n" + vertexProps +
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const std::string threeRows = "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n";
    return {
        {"Empty", "", "empty file"},
        {"NotPly", "hello world\n", "not a PLY file"},
        {"BinaryGarbage", std::string("\x7f\x45LF\0\0\0", 8), "not a PLY file"},
        {"UnknownFormat", "ply\nformat binary_middle_endian 1.0\nelement vertex 1\nend_header\n",
         "unknown format"},
        {"BadVersion", "ply\nformat ascii 2.0\nend_header\n", "version"},
        {"NoFormat", "ply\nelement vertex 1\n" + vertexProps + "end_header\n0 0 0 0 0 1\n", "no format"},
        {"TwoFormats", "ply\nformat ascii 1.0\nformat ascii 1.0\nend_header\n", "second format"},
        {"ElementWithoutCount", "ply\nformat ascii 1.0\nelement vertex\nend_header\n", "element"},
        {"NegativeCount", "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", "non-negative"},
        {"TextCount", "ply\nformat ascii 1.0\nelement vertex 12abc\nend_header\n", "non-negative"},
        {"OverflowingCount", "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n",
         "non-negative"},
        {"UnknownType", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", "type"},
        {"PropertyBeforeElement", "ply\nformat ascii 1.0\nproperty float x\nend_header\n",
         "before any element"},
        {"ShortPropertyLine", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float\nend_header\n",
         "property"},
        {"BadListLine", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar x\nend_header\n",
         "property"},
        {"FloatListCount", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\nend_header\n",
         "count type"},
        {"DuplicateProperty",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\n"
         "end_header\n",
         "same name"},
        {"DuplicateElement", "ply\nformat ascii 1.0\nelement vertex 1\nelement vertex 1\nend_header\n",
         "same name"},
        {"UnknownKeyword", "ply\nformat ascii 1.0\nelephant vertex 1\nend_header\n", "unknown keyword"},
        {"NoEndHeader", "ply\nformat ascii 1.0\nelement vertex 1\n" + vertexProps, "no end_header"},
        {"NoEndHeaderBinary",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + vertexProps + goodRow, "no end_header"},
        {"HugeHeader", hugeHeader, "64 KiB"},
        {"NoVertexElement", "ply\nformat ascii 1.0\nelement face 0\nend_header\n", "no vertex element"},
        {"MissingX",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nend_header\n1 2 0 0 1\n",
         "'x'"},
        {"MissingNz",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
         "property float z\nproperty float nx\nproperty float ny\nend_header\n1 2 3 0 1\n",
         "'nz'"},
        {"ListCoordinate",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\n"
         "property float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nend_header\n1 1 2 3 0 0 1\n",
         "is a list"},
        {"NoPoints", asciiHeader(0), "no points"},
        {"TruncatedBinary", binary + goodRow + goodRow.substr(0, 10),
         "truncated binary data (vertex 1 of 2)"},
        {"TruncatedBinaryEmptyBody", binary, "truncated binary data (vertex 0 of 2)"},
        {"TruncatedAscii", ascii + "1 2 3 0 0 1\n1 2 3 0 0\n", "truncated ascii data (vertex 1 of 2)"},
        {"NonNumericAscii", ascii + "1 2 3 0 0 1\n1 two 3 0 0 1\n", "bad number 'two'"},
        // A row's values lie on its line: one too few or too many is an error there, not a shift.
        {"AsciiShortRow", ascii + "1 2 3 0 0\n1 2 3 0 0 1\n",
         "line 11: fewer values than vertex 0 has properties (6)"},
        {"AsciiLongRow", ascii + "1 2 3 0 0 1\n1 2 3 0 0 1 7\n",
         "line 12: more values than vertex 1 has properties (6)"},
        {"AsciiTrailingJunk", ascii + "1 2 3 0 0 1\n1 2x 3 0 0 1\n", "bad number"},
        // Rows beyond the header's count would be lost unseen (blank lines after the last are fine).
        {"AsciiMoreRowsThanDeclared", ascii + "1 2 3 0 0 1\n1 2 3 0 0 1\n\n4 5 6 0 0 1\n",
         "line 14: '4' after the last row the header declares (vertex 2)"},
        {"BinaryMoreRowsThanDeclared", binary + goodRow + goodRow + goodRow,
         "24 bytes after the last row the header declares (vertex 2)"},
        {"AsciiIntegerOutOfRange",
         "ply\nformat ascii 1.0\nelement vertex 1\n" + vertexProps +
             "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n0 0 0 0 0 1 300 0 "
             "0\n",
         "bad number '300'"},
        {"AsciiFloatInIntegerField",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty short x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nend_header\n1.5 0 0 0 0 1\n",
         "bad number '1.5'"},
        {"AsciiNanCoordinate", ascii + "1 2 3 0 0 1\nnan 2 3 0 0 1\n", "non-finite coordinate at vertex 1"},
        {"AsciiInfNormal", ascii + "1 2 3 0 0 1\n1 2 3 0 -inf 1\n", "non-finite normal at vertex 1"},
        {"AsciiOverflowingFloat", ascii + "1 2 3 0 0 1\n1e39 2 3 0 0 1\n", "bad number"},
        {"DoubleOverflowingFloat",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nend_header\n1e300 0 0 0 0 1\n",
         "non-finite coordinate"},
        {"BinaryNanCoordinate", binary + goodRow + binaryBody({{1, nan, 3, 0, 0, 1}}),
         "non-finite coordinate"},
        {"BinaryInfNormal", binary + goodRow + binaryBody({{1, 2, 3, inf, 0, 1}}), "non-finite normal"},
        {"BinaryNanNormal", binary + binaryBody({{1, 2, 3, 0, nan, 1}}) + goodRow,
         "non-finite normal at vertex 0"},
        {"ZeroNormal", ascii + "1 2 3 0 0 1\n1 2 3 0 0 0\n", "zero-length normal at vertex 1"},
        {"TinyNormal", ascii + "1 2 3 1e-13 0 0\n1 2 3 0 0 1\n",
         "a normal after rows whose normals are zero at vertex 1"},
        {"NegativeRadius", radiusHeader + "0 0 0 0 0 1 -0.5\n", "radius"},
        {"InfiniteRadius", radiusHeader + "0 0 0 0 0 1 inf\n", "radius"},
        {"NanRadius", radiusHeader + "0 0 0 0 0 1 nan\n", "radius"},
        {"AbsurdBinaryCount",
         binaryHeader(0).replace(binaryHeader(0).find("vertex 0"), 8, "vertex 4000000000000") + goodRow,
         "truncated binary data (vertex 1 of 4000000000000)"},
        {"MaximalBinaryCount",
         binaryHeader(0).replace(binaryHeader(0).find("vertex 0"), 8, "vertex 18446744073709551615") +
             goodRow,
         "truncated binary data"},
        {"AbsurdAsciiCount",
         asciiHeader(0).replace(asciiHeader(0).find("vertex 0"), 8, "vertex 999999999999") + "0 0 0 0 0 1\n",
         "truncated ascii data (vertex element of 999999999999 rows"},
        {"AbsurdFaceCount",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + vertexProps +
             "element face 18446744073709551615\nproperty list uchar int vertex_indices\nend_header\n" +
             goodRow + "\x03",
         "truncated binary data (face element of 18446744073709551615 rows"},
        {"HugeBinaryList",
         faceHeader + goodRow + Bytes(false).put<std::uint8_t>(200).put<std::int32_t>(0).str(),
         "truncated binary data (face 0 of 1)"},
        {"NegativeBinaryList",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + vertexProps +
             "element face 1\nproperty list char int vertex_indices\nend_header\n" + goodRow + "\xff",
         "negative list length (face 0)"},
        {"HugeAsciiList", asciiFaceHeader + threeRows + "4000000000 0 1 2\n", "bad number"},
        {"LongAsciiList",
         "ply\nformat ascii 1.0\nelement vertex 3\n" + vertexProps +
             "element face 1\nproperty list uint int vertex_indices\nend_header\n" + threeRows +
             "4000000000 0 1 2\n",
         "truncated ascii data (face 0 of 1)"},
        {"FaceIndexOutOfRange",
         faceHeader + goodRow +
             Bytes(false)
                 .put<std::uint8_t>(3)
                 .put<std::int32_t>(0)
                 .put<std::int32_t>(0)
                 .put<std::int32_t>(1)
                 .str(),
         "refers to vertex 1 but there are only 1 vertices", true},
        {"NegativeFaceIndex", asciiFaceHeader + threeRows + "3 0 -1 2\n", "invalid vertex index in face 0",
         true},
        {"TwoVertexFace", asciiFaceHeader + threeRows + "2 0 1\n", "fewer than 3 vertices in face 0", true},
        {"FaceWithoutIndexList",
         "ply\nformat ascii 1.0\nelement vertex 3\n" + vertexProps +
             "element face 1\nproperty list uchar int corners\nend_header\n" + threeRows + "3 0 1 2\n",
         "no vertex_indices", true},
        {"TruncatedFaceAscii", asciiFaceHeader + threeRows + "3 0 1\n", "truncated ascii data (face 0 of 1)"},
    };
}

class PlyBadFile : public PlyTest, public ::testing::WithParamInterface<BadFile> {};

TEST_P(PlyBadFile, IsRejectedWithOneLineNamingTheFile) {
    const BadFile& bad = GetParam();
    const fs::path path = writeFile(std::string("bad-") + bad.name + ".ply", bad.bytes);
    const Result<PlyData> read = readPly(path, {.readFaces = bad.readFaces});
    ASSERT_FALSE(read.ok());
    const std::string& message = read.error().message;
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find(bad.expected), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

INSTANTIATE_TEST_SUITE_P(Cases, PlyBadFile, ::testing::ValuesIn(badFiles()),
                         [](const ::testing::TestParamInfo<BadFile>& testInfo) {
                             return std::string(testInfo.param.name);
                         });

TEST_F(PlyTest, MissingFileIsAnError) {
    const fs::path path = file("does-not-exist.ply");
    const Result<PlyData> read = readPly(path);
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.error().message.find(path.string()), std::string::npos);
    EXPECT_NE(read.error().message.find("no such file"), std::string::npos);
}

TEST_F(PlyTest, DirectoryIsAnError) {
    const Result<PlyData> read = readPly(dir_);
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.error().message.find(dir_.string()), std::string::npos);
    EXPECT_NE(read.error().message.find("directory"), std::string::npos);
}

TEST_F(PlyTest, PathThroughAFileIsAnError) {
    const fs::path plain = writeFile("plain.ply", asciiHeader(1) + "0 0 0 0 0 1\n");
    const Result<PlyData> read = readPly(plain / "inner.ply");
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.error().message.find("inner.ply"), std::string::npos);
}

TEST_F(PlyTest, UnreadableFileIsAnError) {
    const fs::path path = writeFile("secret.ply", asciiHeader(1) + "0 0 0 0 0 1\n");
    fs::permissions(path, fs::perms::none);
    if (std::ifstream(path).is_open()) GTEST_SKIP() << "permissions are not enforced for this user (root?)";
    const Result<PlyData> read = readPly(path);
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.error().message.find(path.string()), std::string::npos);
}

// --- Writing ---------------------------------------------------------------------------------

TEST_F(PlyTest, WriteIntoMissingDirectoryFailsAndLeavesNothing) {
    const PointSet points = randomPoints(10, false, false, 3u);
    const fs::path path = file("missing") / "out.ply";
    const Result<void> written = writePly(path, points);
    ASSERT_FALSE(written.ok());
    EXPECT_NE(written.error().message.find(path.string()), std::string::npos);
    EXPECT_FALSE(fs::exists(file("missing")));
    EXPECT_TRUE(entries().empty());
}

TEST_F(PlyTest, WriteOverADirectoryFailsAndRemovesTheTemporaryFile) {
    fs::create_directory(file("taken.ply"));
    const Result<void> written =
        writePly(file("taken.ply"), randomPoints(10, true, false, 3u), PlyFormat::Ascii);
    ASSERT_FALSE(written.ok());
    EXPECT_NE(written.error().message.find("taken.ply"), std::string::npos);
    EXPECT_EQ(entries(), std::vector<std::string>{"taken.ply"});
    EXPECT_TRUE(fs::is_directory(file("taken.ply")));
}

TEST_F(PlyTest, WriteIntoReadOnlyDirectoryFails) {
    const fs::path sub = file("readonly");
    fs::create_directory(sub);
    fs::permissions(sub, fs::perms::owner_read | fs::perms::owner_exec);
    if (std::ofstream(sub / "probe").is_open())
        GTEST_SKIP() << "permissions are not enforced for this user (root?)";
    const Result<void> written = writePly(sub / "out.ply", randomPoints(10, false, false, 3u));
    ASSERT_FALSE(written.ok());
    EXPECT_NE(written.error().message.find("out.ply"), std::string::npos);
    EXPECT_TRUE(fs::is_empty(sub));
}

TEST_F(PlyTest, WriteReplacesAnExistingFileCompletely) {
    const fs::path path = file("replace.ply");
    ASSERT_TRUE(writePly(path, randomPoints(5000, true, true, 11u), PlyFormat::Ascii).ok());
    const auto bigSize = fs::file_size(path);
    const PointSet small = randomPoints(3, false, false, 12u);
    ASSERT_TRUE(writePly(path, small).ok());
    EXPECT_LT(fs::file_size(path), bigSize);
    const Result<PlyData> read = readPly(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_TRUE(sameBits(read->points.position, small.position));
    EXPECT_FALSE(read->points.hasRadius());
    EXPECT_FALSE(read->points.hasColour());
    EXPECT_EQ(entries(), std::vector<std::string>{"replace.ply"});
}

// --- Real models (../shared/data) ------------------------------------------------------------

TEST(PlyData, BunnyMeshHasAllTriangles) {
    PNSPLAT_REQUIRE_DATA("bunny-mesh.ply");
    const Result<PlyData> read = readPly(test::dataDir() / "bunny-mesh.ply", {.readFaces = true});
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->points.size(), 34834u);
    EXPECT_EQ(read->triangles.size(), 69451u);
}

TEST(PlyData, BananaHasColour) {
    PNSPLAT_REQUIRE_DATA("banana-1500-random.ply");
    const Result<PlyData> read = readPly(test::dataDir() / "banana-1500-random.ply");
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->points.size(), 1500u);
    ASSERT_TRUE(read->points.hasColour());
    EXPECT_FALSE(read->points.hasRadius());
    bool anyColour = false;
    for (const glm::u8vec3& c : read->points.colour) anyColour = anyColour || c != glm::u8vec3(0);
    EXPECT_TRUE(anyColour);
}

// Without a crease flag, a second normal that is zero or repeats the first marks an ordinary
// point; with the flag, a crease point needs a second normal that is a direction.
TEST_F(PlyTest, SecondNormalsWithAndWithoutFlag) {
    const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                               "property float nx2\nproperty float ny2\nproperty float nz2\n";
    const Result<PlyData> unflagged =
        readPly(writeFile("a.ply", header + "end_header\n0 0 0 0 0 1 0 0 0\n"
                                            "1 0 0 0 0 1 0 0 1\n2 0 0 0 0 1 1 0 0\n"));
    ASSERT_TRUE(unflagged.ok()) << unflagged.error().message;
    EXPECT_FALSE(unflagged->points.isCrease(0));
    EXPECT_FALSE(unflagged->points.isCrease(1));
    EXPECT_TRUE(unflagged->points.isCrease(2));
    EXPECT_EQ(unflagged->points.crease[2], glm::vec3(1, 0, 0));

    const Result<PlyData> flagged =
        readPly(writeFile("b.ply", header + "property uchar crease\nend_header\n"
                                            "0 0 0 0 0 1 0 1 0 0\n1 0 0 0 0 1 0 1 0 1\n"
                                            "2 0 0 0 0 1 0 0 1 2\n"));
    ASSERT_TRUE(flagged.ok()) << flagged.error().message;
    EXPECT_FALSE(flagged->points.isCrease(0)); // flag 0: its n2 is ignored
    EXPECT_TRUE(flagged->points.isCrease(1));
    EXPECT_TRUE(flagged->points.isCrease(2)); // a corner: n2 = n is still its second normal

    const Result<PlyData> bad =
        readPly(writeFile("c.ply", header + "property uchar crease\nend_header\n"
                                            "0 0 0 0 0 1 0 0 0 1\n1 0 0 0 0 1 0 1 0 0\n"
                                            "2 0 0 0 0 1 0 1 0 0\n"));
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("crease normal"), std::string::npos) << bad.error().message;
}

// The fandisk's crease file: the same points, crease and corner points (flag 1 and 2) with their
// second normal, the others ordinary; the first normal is the file's, and a round trip through
// pnsplat's writer keeps every bit and the flags.
TEST_F(PlyTest, FandiskCreasePointsHaveTwoNormals) {
    PNSPLAT_REQUIRE_DATA("fandisk-1500-uniform-crease.ply");
    PNSPLAT_REQUIRE_DATA("fandisk-1500-uniform.ply");
    const Result<PlyData> crease = readPly(test::dataDir() / "fandisk-1500-uniform-crease.ply");
    ASSERT_TRUE(crease.ok()) << crease.error().message;
    const Result<PlyData> plain = readPly(test::dataDir() / "fandisk-1500-uniform.ply");
    ASSERT_TRUE(plain.ok()) << plain.error().message;
    const PointSet& points = crease->points;
    EXPECT_EQ(points.size(), 1500u);
    EXPECT_TRUE(sameBits(points.position, plain->points.position));
    ASSERT_TRUE(points.hasCrease());
    std::size_t creasePoints = 0, sameAsPlain = 0;
    for (std::size_t i = 0; i < 1500; ++i) {
        EXPECT_NEAR(glm::length(points.normal[i]), 1.0f, 1e-6f);
        if (points.isCrease(i)) {
            ++creasePoints;
            EXPECT_NEAR(glm::length(points.crease[i]), 1.0f, 1e-6f);
            EXPECT_LT(glm::dot(points.normal[i], points.crease[i]), 0.99f) << i; // two different sides
        }
        sameAsPlain += points.normal[i] == plain->points.normal[i] ? 1 : 0;
    }
    EXPECT_EQ(creasePoints, 173u + 6u);
    EXPECT_GE(sameAsPlain, 1500u - creasePoints);

    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        const auto path = file("crease.ply");
        ASSERT_TRUE(writePly(path, points, format).ok());
        const Result<PlyData> back = readPly(path);
        ASSERT_TRUE(back.ok()) << back.error().message;
        EXPECT_TRUE(sameBits(back->points.position, points.position));
        EXPECT_TRUE(sameBits(back->points.normal, points.normal));
        EXPECT_TRUE(sameBits(back->points.crease, points.crease));
    }
}

// --- Mutated files ---------------------------------------------------------------------------

// Random damage to valid files (bit flips, stray bytes, cuts, repeated chunks, header numbers
// replaced by extreme ones), fixed seeds: every mutant is either read into a consistent point set
// or rejected with a one-line message, and whatever is read goes through radius estimation and a
// level of refinement, or is rejected by validateForRefinement, without a crash or a hang (the
// sanitizer suites run this too).
std::string mutate(std::string bytes, std::mt19937_64& rng) {
    const auto pick = [&](std::size_t n) {
        return n == 0 ? std::size_t{0} : static_cast<std::size_t>(rng() % n);
    };
    static const std::array<const char*, 8> kNumbers = {"0",           "1",    "-1",  "4294967295",
                                                        "99999999999", "1e38", "nan", "3"};
    static const std::string kChars = "\n 0123456789-+.e\t\r";
    const int operations = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < operations && !bytes.empty(); ++k) {
        const std::size_t at = pick(bytes.size());
        switch (rng() % 6) {
        case 0:
            bytes[at] = static_cast<char>(bytes[at] ^ (1 << (rng() % 8)));
            break;
        case 1:
            bytes[at] = static_cast<char>(rng() & 0xff);
            break;
        case 2:
            bytes[at] = kChars[pick(kChars.size())];
            break;
        case 3:
            bytes.resize(at);
            break;
        case 4: {
            const std::size_t from = pick(bytes.size()), length = 1 + pick(64); // in this order
            bytes.insert(at, bytes.substr(from, length));
            break;
        }
        default: {
            // A number of the header (a count, a property's position) becomes an extreme one.
            const std::size_t headerEnd = std::min(bytes.find("end_header"), bytes.size());
            std::vector<std::size_t> digits;
            for (std::size_t i = 0; i < headerEnd; ++i)
                if (std::isdigit(static_cast<unsigned char>(bytes[i])) && (i == 0 || bytes[i - 1] == ' '))
                    digits.push_back(i);
            if (digits.empty()) break;
            const std::size_t begin = digits[pick(digits.size())];
            std::size_t end = begin;
            while (end < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[end]))) ++end;
            bytes.replace(begin, end - begin, kNumbers[pick(kNumbers.size())]);
        }
        }
    }
    return bytes;
}

TEST_F(PlyTest, MutatedFilesAreReadConsistentlyOrRejectedWithOneLine) {
    PointSet coloured = sampleSphereUniform(60, 1.0f);
    coloured.radius.assign(coloured.size(), 0.3f);
    coloured.colour.assign(coloured.size(), glm::u8vec3(200, 120, 40));
    PointSet creased = sampleSphereUniform(40, 1.0f);
    creased.crease.assign(creased.size(), glm::vec3(0.0f));
    for (std::size_t i = 0; i < creased.size(); i += 5) creased.crease[i] = glm::vec3(0.0f, 0.0f, 1.0f);
    std::vector<std::string> seeds;
    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        for (const PointSet* points : {&coloured, &creased}) {
            const fs::path path = file("seed.ply");
            ASSERT_TRUE(writePly(path, *points, format).ok());
            std::ifstream in(path, std::ios::binary);
            std::string bytes(fs::file_size(path), '\0');
            in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
            ASSERT_TRUE(in.good());
            seeds.push_back(std::move(bytes));
        }
    }
    seeds.push_back(asciiHeader(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0.2 0 0 1\n");

    std::mt19937_64 rng(20261123);
    constexpr int kMutantsPerSeed = 300;
    std::size_t read = 0, rejected = 0, refined = 0;
    for (const std::string& seed : seeds) {
        for (int m = 0; m < kMutantsPerSeed; ++m) {
            const fs::path path = writeFile("mutant.ply", mutate(seed, rng));
            PlyReadOptions options;
            options.readFaces = (m % 2) == 1;
            const Result<PlyData> result = readPly(path, options);
            if (!result.ok()) {
                ++rejected;
                const std::string& message = result.error().message;
                EXPECT_FALSE(message.empty());
                EXPECT_EQ(message.find('\n'), std::string::npos) << message;
                continue;
            }
            ++read;
            PointSet points = result->points;
            const std::size_t n = points.size();
            ASSERT_GT(n, 0u);
            ASSERT_EQ(points.normal.size(), n);
            ASSERT_EQ(test::pointSetDefect(points), "");
            for (const glm::u32vec3& t : result->triangles) ASSERT_TRUE(t.x < n && t.y < n && t.z < n);
            if (n < 3 || n > 500) continue;
            if (!points.hasRadius()) estimateRadii(points, 1);
            if (!validateForRefinement(points).ok()) continue;
            Refiner refiner(std::move(points), RefineOptions{});
            refiner.refineLevel();
            EXPECT_GE(refiner.points().size(), n);
            ++refined;
        }
    }
    std::cout << "    mutants: " << read << " read (" << refined << " refined), " << rejected
              << " rejected\n";
    EXPECT_GT(read, 0u);
    EXPECT_GT(rejected, 0u);
    EXPECT_GT(refined, 0u);
}

} // namespace
} // namespace pnsplat
