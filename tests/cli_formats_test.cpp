// The `pnsplat` program on point files besides PLY: `refine` reads text and PCD and writes the
// kind `-o` names, bit for bit the same refinement as from PLY; `render` reads PCD; a malformed
// file is one line naming its line.
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "program.h"

namespace pnsplat {
namespace {

using namespace test;

// The same sphere as PLY, XYZ text, CSV with a header, and ascii and binary PCD refines to the
// same points, written back as the kind of each output's name (issue 27, acceptance 7).
TEST(CliFormats, EveryInputKindRefinesBitForBitTheSame) {
    const TempDir dir;
    PointSet sphere = sampleSphereUniform(600, 1.0f);
    struct Kind {
        std::string in, out;
        bool ascii;
    };
    const std::vector<Kind> kinds = {{"scan.ply", "out.ply", false},
                                     {"scan.xyz", "out.xyz", false},
                                     {"scan.csv", "out.csv", false},
                                     {"scan.pcd", "out.pcd", false},
                                     {"ascii.pcd", "ascii-out.pcd", true}};
    PointSet first;
    for (const Kind& k : kinds) {
        ASSERT_TRUE(writePointFile(dir / k.in, sphere, k.ascii).ok());
        const RunResult r = run("refine " + quote(dir / k.in) + " -l 1 -o " + quote(dir / k.out) +
                                (k.ascii ? " --ascii" : ""));
        ASSERT_TRUE(r.exited && r.exitCode == 0) << k.in << ": " << r.err;
        EXPECT_EQ(r.err, "") << k.in;
        const Result<PointFileData> refined = readPointFile(dir / k.out);
        ASSERT_TRUE(refined.ok()) << refined.error().message;
        EXPECT_EQ(refined->kind, *pointFileKindOf(dir / k.out));
        const PointSet& points = refined->data.points;
        EXPECT_GT(points.size(), 2 * sphere.size()) << k.in;
        if (first.empty()) {
            first = points;
            continue;
        }
        EXPECT_TRUE(sameBits(points.position, first.position)) << k.in;
        EXPECT_TRUE(sameBits(points.normal, first.normal)) << k.in;
        EXPECT_TRUE(sameBits(points.radius, first.radius)) << k.in;
    }
    EXPECT_TRUE(readText(dir / "out.xyz").starts_with("//x y z nx ny nz radius\n"));
    EXPECT_TRUE(readText(dir / "ascii-out.pcd").find("\nDATA ascii\n") != std::string::npos);
}

// Positions only in a text file with another column named by --columns: normals estimated, the
// column carried through as an attribute; a partial colour is named in the warning.
TEST(CliFormats, ColumnsOptionNamesATextFilesColumns) {
    const TempDir dir;
    const PointSet sphere = sampleSphereUniform(300, 1.0f);
    std::string text;
    for (const glm::vec3& x : sphere.position) text += fmt::format("7 {} {} {} 5\n", x.x, x.y, x.z);
    writeText(dir / "scan.txt", text);
    const RunResult r = run("refine " + quote(dir / "scan.txt") + " --columns intensity,x,y,z,r -l 1 -o " +
                            quote(dir / "out.ply"));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.err.find("not used, dropped: column r"), std::string::npos) << r.err; // a partial colour
    const Result<PlyData> out = readPly(dir / "out.ply");
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_EQ(out->points.attributes.size(), 1u);
    EXPECT_EQ(out->points.attributes[0].name, "intensity");
    EXPECT_EQ(out->points.attributes[0].type, ScalarType::Float32);
    EXPECT_EQ(
        std::count(out->points.attributes[0].values.begin(), out->points.attributes[0].values.end(), 7.0),
        static_cast<std::ptrdiff_t>(out->points.size()));
    EXPECT_NE(r.err.find("has no normals"), std::string::npos) << r.err;

    // A PLY file names its own properties: the option is not used, and the user is told.
    ASSERT_TRUE(writePointFile(dir / "scan.ply", sphere).ok());
    const RunResult ply = run("refine " + quote(dir / "scan.ply") + " --columns intensity,x,y,z,r -l 1 -o " +
                              quote(dir / "out2.ply"));
    ASSERT_TRUE(ply.exited && ply.exitCode == 0) << ply.err;
    EXPECT_NE(ply.err.find("a PLY file names its own properties: --columns not used"), std::string::npos)
        << ply.err;
}

TEST(CliFormats, RenderReadsPcd) {
    const TempDir dir;
    ASSERT_TRUE(writePointFile(dir / "scan.pcd", makeBumpySphere()).ok());
    const RunResult r =
        run("render " + quote(dir / "scan.pcd") + " --width 64 --height 48 -o " + quote(dir / "out.png"));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const Result<engine::RgbaImage> image = engine::readPng(dir / "out.png");
    ASSERT_TRUE(image.ok()) << image.error().message;
    std::size_t drawn = 0; // pixels not of the white background
    for (std::size_t i = 0; i < image->pixels.size(); i += 4)
        drawn += image->pixels[i] < 250 || image->pixels[i + 1] < 250 || image->pixels[i + 2] < 250;
    EXPECT_GT(drawn, std::size_t{64 * 48 / 10});
}

TEST(CliFormats, MalformedTextIsOneLineNamingTheLine) {
    const TempDir dir;
    writeText(dir / "bad.xyz", "0 0 0\n1 0 0\n1 x 0\n");
    const RunResult r = run("refine " + quote(dir / "bad.xyz") + " -o " + quote(dir / "out.xyz"));
    EXPECT_TRUE(failsCleanly(r)) << r.err;
    EXPECT_NE(r.err.find("bad.xyz: line 3: 'x' is not a number"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.xyz"));
}

} // namespace
} // namespace pnsplat
