// End-to-end tests of the `pnsplat` program: help texts, the README's first command (the embedded
// default model), option conflicts, thread-count independence of the written file, `eval` JSON,
// and bad input (CONTRIBUTING.md "Errors": one line naming the file and the problem, a non-zero exit,
// never a crash, and no output file left behind).
//
// The program runs through program.h's run(); every test works in its own folder, removed at the end.
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "oracles.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "program.h"
#include "test_data.h"

namespace pnsplat {
namespace {

namespace fs = std::filesystem;
using namespace test;

std::string headerAscii(std::size_t count) {
    return "ply\nformat ascii 1.0\nelement vertex " + std::to_string(count) +
           "\nproperty float x\nproperty float y\nproperty float z\n"
           "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
}

// ---------------------------------------------------------------------------------------------

TEST(CliHelp, ProgramAndSubcommandsPrintTheirOptions) {
    struct Case {
        std::string args;
        std::vector<std::string> mentions;
    };
    const std::vector<Case> cases = {
        {"--help", {"refine", "eval", "bench", "render", "diff"}},
        {"render --help",
         {"--output", "--width", "--height", "--camera", "--orbit", "--elevation", "--up", "--frame", "--fov",
          "--refine-levels", "--fill-hole", "--path", "--device", "--json", "--compare", "--reference",
          "--reference-png"}},
        {"diff --help", {"--heatmap", "--max-rmse"}},
        {"bench render --help", {"--sizes", "--splat-pixels", "--repeat", "--output"}},
        {"refine --help",
         {"--output", "--levels", "--target-points", "--threads", "--fast", "--neighbourhood",
          "--no-smoothing", "--euclidean-geodesic", "--plain-angle", "--centroid-candidates", "--fill-hole",
          "--json"}},
        {"eval --help",
         {"--reference", "--input", "--output", "--flat-normals", "sphere:R", "torus:R,r", "uniformity_cv",
          "holes"}},
        {"bench --help", {"refine"}},
        {"bench refine --help",
         {"--sphere-points", "--target-points", "--repeat", "--output", "--input", "--models", "--levels",
          "--threads"}},
    };
    for (const Case& c : cases) {
        const RunResult r = run(c.args);
        EXPECT_TRUE(r.exited && r.exitCode == 0) << c.args << ": exit " << r.exitCode << "\n" << r.err;
        for (const std::string& m : c.mentions)
            EXPECT_NE(r.out.find(m), std::string::npos) << c.args << " lacks " << m;
    }
}

TEST(CliRefine, DefaultModelTwoLevels) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r = run("refine -o " + quote(out) + " -l 2");
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(r.err, "");
    std::cout << "[refine -l 2] " << r.out;
    EXPECT_NE(r.out.find(std::to_string(kDefaultModelPoints) + " points in"), std::string::npos) << r.out;
    EXPECT_EQ(lines(r.out).size(), 1u) << r.out;
    const auto data = readPly(out);
    ASSERT_TRUE(data.ok()) << data.error().message;
    const PointSet& points = data->points;
    // Two √3-like levels multiply the count by about 9.
    EXPECT_GT(points.size(), kDefaultModelPoints * 6);
    EXPECT_TRUE(points.hasColour());
    EXPECT_TRUE(points.hasRadius());
    EXPECT_NE(r.out.find(std::to_string(points.size()) + " out"), std::string::npos) << r.out;
}

TEST(CliRefine, LevelsAndTargetPointsAreExclusive) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r = run("refine -o " + quote(out) + " --levels 2 --target-points 20000");
    EXPECT_TRUE(failsCleanly(r, Exit::Usage));
    EXPECT_FALSE(fs::exists(out));
}

// A count or a bound out of range is named in one short line (CLI11's own checks printed their
// range up to the largest double, 309 digits).
TEST(CliRefine, CountsOutOfRangeGetAShortLine) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    for (const std::string bad : {"--target-points 0", "--max-points -3", "--max-points 1.5"}) {
        const RunResult r = run("refine -o " + quote(out) + " " + bad);
        EXPECT_TRUE(failsCleanly(r, Exit::Usage)) << bad;
        EXPECT_NE(r.err.find("must be a whole number of at least 1"), std::string::npos) << r.err;
        EXPECT_LT(r.err.size(), 160u) << r.err;
    }
    // NaN and infinity too, which CLI11's ranges let through (`--orbit nan` reached the camera).
    for (const std::string bad : {"render --orbit nan", "render --background nan,0,0", "render --fov inf",
                                  "bench view --target-fps nan", "refine --theta-f nan"}) {
        const RunResult r = run(bad + (bad.starts_with("bench") ? "" : " -o " + quote(out))); // bench: no -o
        EXPECT_TRUE(failsCleanly(r, Exit::Usage)) << bad;
        EXPECT_NE(r.err.find("must be a number from"), std::string::npos) << r.err;
    }
    const RunResult diff = run("diff a.png b.png --max-rmse -1");
    EXPECT_TRUE(failsCleanly(diff, Exit::Usage));
    EXPECT_NE(diff.err.find("--max-rmse: must be a number of at least 0 (got -1)"), std::string::npos)
        << diff.err;
    EXPECT_FALSE(fs::exists(out));
}

TEST(CliRefine, TargetPointsStopsAtTheFirstLevelReachingIt) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r = run("refine -o " + quote(out) + " --target-points 20000");
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    std::cout << "[refine --target-points 20000] " << r.out;
    const auto data = readPly(out);
    ASSERT_TRUE(data.ok()) << data.error().message;
    EXPECT_GE(data->points.size(), 20000u);
    // The level before had fewer than 20,000 points and a level about triples them.
    EXPECT_LT(data->points.size(), 80000u);
}

TEST(CliRefine, EvenOutAddsLevelsAfterTheUniformOnes) {
    const TempDir dir;
    const fs::path plain = dir / "plain.ply", even = dir / "even.ply";
    const RunResult r1 = run("refine -l 2 -o " + quote(plain));
    const RunResult r2 = run("refine -l 2 --even-out 2 -o " + quote(even));
    ASSERT_TRUE(r1.exited && r1.exitCode == 0) << r1.err;
    ASSERT_TRUE(r2.exited && r2.exitCode == 0) << r2.err;
    std::cout << "[refine -l 2 --even-out 2] " << r2.out;
    for (const char* bad : {"0.5", "-1", "abc", "2x", "101"}) {
        const fs::path none = dir / "none.ply";
        const RunResult r3 = run("refine -l 1 --even-out " + std::string(bad) + " -o " + quote(none));
        EXPECT_TRUE(failsCleanly(r3, Exit::Usage)) << "--even-out " << bad;
        EXPECT_FALSE(fs::exists(none)) << "--even-out " << bad;
    }
    const auto a = readPly(plain), b = readPly(even);
    ASSERT_TRUE(a.ok() && b.ok());
    // The evened-out file starts with the plain one's points and adds a few (the default model's
    // jittered sampling leaves a few sparse patches).
    ASSERT_GT(b->points.size(), a->points.size());
    EXPECT_LT(b->points.size(), 2 * a->points.size());
    EXPECT_TRUE(std::equal(a->points.position.begin(), a->points.position.end(), b->points.position.begin()));
    EXPECT_EQ(r1.out.find("evening out"), std::string::npos) << r1.out;
    EXPECT_NE(r2.out.find("evening out"), std::string::npos) << r2.out;
}

// Radii spanning the whole model: the refinement goes on (neighbourhoods cut to the nearest
// kMaxNeighbours points) and the summary is followed by a warning that names the likely cause.
TEST(CliRefine, OversizedRadiiRefineWithAWarning) {
    const TempDir dir;
    PointSet sphere = sampleSphereUniform(400, 1.0f);
    sphere.radius.assign(sphere.size(), 5.0f);
    const fs::path in = dir / "in.ply", out = dir / "out.ply";
    ASSERT_TRUE(writePly(in, sphere).ok());
    const RunResult r = run("refine " + quote(in) + " -l 1 -o " + quote(out));
    std::cout << "[refine, radii spanning the model] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(r.exited && r.exitCode == 0);
    EXPECT_TRUE(fs::exists(out));
    EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
    EXPECT_NE(r.err.find("warning"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("radii look too large"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--estimate-radii"), std::string::npos) << r.err;
    // Following the advice helps: no neighbourhood is cut.
    const RunResult estimated = run("refine " + quote(in) + " -l 1 --estimate-radii -o " + quote(out));
    ASSERT_TRUE(estimated.exited && estimated.exitCode == 0) << estimated.err;
    EXPECT_EQ(estimated.err, "");
}

// A scan in georeferenced coordinates, far from 0 (PlyData::origin): held less an origin near it,
// refined in single precision as the same scan near 0 is, bit for bit, and written back in double,
// in every kind; a hole given in the file's coordinates is filled where it is. Held in single
// precision in the file itself, its positions are rounded already: a warning says so.
TEST(CliRefine, GeoreferencedCoordinatesAreRefinedLessAnOrigin) {
    const TempDir dir;
    PointSet sphere = sampleSphereUniform(400, 1.0f);
    for (glm::vec3& p : sphere.position) p += glm::vec3(1.5f); // in [0.5, 2.5]: exact beside the origin
    const glm::vec3 pole(1.5f, 1.5f, 2.5f);
    std::vector<std::uint32_t> cut; // a hole about the north pole
    for (std::uint32_t i = 0; i < sphere.size(); ++i)
        if (glm::distance(sphere.position[i], pole) < 0.35f) cut.push_back(i);
    ASSERT_GT(cut.size(), 2u);
    removePoints(sphere, cut);
    const glm::dvec3 origin(500004.0, -2e6, 0.0);
    const std::string hole = " --fill-hole 1.5,1.5,2.5,0.3";
    ASSERT_TRUE(writePly(dir / "near.ply", sphere).ok());
    const RunResult near =
        run("refine " + quote(dir / "near.ply") + hole + " -l 1 -o " + quote(dir / "near-out.ply"));
    ASSERT_TRUE(near.exited && near.exitCode == 0) << near.err;
    EXPECT_EQ(near.err.find("origin"), std::string::npos) << near.err;
    const Result<PlyData> nearOut = readPly(dir / "near-out.ply");
    ASSERT_TRUE(nearOut.ok());
    for (const char* kind : {".ply", ".xyz", ".pcd"}) {
        const fs::path far = dir / (std::string("far") + kind), out = dir / (std::string("far-out") + kind);
        ASSERT_TRUE(writePointFile(far, sphere, false, {}, origin).ok());
        const RunResult r =
            run("refine " + quote(far) + " --fill-hole 500005.5,-1999998.5,2.5,0.3 -l 1 -o " + quote(out));
        ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
        EXPECT_NE(r.err.find("coordinates near 500004, -2000000, 0: held less that origin, in single "
                             "precision (point files written add it back, in double)"),
                  std::string::npos)
            << r.err;
        EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
        const Result<PointFileData> back = readPointFile(out);
        ASSERT_TRUE(back.ok()) << back.error().message;
        EXPECT_EQ(back->data.origin, origin) << kind;
        EXPECT_GT(back->data.points.size(), 2 * sphere.size()) << kind;
        EXPECT_TRUE(sameBits(back->data.points.position, nearOut->points.position)) << kind;
        EXPECT_TRUE(sameBits(back->data.points.normal, nearOut->points.normal)) << kind;
    }
    EXPECT_NE(readText(dir / "far-out.ply").find("property double x\n"), std::string::npos);
    // Read in double beside an origin, a hole's radius or place must still be a float's.
    for (const auto& [bad, says] : {std::pair{"500005.5,-1999998.5,2.5,1e-50", "the radius is not positive"},
                                    std::pair{"1e39,-1999998.5,2.5,0.3", "four finite numbers"}}) {
        const RunResult r =
            run("refine " + quote(dir / "far.pcd") + " --fill-hole " + bad + " -o " + quote(dir / "bad.ply"));
        EXPECT_TRUE(r.exited && r.exitCode == static_cast<int>(Exit::Usage)) << r.err;
        EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
    }
    // eval puts the files it reads on one origin: a reference of the sphere and a copy of it 12
    // above, out of every refined point's reach, has another (500000: the multiple of 32 nearest
    // the middle of its box) and is moved to the refined points'; the same report as near 0 but
    // for roundings.
    PointSet reference = sphere;
    for (std::size_t i = 0; i < sphere.size(); ++i) {
        reference.appendFrom(sphere, i);
        reference.position.back().z += 12.0f;
    }
    ASSERT_TRUE(writePly(dir / "near-ref.ply", reference).ok());
    ASSERT_TRUE(writePly(dir / "far-ref.ply", reference, PlyFormat::BinaryLittleEndian, {}, origin).ok());
    const Result<PlyData> farReference = readPly(dir / "far-ref.ply");
    ASSERT_TRUE(farReference.ok());
    EXPECT_EQ(farReference->origin, glm::dvec3(500000.0, -2e6, 0.0));
    const auto meanDistance = [&](const std::string& refined, const std::string& ref,
                                  const std::string& input) {
        const RunResult r = run("eval " + quote(dir / refined) + " --reference " + quote(dir / ref) +
                                " --input " + quote(dir / input));
        EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
        EXPECT_NE(r.out.find("\"input_preserved\": true"), std::string::npos) << r.out;
        const std::size_t at = r.out.find("\"mean\": ");
        return at == std::string::npos ? -1.0 : std::stod(r.out.substr(at + 8));
    };
    const double nearMean = meanDistance("near-out.ply", "near-ref.ply", "near.ply");
    EXPECT_GT(nearMean, 0.0);
    EXPECT_NEAR(meanDistance("far-out.ply", "far-ref.ply", "far.ply"), nearMean, 1e-6);

    // render prints its camera in the file's coordinates and takes --camera so: the same picture
    // (the camera given to a millionth of its distance), and the same as the sphere near 0 from
    // the camera less the origin. Fails where --camera is read less no origin (tried).
    const auto render = [&](const std::string& input, const std::string& options, const std::string& png) {
        const RunResult r = run("render " + quote(dir / input) + " --width 64 --height 48" + options +
                                " -o " + quote(dir / png));
        EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
        const std::size_t at = r.out.find("camera: --camera ");
        return at == std::string::npos ? std::string()
                                       : r.out.substr(at + 17, r.out.find(' ', at + 17) - at - 17);
    };
    const std::string farCamera = render("far.ply", "", "far.png");
    render("far.ply", " --camera " + farCamera, "again.png");
    const std::string nearCamera = render("near.ply", "", "near.png");
    const auto numbers = [](std::string text) {
        std::replace(text.begin(), text.end(), ',', ' ');
        std::istringstream in(text);
        std::vector<double> values;
        for (double v = 0.0; in >> v;) values.push_back(v);
        return values;
    };
    const std::vector<double> farValues = numbers(farCamera), nearValues = numbers(nearCamera);
    ASSERT_EQ(farValues.size(), 9u) << farCamera;
    ASSERT_EQ(nearValues.size(), 9u) << nearCamera;
    for (int k = 0; k < 9; ++k)
        EXPECT_NEAR(farValues[k] - (k < 6 ? origin[k % 3] : 0.0), nearValues[k], 1e-5) << farCamera;
    for (const char* png : {"again.png", "near.png"}) {
        const RunResult same =
            run("diff " + quote(dir / "far.png") + " " + quote(dir / png) + " --max-rmse 0.5");
        EXPECT_TRUE(same.exited && same.exitCode == 0) << png << ": " << same.out << same.err;
    }

    // bench view reads camera-path files and writes each frame's camera in them too: fails where
    // either is taken less no origin (tried).
    writeText(dir / "path.txt", "0  500005.5 -1999998.5 6  500005.5 -1999998.5 1.5\n"
                                "1  500005.5 -1999998.5 6  500005.5 -1999998.5 1.5\n");
    const RunResult walk = run("bench view " + quote(dir / "far.ply") + " --camera-path " +
                               quote(dir / "path.txt") + " --width 64 --height 48");
    ASSERT_TRUE(walk.exited && walk.exitCode == 0) << walk.err;
    EXPECT_NE(walk.out.find(R"("camera": "500005.5,-1999998.5,6,500005.5,-1999998.5,1.5,0,1,0")"),
              std::string::npos)
        << walk.out.substr(0, 2000);

    // The notes give places in the file's coordinates: an outlier 10 from the sphere.
    PointSet stray = sphere;
    stray.position[0] = glm::vec3(-4.0f, 10.0f, 7.0f); // 500000 -1999990 7 in the file
    ASSERT_TRUE(writePointFile(dir / "stray.ply", stray, false, {}, origin).ok());
    const RunResult strayRun =
        run("refine " + quote(dir / "stray.ply") + " -l 1 -o " + quote(dir / "stray-out.ply"));
    ASSERT_TRUE(strayRun.exited && strayRun.exitCode == 0) << strayRun.err;
    EXPECT_NE(strayRun.err.find("(the first at 500000 -1999990 7)"), std::string::npos) << strayRun.err;

    for (glm::vec3& p : sphere.position) p += glm::vec3(5e5f, -2e6f, 0.0f); // single precision, far
    ASSERT_TRUE(writePly(dir / "single.ply", sphere).ok());
    const RunResult single =
        run("refine " + quote(dir / "single.ply") + " -l 1 -o " + quote(dir / "out.ply"));
    ASSERT_TRUE(single.exited && single.exitCode == 0) << single.err;
    EXPECT_NE(single.err.find("warning: " + (dir / "single.ply").string() +
                              ": coordinates far from 0 in single precision are rounded by about"),
              std::string::npos)
        << single.err;
}

// What a new user tried (thirty-fifth session): --columns takes one argument (its names split at
// commas), so a file after it is not taken for a column; --ascii for a text output says it is not
// used (forty-fifth session: it was ignored silently); bench refine refuses a sphere of fewer than
// 3 points and to write its JSON over its input.
TEST(CliRefine, ListsAndOutputsOfANewUsersPass) {
    const TempDir dir;
    const fs::path in = dir / "scan.xyz", out = dir / "out.ply";
    writeText(in, "0 0 0\n1 0 0\n0 1 0\n1 1 0.1\n0.5 0.5 0.2\n");
    EXPECT_TRUE(
        failsCleanly(run("refine --columns x y z " + quote(in) + " -l 1 -o " + quote(out)), Exit::Usage));
    EXPECT_FALSE(fs::exists(out));
    const RunResult named = run("refine --columns x,y,z " + quote(in) + " -l 1 -o " + quote(out));
    EXPECT_TRUE(named.exited && named.exitCode == 0) << named.err;
    EXPECT_NE(named.out.find("5 points in"), std::string::npos) << named.out;
    EXPECT_EQ(named.err.find("--ascii"), std::string::npos) << named.err;
    const fs::path text = dir / "out.xyz";
    const RunResult ascii = run("refine --ascii " + quote(in) + " -l 1 -o " + quote(text));
    EXPECT_TRUE(ascii.exited && ascii.exitCode == 0) << ascii.err;
    EXPECT_NE(ascii.err.find(text.string() + ": a text point file is ascii already: --ascii not used"),
              std::string::npos)
        << ascii.err;
    EXPECT_TRUE(fs::exists(text));
    EXPECT_TRUE(failsCleanly(run("bench refine --sphere-points 2 --repeat 1"), Exit::Usage));
    const std::string before = "0 0 0\n";
    const fs::path victim = dir / "victim.xyz";
    writeText(victim, before);
    EXPECT_TRUE(
        failsCleanly(run("bench refine --input " + quote(victim) + " -o " + quote(victim)), Exit::Failure));
    EXPECT_EQ(readText(victim), before);
}

// Estimated radii that still reach more than kMaxNeighbours points (a sparse grid of spacing 1
// around a dense 40 x 40 patch of spacing 0.01): the warning names the uneven sampling and does
// not advise --estimate-radii, which would change nothing. (--keep-outliers: the grid's 169 points,
// 100 times sparser than the patch's 1,600, are otherwise left out as outliers, ALGORITHM.md §9.7.)
TEST(CliRefine, CutNeighbourhoodsWithEstimatedRadiiAdviseNothingUseless) {
    const TempDir dir;
    std::ostringstream body;
    std::size_t count = 0;
    for (int i = -6; i <= 6; ++i)
        for (int j = -6; j <= 6; ++j, ++count) body << i << " " << j << " 0 0 0 1\n";
    for (int i = 0; i < 40; ++i)
        for (int j = 0; j < 40; ++j, ++count) body << 2.3 + 0.01 * i << " " << 2.3 + 0.01 * j << " 0 0 0 1\n";
    const fs::path in = dir / "uneven.ply", out = dir / "out.ply";
    writeText(in, headerAscii(count) + body.str());
    const RunResult r = run("refine " + quote(in) + " -l 1 --keep-outliers -o " + quote(out));
    std::cout << "[refine, uneven sampling] exit " << r.exitCode << ": " << r.err;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
    EXPECT_NE(r.err.find("warning"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("sampling is very uneven"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("--estimate-radii"), std::string::npos) << r.err;
}

// Neighbourhoods cut at a later level only: the nefertiti's fourth level cuts one (a point whose
// radius grew to reach a ring neighbour across a gap, ALGORITHM.md §4.6), its first none. The
// warning names the level and does not blame the input's sampling or radii.
TEST(CliRefine, NeighbourhoodsCutOnlyAtALaterLevelNameTheLevel) {
    PNSPLAT_REQUIRE_DATA("nefertiti-3500-random.ply");
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r =
        run("refine " + quote(test::dataDir() / "nefertiti-3500-random.ply") + " -l 4 -o " + quote(out));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
    EXPECT_NE(r.err.find("warning: 1 neighbourhood(s)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("from level 4 on"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("sampling"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("--estimate-radii"), std::string::npos) << r.err;
}

// --fill-hole on a sphere with a hole (3,000 uniform points minus those within 0.7 of the north
// pole, a radius of some 11 spacings; it stays nearly empty when the uniform levels come first): the
// summary names the hole and its rim points, and the output samples the hole (the option given
// before the input file). Bad holes are one-line errors that leave no output: not four numbers
// (also when split over two options), a radius that is not positive, a number that is not one, a
// ball that reaches no point, a ball that holds points (as the second of two holes).
// A unit sphere of 3,000 points without those within 0.7 of its north pole: a hole about 1.3
// across, 20 spacings.
PointSet sphereWithAHole() {
    const PointSet sphere = sampleSphereUniform(3000, 1.0f);
    PointSet holed;
    for (std::size_t i = 0; i < sphere.size(); ++i)
        if (glm::length(sphere.position[i] - glm::vec3(0.0f, 0.0f, 1.0f)) >= 0.7f)
            holed.appendFrom(sphere, i);
    return holed;
}

TEST(CliRefine, FillHoleSamplesTheHole) {
    const TempDir dir;
    const PointSet holed = sphereWithAHole();
    const fs::path in = dir / "holed.ply", out = dir / "filled.ply";
    ASSERT_TRUE(writePly(in, holed).ok());
    const RunResult r = run("refine --fill-hole 0,0,1,0.7 " + quote(in) + " -l 2 -o " + quote(out));
    std::cout << "[refine --fill-hole] " << r.out;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("1 hole(s) filled from"), std::string::npos) << r.out;
    auto filled = readPly(out);
    ASSERT_TRUE(filled.ok()) << filled.error().message;
    std::size_t inside = 0;
    for (const glm::vec3& x : filled->points.position)
        inside += glm::length(x - glm::vec3(0.0f, 0.0f, 1.0f)) < 0.56f;
    // Measured 4,797 (2,479 before §9.6's mean normals and density levels); 12 with the uniform
    // levels first.
    EXPECT_GT(inside, 1000u);

    // Malformed texts are usage errors; balls that do not fit the input, failures.
    const std::vector<std::pair<std::string, Exit>> bads = {
        {"0,0,1", Exit::Usage},       {"0,0,1 --fill-hole 0.7", Exit::Usage},
        {"0,0,1,0.7,2", Exit::Usage}, {"0,0,1,0", Exit::Usage},
        {"0,0,1,-1", Exit::Usage},    {"0,0,1,nan", Exit::Usage},
        {"0,0,1,x", Exit::Usage},     {"0,,1,0.7", Exit::Usage},
        {"0,0,9,0.7", Exit::Failure}, {"0,0,1,0.7 --fill-hole 0,0,-1,0.3", Exit::Failure}};
    for (const auto& [holes, status] : bads) {
        SCOPED_TRACE(holes);
        const RunResult bad =
            run("refine " + quote(in) + " -l 1 --fill-hole " + holes + " -o " + quote(dir / "bad.ply"));
        std::cout << "[refine --fill-hole " << holes << "] exit " << bad.exitCode << ": " << bad.err;
        EXPECT_TRUE(failsCleanly(bad, status));
        EXPECT_FALSE(fs::exists(dir / "bad.ply"));
    }
}

// --fill-holes finds the same hole without being told where it is, fills it up to its size, leaves
// it open below; a SIZE that is not a positive length or multiple is a usage error.
TEST(CliRefine, FillHolesFindsTheHoleAndFillsIt) {
    const TempDir dir;
    const PointSet holed = sphereWithAHole();
    const fs::path in = dir / "holed.ply", out = dir / "filled.ply";
    ASSERT_TRUE(writePly(in, holed).ok());
    const auto insideOf = [](const fs::path& file) {
        auto filled = readPly(file);
        EXPECT_TRUE(filled.ok()) << filled.error().message;
        std::size_t inside = 0;
        if (filled)
            for (const glm::vec3& x : filled->points.position)
                inside += glm::length(x - glm::vec3(0.0f, 0.0f, 1.0f)) < 0.56f;
        return inside;
    };
    const RunResult r = run("refine --fill-holes 40x " + quote(in) + " -l 2 --json -o " + quote(out));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(jsonField(r.out, "holes_found"), "1") << r.out;
    EXPECT_EQ(jsonField(r.out, "holes"), "1") << r.out;
    EXPECT_NE(r.err.find("1 hole(s) up to"), std::string::npos) << r.err;
    EXPECT_GT(insideOf(out), 1000u); // as --fill-hole 0,0,1,0.7 (CliRefine.FillHoleSamplesTheHole)
    // Given by --fill-hole too: filled once, from the ball given.
    const RunResult both =
        run("refine --fill-holes 40x --fill-hole 0,0,1,0.7 " + quote(in) + " -l 1 --json -o " + quote(out));
    ASSERT_TRUE(both.exited && both.exitCode == 0) << both.err;
    EXPECT_EQ(jsonField(both.out, "holes"), "1") << both.out;
    EXPECT_EQ(jsonField(both.out, "holes_found"), "0") << both.out;
    EXPECT_NE(both.err.find("1 of them given by --fill-hole too"), std::string::npos) << both.err;
    // The real-time engine's commands fill the same hole before they refine (withHolesFilled).
    const RunResult view = run("bench view " + quote(in) +
                               " --fill-holes 40x --frames 2 --width 64 --height 48" + kFewWholeLevels);
    ASSERT_TRUE(view.exited && view.exitCode == 0) << view.err;
    EXPECT_NE(view.err.find("1 hole(s) up to"), std::string::npos) << view.err;
    EXPECT_EQ(view.err.find(fmt::format("({} points)", holed.size())), std::string::npos) << view.err;
    const RunResult small = run("refine --fill-holes 0.5 " + quote(in) + " -l 2 --json -o " + quote(out));
    ASSERT_TRUE(small.exited && small.exitCode == 0) << small.err;
    EXPECT_EQ(jsonField(small.out, "holes_found"), "0") << small.out;
    EXPECT_EQ(jsonField(small.out, "holes_left_open"), "1") << small.out;
    EXPECT_NE(small.err.find("1 wider left open"), std::string::npos) << small.err;
    EXPECT_EQ(insideOf(out), 0u);
    for (const char* bad : {"0", "-3", "x", "20y", "nan", "2xx"}) {
        const RunResult wrong = run("refine --fill-holes " + std::string(bad) + " " + quote(in) + " -o " +
                                    quote(dir / "bad.ply"));
        EXPECT_TRUE(failsCleanly(wrong, Exit::Usage)) << bad << ": " << wrong.err;
        EXPECT_FALSE(fs::exists(dir / "bad.ply"));
    }
}

// Flat and open scans (issue 27): a flat 25 × 25 grid and a gently rolling terrain-like patch,
// normals up (+z), render their lit side by default, offline and adaptive: the picture covers most
// of what the patch fills, not the blank of back faces (before the camera rule of camera.cpp, the
// flat grid put the eye on -z: 0 pixels covered).
TEST(CliRender, FlatAndTerrainScansShowTheSideTheirNormalsFace) {
    const TempDir dir;
    const auto height = [](float x, float y, float amplitude) {
        return amplitude * std::sin(3.0f * x) * std::cos(2.0f * y);
    };
    for (const float amplitude : {0.0f, 0.08f}) {
        PointSet patch;
        for (int j = 0; j < 25; ++j)
            for (int i = 0; i < 25; ++i) {
                const float x = 0.08f * float(i), y = 0.08f * float(j);
                patch.position.push_back({x, y, height(x, y, amplitude)});
                // The upward normal of z = h(x, y): (-h_x, -h_y, 1), normalised.
                const glm::vec3 up(-3.0f * amplitude * std::cos(3.0f * x) * std::cos(2.0f * y),
                                   2.0f * amplitude * std::sin(3.0f * x) * std::sin(2.0f * y), 1.0f);
                patch.normal.push_back(glm::normalize(up));
            }
        const fs::path in = dir / fmt::format("patch-{}.ply", amplitude);
        ASSERT_TRUE(writePly(in, patch).ok());
        for (const std::string mode : {"", " --adaptive"}) {
            SCOPED_TRACE(fmt::format("amplitude {}{}", amplitude, mode));
            const RunResult r = run("render " + quote(in) + mode + " --width 120 --height 90 --json -o " +
                                    quote(dir / "patch.png"));
            ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
            EXPECT_EQ(jsonField(r.out, "eye_side"), "+z") << r.out;
            // Seen from above, framed by its bounding sphere: the square covers about a third of the
            // picture (measured 3,420 to 4,084 of 10,800 pixels).
            EXPECT_GT(std::stod(jsonField(r.out, "covered_px")), 0.25 * 120 * 90) << r.out;
        }
    }
}

// render --adaptive with a cache too small for the settled picture (the default model at 64 × 48
// settles with 19,538 points, 625 kB; 0.1 MiB holds its 1,500 and stops short): it says so, and
// `settled` is false, where a cache of 1 MiB settles and the summary names the threshold reached.
TEST(CliRender, AdaptiveSaysWhenTheCacheStopsItShort) {
    const TempDir dir;
    const std::string size = " --width 64 --height 48 -o " + quote(dir / "d.png");
    for (const bool small : {true, false}) {
        SCOPED_TRACE(small ? "0.1 MiB" : "1 MiB");
        const std::string cache = small ? " --cache-mb 0.1" : " --cache-mb 1";
        const RunResult text = run("render --adaptive" + cache + size);
        ASSERT_TRUE(text.exited && text.exitCode == 0) << text.err;
        const std::string said = text.out + text.err;
        EXPECT_EQ(said.find("as far as the cache of 0.1 MiB holds, short of a median splat of 3 px") !=
                      std::string::npos,
                  small)
            << said;
        EXPECT_EQ(said.find("until its median splat is at most 3 px wide") != std::string::npos, !small)
            << said;
        const RunResult json = run("render --adaptive --json" + cache + size);
        ASSERT_TRUE(json.exited && json.exitCode == 0) << json.err;
        EXPECT_EQ(jsonField(json.out, "settled"), small ? "false" : "true") << json.out;
    }
    const RunResult plain = run("render --json" + size);
    ASSERT_TRUE(plain.exited && plain.exitCode == 0) << plain.err;
    EXPECT_EQ(jsonField(plain.out, "settled"), "null") << plain.out;
}

// A scan of positions only: normals estimated (ALGORITHM.md §9.2), said on stderr, and the refinement runs.
TEST(CliRefine, EstimatesMissingNormals) {
    const TempDir dir;
    const PointSet sphere = sampleSphereUniform(600, 1.0f);
    std::ostringstream text;
    text
        << "ply\nformat ascii 1.0\nelement vertex 600\nproperty float x\nproperty float y\nproperty float z\n"
        << "end_header\n"
        << std::setprecision(9);
    for (const glm::vec3& x : sphere.position) text << x.x << " " << x.y << " " << x.z << "\n";
    const fs::path in = dir / "positions.ply", out = dir / "refined.ply";
    writeText(in, text.str());
    const RunResult r = run("refine " + quote(in) + " -l 2 -o " + quote(out));
    std::cout << "[refine, positions only] exit " << r.exitCode << ": " << r.err;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.err.find("has no normals: estimated"), std::string::npos) << r.err;
    auto refined = readPly(out);
    ASSERT_TRUE(refined.ok()) << refined.error().message;
    const PointSet& points = refined->points;
    EXPECT_GT(points.size(), 5000u);
    // Every normal of the refined unit sphere faces outward and lies close to the true one.
    std::size_t inward = 0;
    double worst = 1.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double agreement = glm::dot(points.normal[i], glm::normalize(points.position[i]));
        inward += agreement < 0.0 ? 1 : 0;
        worst = std::min(worst, agreement);
    }
    std::cout << "    " << points.size() << " points, inward normals " << inward
              << ", worst cosine to the true normal " << worst << "\n";
    EXPECT_EQ(inward, 0u);
    EXPECT_GT(worst, std::cos(radians(5.0)));
}

// Flipped normals (issue 20): turned back with a note and a word in the summary; with
// --keep-normals, refine and render refuse with one line naming the first. Render turns them
// back too.
TEST(CliRefine, FlippedNormalsAreTurnedBackOrRefused) {
    const TempDir dir;
    PointSet sphere = sampleSphereRandom(1000, 1.0f, 9);
    for (const std::size_t i : {17u, 250u, 640u}) sphere.normal[i] = -sphere.normal[i];
    const fs::path in = dir / "flipped.ply", out = dir / "out.ply", png = dir / "out.png";
    ASSERT_TRUE(writePly(in, sphere).ok());

    RunResult r = run("refine " + quote(in) + " -l 1 -o " + quote(out));
    std::cout << "[refine, 3 flipped normals] " << r.err << r.out;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(r.err, "pnsplat: " + in.string() +
                         ": 3 normal(s) pointed against their neighbours' and were turned back (the first: "
                         "point 17); --keep-normals refuses them instead\n");
    EXPECT_NE(r.out.find("1000 points in (3 flipped normal(s) turned back)"), std::string::npos) << r.out;
    const auto refined = readPly(out);
    ASSERT_TRUE(refined.ok()) << refined.error().message;
    for (std::size_t i = 0; i < refined->points.size(); ++i)
        ASSERT_GT(glm::dot(refined->points.normal[i], refined->points.position[i]), 0.0f) << i;
    fs::remove(out);

    r = run("refine " + quote(in) + " -l 1 --keep-normals -o " + quote(out));
    std::cout << "[refine --keep-normals] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_NE(
        r.err.find(in.string() + ": 3 normal(s) point against their neighbours' (the first: point 17, at "),
        std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out));

    r = run("render " + quote(in) + " --keep-normals --width 64 --height 48 -o " + quote(png));
    std::cout << "[render --keep-normals] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_NE(r.err.find("3 normal(s) point against their neighbours'"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(png));

    r = run("render " + quote(in) + " --refine-levels 1 --width 64 --height 48 -o " + quote(png));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.err.find("3 normal(s) pointed against their neighbours' and were turned back"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
    EXPECT_TRUE(fs::exists(png));
}

// Acceptance 2 of issue 20 through the program: the bunny with 7 normals flipped (a fixed-seed
// choice) refines and renders (FlippedNormals.DataModelsRefineAsTheCleanOnes measures the result).
TEST(CliRefine, BunnyWithFlippedNormalsRefinesAndRenders) {
    PNSPLAT_REQUIRE_DATA("bunny-3500-random.ply");
    const TempDir dir;
    auto data = readPly(test::dataDir() / "bunny-3500-random.ply");
    ASSERT_TRUE(data.ok()) << data.error().message;
    PointSet bunny = std::move(data).value().points;
    std::mt19937_64 rng(7);
    std::set<std::size_t> flipped;
    while (flipped.size() < 7) flipped.insert(static_cast<std::size_t>(rng() % bunny.size()));
    for (const std::size_t i : flipped) bunny.normal[i] = -bunny.normal[i];
    const fs::path in = dir / "bunny-7.ply", out = dir / "out.ply", png = dir / "out.png";
    ASSERT_TRUE(writePly(in, bunny).ok());
    RunResult r = run("refine " + quote(in) + " -l 2 -o " + quote(out));
    std::cout << "[refine, bunny with 7 flipped normals] " << r.err << r.out;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("(7 flipped normal(s) turned back)"), std::string::npos) << r.out;
    r = run("render " + quote(in) + " --refine-levels 2 --width 160 --height 120 -o " + quote(png));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_TRUE(fs::exists(png));
}

// Extra scalar vertex properties are carried through to the output with their names and types
// (every new point the mean of its corners: here all equal); what refine does not use is named in
// one warning (a partial colour, list properties, other elements); PCL's normals are read (no
// note of normals estimated); the header's comments are carried on to the output.
TEST(CliRefine, ExtraPropertiesAreCarriedUnusedOnesNamedAndCommentsCarriedOn) {
    const TempDir dir;
    const PointSet sphere = sampleSphereUniform(600, 1.0f);
    std::ostringstream text;
    text << "ply\nformat ascii 1.0\ncomment scanned by hand\nelement vertex 600\n"
         << "property float x\nproperty float y\nproperty float z\nproperty float confidence\n"
         << "property float normal_x\nproperty float normal_y\nproperty float normal_z\n"
         << "property float scalar_Intensity\nproperty uchar alpha\nproperty uchar green\n"
         << "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
         << std::setprecision(9);
    for (std::size_t i = 0; i < sphere.size(); ++i) {
        const glm::vec3 x = sphere.position[i], n = sphere.normal[i];
        text << x.x << " " << x.y << " " << x.z << " 0.5 " << n.x << " " << n.y << " " << n.z
             << " 12 255 9\n";
    }
    text << "3 0 1 2\n";
    const fs::path in = dir / "extras.ply", out = dir / "out.ply";
    writeText(in, text.str());
    const RunResult r = run("refine " + quote(in) + " -l 1 -o " + quote(out));
    std::cout << "[refine, extra properties] " << r.err;
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_EQ(r.err, "pnsplat: warning: " + in.string() +
                         ": not used, dropped: vertex property green; element face (1 item(s))\n");
    const auto refined = readPly(out);
    ASSERT_TRUE(refined.ok()) << refined.error().message;
    const PointSet& points = refined->points;
    ASSERT_GT(points.size(), sphere.size());
    ASSERT_EQ(points.attributes.size(), 3u);
    const std::array<std::pair<const char*, ScalarType>, 3> kept{{{"confidence", ScalarType::Float32},
                                                                  {"scalar_Intensity", ScalarType::Float32},
                                                                  {"alpha", ScalarType::UInt8}}};
    const std::array<double, 3> value{0.5, 12.0, 255.0};
    for (std::size_t a = 0; a < 3; ++a) {
        EXPECT_EQ(points.attributes[a].name, kept[a].first);
        EXPECT_EQ(points.attributes[a].type, kept[a].second);
        EXPECT_EQ(
            std::count(points.attributes[a].values.begin(), points.attributes[a].values.end(), value[a]),
            static_cast<std::ptrdiff_t>(points.size()))
            << points.attributes[a].name;
    }
    EXPECT_EQ(refined->comments,
              (std::vector<std::string>{"comment scanned by hand", "comment written by pnsplat"}));
}

// A scan that repeats points (here every one, twice): each position is refined once, and the
// file comes out as from the points without repeats, bit for bit.
TEST(CliRefine, RepeatedPointsAreRefinedOnce) {
    const TempDir dir;
    PointSet sphere = sampleSphereUniform(600, 1.0f);
    estimateRadii(sphere, 1);
    PointSet twice = sphere;
    for (std::size_t i = 0; i < sphere.size(); ++i) twice.appendFrom(sphere, i);
    const fs::path once = dir / "once.ply", repeated = dir / "twice.ply";
    ASSERT_TRUE(writePly(once, sphere).ok());
    ASSERT_TRUE(writePly(repeated, twice).ok());
    const RunResult a = run("refine " + quote(once) + " -l 2 -o " + quote(dir / "a.ply"));
    const RunResult b = run("refine " + quote(repeated) + " -l 2 -o " + quote(dir / "b.ply"));
    std::cout << "[refine, every point twice] exit " << b.exitCode << ": " << b.err;
    ASSERT_TRUE(a.exited && a.exitCode == 0) << a.err;
    ASSERT_TRUE(b.exited && b.exitCode == 0) << b.err;
    EXPECT_NE(b.err.find("600 point(s) repeat the position of an earlier one"), std::string::npos) << b.err;
    EXPECT_NE(b.out.find("1200 points in (600 distinct)"), std::string::npos) << b.out;
    const std::string refinedOnce = readText(dir / "a.ply"), refinedTwice = readText(dir / "b.ply");
    ASSERT_GT(refinedOnce.size(), 100000u);
    EXPECT_TRUE(refinedOnce == refinedTwice);
}

TEST(CliRefine, ThreadCountDoesNotChangeTheFile) {
    const TempDir dir;
    const fs::path one = dir / "one.ply", two = dir / "two.ply";
    const RunResult r1 = run("refine -l 3 --threads 1 -o " + quote(one));
    const RunResult r2 = run("refine -l 3 --threads 2 -o " + quote(two));
    ASSERT_TRUE(r1.exited && r1.exitCode == 0) << r1.err;
    ASSERT_TRUE(r2.exited && r2.exitCode == 0) << r2.err;
    const std::string a = readText(one), b = readText(two);
    std::cout << "[refine -l 3] files for 1 and 2 threads: " << a.size() << " and " << b.size()
              << " bytes, identical: " << (a == b ? "yes" : "NO") << "\n";
    ASSERT_GT(a.size(), 100000u);
    EXPECT_TRUE(a == b);
}

// ---------------------------------------------------------------------------------------------
// Memory (issue 20, defect 3): what does not fit is refused before it starts, with its estimate;
// running out all the same, on any thread, is one line and a non-zero exit, never a signal.

// Sanitizers reserve terabytes of address space for their shadow memory: under ulimit -v their
// programs do not start.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__) // GCC
#define PNSPLAT_SANITIZED 1
#elif defined(__has_feature) // Clang
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PNSPLAT_SANITIZED 1
#endif
#endif
#ifdef PNSPLAT_SANITIZED
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#define PNSPLAT_SKIP_UNDER_SANITIZERS()                                                                      \
    do {                                                                                                     \
        if (kSanitized) GTEST_SKIP() << "a sanitizer's shadow memory does not fit under ulimit -v";          \
    } while (0)

// ulimit -v 3000000 (3.1 GB of address space) and 10 levels of igea's 600 points (some 35 million
// points, 5 GB): refused at once. Before, the refinement ran into the limit, and with more than
// one thread died of SIGSEGV or SIGABRT (std::bad_alloc on a worker thread).
TEST(CliMemory, RefinementBeyondTheAddressSpaceLimitIsRefusedWithItsEstimate) {
    PNSPLAT_SKIP_UNDER_SANITIZERS();
    PNSPLAT_REQUIRE_DATA("igea-600-uniform.ply");
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    for (const unsigned threads : {1u, 2u, 8u}) {
        SCOPED_TRACE(threads);
        const RunResult r = run("refine " + quote(test::dataDir() / "igea-600-uniform.ply") +
                                    " --levels 10 --threads " + std::to_string(threads) + " -o " + quote(out),
                                "ulimit -v 3000000; ");
        std::cout << "[ulimit -v 3000000; refine igea-600 --levels 10 --threads " << threads << "] exit "
                  << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r));
        EXPECT_NE(r.err.find("10 level(s) would make about 35.4 million points"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(" of address space); the address-space limit (ulimit -v) allows 3.1 GB"),
                  std::string::npos)
            << r.err;
        EXPECT_TRUE(dir.entries().empty());
    }
}

// 64 levels (the largest --levels takes) make some 7e33 points: refused at once, saying so.
TEST(CliMemory, SixtyFourLevelsAreRefusedAtOnce) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r = run("refine --levels 64 -o " + quote(out));
    std::cout << "[refine --levels 64] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_NE(r.err.find("64 level(s) would make about 5.2e+33 points"), std::string::npos) << r.err;
    EXPECT_TRUE(dir.entries().empty());
    // A target: at most three times the target (the level before it had fewer points).
    const RunResult target = run("refine --target-points 100000 --max-points 200000 -o " + quote(out));
    std::cout << "[refine --target-points 100000 --max-points 200000] exit " << target.exitCode << ": "
              << target.err;
    EXPECT_TRUE(failsCleanly(target));
    EXPECT_NE(target.err.find("would make about 300000 points"), std::string::npos) << target.err;
    EXPECT_NE(target.err.find("more than --max-points 200000"), std::string::npos) << target.err;
    EXPECT_TRUE(dir.entries().empty());
    // Within the bound it runs (1,500 points, 2 levels: about 13,500).
    const RunResult within = run("refine --levels 2 --max-points 20000 -o " + quote(out));
    EXPECT_TRUE(within.exited && within.exitCode == 0) << within.err;
    EXPECT_TRUE(fs::exists(out));
}

// --max-points lifts the bound, and the refinement runs into the address-space limit (set at about
// 120 MB plus 84 MiB per extra thread, which lets the default model reach level 5 or 6): the
// allocation fails inside the levels, on whichever worker, and the program says so in one line.
TEST(CliMemory, RunningOutOfMemoryOnAnyThreadIsOneLine) {
    PNSPLAT_SKIP_UNDER_SANITIZERS();
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    for (const unsigned threads : {1u, 2u, 8u}) {
        SCOPED_TRACE(threads);
        const unsigned limitKb = 120000 + (threads - 1) * 86000;
        const RunResult r = run("refine --levels 10 --max-points 1000000000 --threads " +
                                    std::to_string(threads) + " -o " + quote(out),
                                "ulimit -v " + std::to_string(limitKb) + "; ");
        std::cout << "[ulimit -v " << limitKb << "; refine --levels 10 --threads " << threads << "] exit "
                  << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r));
        EXPECT_NE(r.err.find("out of memory in refinement level"), std::string::npos) << r.err;
        EXPECT_TRUE(dir.entries().empty());
    }
}

// ---------------------------------------------------------------------------------------------
// Outputs (issue 20, defect 4): one writer for every file (output_file.h).

bool isLink(const fs::path& path) {
    return fs::is_symlink(fs::symlink_status(path));
}

// Every output through a link: the link's target gets the file and the link stays. Before, the
// link was replaced by a regular file (and bench wrote its JSON with a plain stream).
TEST(CliOutput, EveryWriterWritesThroughALink) {
    const TempDir dir;
    const fs::path sphere = dir / "sphere.ply";
    ASSERT_TRUE(writePly(sphere, sampleSphereUniform(600, 1.0f)).ok());
    struct Case {
        std::string what, args; // args end with the option that names the output
    };
    const std::vector<Case> cases = {
        {"refine", "refine " + quote(sphere) + " -l 1 -o"},
        {"eval -o", "eval " + quote(sphere) + " --reference sphere:1 -o"},
        {"eval --hole-map", "eval " + quote(sphere) + " --reference sphere:1 --hole-map"},
        {"render", "render --width 32 --height 24 -o"},
        {"bench refine", "bench refine --sphere-points 200 --target-points 2000 --repeat 1 -o"},
    };
    std::vector<std::string> withLinks;
    for (std::size_t k = 0; k < cases.size(); ++k) {
        SCOPED_TRACE(cases[k].what);
        const fs::path target = dir / ("target-" + std::to_string(k)),
                       link = dir / ("link-" + std::to_string(k));
        fs::create_symlink(target.filename(), link);
        const RunResult r = run(cases[k].args + " " + quote(link));
        EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
        EXPECT_TRUE(isLink(link));
        EXPECT_TRUE(fs::is_regular_file(target));
        EXPECT_GT(readText(target).size(), 10u);
    }
    // diff's heat map, from the picture just rendered.
    const fs::path picture = dir / "target-3", link = dir / "heat-link", target = dir / "heat.png";
    fs::create_symlink("heat.png", link);
    const RunResult r = run("diff " + quote(picture) + " " + quote(picture) + " --heatmap " + quote(link));
    EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_TRUE(isLink(link));
    EXPECT_EQ(readText(target).substr(1, 3), "PNG");
}

// `-` reads standard input and writes standard output, in a pipe: the same bytes as through files;
// the summary goes to standard error. Before, `-o -` made a file named "-" and `-` was no input.
TEST(CliOutput, StandardInputAndOutputInAPipe) {
    const TempDir dir;
    const fs::path in = dir / "in.ply", direct = dir / "direct.ply";
    ASSERT_TRUE(writePly(in, sampleSphereUniform(600, 1.0f)).ok());
    const RunResult files = run("refine " + quote(in) + " -l 2 -o " + quote(direct));
    ASSERT_TRUE(files.exited && files.exitCode == 0) << files.err;
    const std::string expected = readText(direct);
    ASSERT_GT(expected.size(), 100000u);

    const RunResult piped =
        runShell("cd " + quote(dir.path()) + " && cat in.ply | " + program() + " refine - -l 2 -o - | cat");
    std::cout << "[cat in.ply | refine - -l 2 -o - | cat] " << piped.err;
    ASSERT_TRUE(piped.exited && piped.exitCode == 0) << piped.err;
    EXPECT_TRUE(piped.out == expected) << piped.out.size() << " bytes, expected " << expected.size();
    EXPECT_NE(piped.err.find("standard input: 600 points in"), std::string::npos) << piped.err;
    EXPECT_NE(piped.err.find("-> standard output"), std::string::npos) << piped.err;

    // Standard input without -o: standard output (a filter). A link to /proc/self/fd/1, as
    // /dev/stdout is (which the program, as root, used to replace by its file; a link of our own
    // here, so that a relapse cannot break the system's), is standard output too.
    const RunResult filter = runShell(program() + " refine - -l 2 < " + quote(in));
    EXPECT_TRUE(filter.exited && filter.exitCode == 0) << filter.err;
    EXPECT_TRUE(filter.out == expected);
    fs::create_symlink("/proc/self/fd/1", dir / "stdout");
    const RunResult devStdout =
        runShell(program() + " refine " + quote(in) + " -l 2 -o " + quote(dir / "stdout") + " | cat");
    EXPECT_TRUE(devStdout.exited && devStdout.exitCode == 0) << devStdout.err;
    EXPECT_TRUE(devStdout.out == expected);
    EXPECT_TRUE(isLink(dir / "stdout"));

    // A PNG to standard output.
    const RunResult png = runShell(program() + " render --width 32 --height 24 -o - | cat");
    EXPECT_TRUE(png.exited && png.exitCode == 0) << png.err;
    EXPECT_EQ(png.out.substr(1, 3), "PNG");
    EXPECT_TRUE(dir.entries() == (std::set<std::string>{"in.ply", "direct.ply", "stdout"}));
}

// A FIFO, a device node made with mknod (as root) and /dev/null are written through and stay what
// they are; /dev/full fails in one line. Before, the program renamed its file over them (as root,
// over the system's devices): the FIFO and the node come first, so that a relapse stops the test
// before it reaches /dev/null.
TEST(CliOutput, PipesAndDevicesAreWrittenThroughNotReplaced) {
    const TempDir dir;
    const fs::path fifo = dir / "fifo";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const RunResult piped = runShell("timeout 60 cat " + quote(fifo) + " | wc -c & " + program() +
                                     " refine -l 1 -o " + quote(fifo) + " > /dev/null; wait");
    EXPECT_TRUE(piped.exited && piped.exitCode == 0) << piped.err;
    EXPECT_GT(std::stol("0" + piped.out), 100000) << piped.out; // the bytes the reader got
    ASSERT_TRUE(fs::is_fifo(fs::symlink_status(fifo))) << "the FIFO was replaced";

    struct stat s {};
    if (::geteuid() != 0) {
        std::cout << "    (not root: no device node made here)\n";
    } else {
        const fs::path node = dir / "node";
        if (::mknod(node.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) {
            std::cout << "    (mknod refused: " << std::strerror(errno) << "; no device node made here)\n";
        } else {
            const RunResult r = run("refine -l 1 -o " + quote(node));
            EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
            ASSERT_EQ(::lstat(node.c_str(), &s), 0);
            ASSERT_TRUE(S_ISCHR(s.st_mode) && s.st_rdev == makedev(1, 3)) << "the device node was replaced";
        }
    }

    const RunResult null = run("refine -l 1 -o /dev/null");
    EXPECT_TRUE(null.exited && null.exitCode == 0) << null.err;
    ASSERT_EQ(::lstat("/dev/null", &s), 0);
    EXPECT_TRUE(S_ISCHR(s.st_mode) && s.st_rdev == makedev(1, 3));

    const RunResult full = run("refine -l 1 -o /dev/full");
    std::cout << "[refine -o /dev/full] exit " << full.exitCode << ": " << full.err;
    EXPECT_TRUE(failsCleanly(full));
    EXPECT_NE(full.err.find("/dev/full: cannot write: No space left on device"), std::string::npos);
    EXPECT_TRUE(dir.entries() == (std::set<std::string>{"fifo", "node"}) ||
                dir.entries() == (std::set<std::string>{"fifo"}));
}

// An output that is an input, however it is spelled (another path, a symbolic or a hard link), is
// refused before any work unless --force; with --force the input is replaced by the output.
TEST(CliOutput, TheInputIsNotOverwrittenWithoutForce) {
    const TempDir dir;
    const fs::path in = dir / "in.ply";
    ASSERT_TRUE(writePly(in, sampleSphereUniform(600, 1.0f)).ok());
    const std::string original = readText(in);
    fs::create_symlink("in.ply", dir / "soft.ply");
    fs::create_hard_link(in, dir / "hard.ply");
    for (const fs::path& out : {in, dir / "." / "in.ply", dir / "soft.ply", dir / "hard.ply"}) {
        SCOPED_TRACE(out.string());
        const RunResult r = run("refine " + quote(in) + " -l 1 -o " + quote(out));
        std::cout << "[refine in.ply -o " << out.filename() << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r));
        EXPECT_NE(r.err.find("not overwriting it without --force"), std::string::npos) << r.err;
        EXPECT_TRUE(readText(in) == original);
    }
    for (const std::string& args :
         {"eval " + quote(in) + " --reference sphere:1 -o " + quote(dir / "soft.ply"),
          "eval " + quote(in) + " --reference sphere:1 --hole-map " + quote(in),
          "render " + quote(in) + " -o " + quote(in), "bench view " + quote(in) + " -o " + quote(in),
          "diff " + quote(in) + " " + quote(in) + " --heatmap " + quote(in)}) {
        SCOPED_TRACE(args);
        EXPECT_TRUE(failsCleanly(run(args)));
        EXPECT_TRUE(readText(in) == original);
    }
    EXPECT_TRUE(dir.entries() == (std::set<std::string>{"in.ply", "soft.ply", "hard.ply"}));

    const RunResult forced = run("refine " + quote(in) + " -l 1 --force -o " + quote(in));
    EXPECT_TRUE(forced.exited && forced.exitCode == 0) << forced.err;
    const auto refined = readPly(in);
    ASSERT_TRUE(refined.ok()) << refined.error().message;
    EXPECT_GT(refined->points.size(), 1500u);
}

// A signal while the output is written (an ascii PLY of half a million points, some 40 MB: the
// program is signalled once it holds a file of the folder open) leaves the folder as it was. The
// unnamed temporary file (O_TMPFILE) vanishes with the process, SIGKILL included. Before, the
// program left OUT.ply.tmp-PID-0 behind.
TEST(CliOutput, SignalsDuringAWriteLeaveNothing) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const std::string prefix = dir.path().string() + "/";
    for (const int signal : {SIGINT, SIGTERM, SIGKILL}) {
        SCOPED_TRACE(strsignal(signal));
        const std::string programPath = test::programPath().string(), outPath = out.string();
        std::vector<std::string> arguments = {programPath, "refine", "-l", "5", "--ascii", "-o", outPath};
        std::vector<char*> argv;
        for (std::string& a : arguments) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
        posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
        pid_t child = 0;
        ASSERT_EQ(posix_spawn(&child, programPath.c_str(), &actions, nullptr, argv.data(), environ), 0);
        posix_spawn_file_actions_destroy(&actions);
        // Wait until it writes: a descriptor of it leads into the folder ("/dir/#123 (deleted)").
        const fs::path fds = fs::path("/proc") / std::to_string(child) / "fd";
        bool writing = false;
        for (int exited = 0; !writing && exited == 0; exited = ::waitpid(child, nullptr, WNOHANG)) {
            std::error_code ec;
            for (fs::directory_iterator it(fds, ec), end; !ec && it != end; it.increment(ec))
                writing |= fs::read_symlink(it->path(), ec).string().rfind(prefix, 0) == 0;
        }
        ASSERT_TRUE(writing) << "the program ended before it was seen writing";
        ::kill(child, signal);
        int status = 0;
        ASSERT_EQ(::waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << status;
        EXPECT_TRUE(dir.entries().empty()) << *dir.entries().begin();
    }
}

// ---------------------------------------------------------------------------------------------
// Acceptance 7: bad input.

struct BadInput {
    std::string name;
    std::string content;   // the input file's bytes; empty: no file at all
    std::string says = ""; // a phrase the message must contain, when not empty
};

std::string validBinaryPly(const TempDir& dir) {
    const fs::path p = dir / "valid.ply";
    EXPECT_TRUE(writePly(p, sampleSphereUniform(600, 1.0f)).ok());
    std::string bytes = readText(p);
    fs::remove(p);
    return bytes;
}

TEST(CliBadInput, RefineFailsWithOneLineAndNoOutput) {
    const TempDir dir;
    const std::string valid = validBinaryPly(dir);
    const std::size_t bodyStart = valid.find("end_header\n") + 11;
    ASSERT_LT(bodyStart, valid.size());
    // Cut in the middle of a vertex record.
    const std::string truncated = valid.substr(0, bodyStart + (valid.size() - bodyStart) / 2 + 5);

    std::vector<BadInput> cases = {
        {"missing file", ""},
        {"truncated binary", truncated},
        {"header cut short", valid.substr(0, bodyStart / 2)},
        {"malformed vertex count",
         "ply\nformat binary_little_endian 1.0\nelement vertex many\nproperty float x\nend_header\n"},
        {"unknown format",
         "ply\nformat binary_middle_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n"},
        {"not a PLY", "solid cube\nfacet normal 0 0 1\n"},
        // Without normals they are estimated (CliRefine.EstimatesMissingNormals); not through points
        // on one line, and not from some of nx ny nz alone.
        {"no normals, points on a line",
         "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n",
         "no normal can be estimated"},
        {"no normals, extent too large",
         "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n1e30 0 0\n0 1e30 0\n1e30 1e30 1e30\n",
         "too large to estimate normals"},
        {"nx without ny nz",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n",
         "no 'ny' (or 'normal_y') property"},
        {"NaN coordinate", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\nnan 1 0 0 0 1\n1 1 0 0 0 1\n"},
        {"infinite coordinate", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 inf 0 0 0 1\n1 1 0 0 0 1\n"},
        {"zero normal", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 0\n0 1 0 0 0 1\n1 1 0 0 0 1\n"},
        {"empty set", headerAscii(0)},
        {"single point", headerAscii(1) + "0 0 0 0 0 1\n"},
        {"two points", headerAscii(2) + "0 0 0 0 0 1\n1 0 0 0 0 1\n"},
        {"three coincident points",
         headerAscii(3) + "0.5 0.5 0.5 0 0 1\n0.5 0.5 0.5 0 0 1\n0.5 0.5 0.5 0 0 1\n"},
        // Squared distances overflow (1e60) or underflow (1e-60) in single precision: no radius.
        {"points too far apart",
         headerAscii(4) + "0 0 0 0 0 1\n1e30 0 0 0 0 1\n0 1e30 0 0 0 1\n1e30 1e30 0 0 0 1\n",
         "lies 1e+30 from its nearest point, too far to measure its radius"},
        {"points too close together",
         headerAscii(4) + "0 0 0 0 0 1\n1e-30 0 0 0 0 1\n0 1e-30 0 0 0 1\n1e-30 1e-30 0 0 0 1\n",
         "lies 1e-30 from its nearest point, too close to measure its radius"},
        {"negative radius",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty float radius\nend_header\n"
         "0 0 0 0 0 1 0.5\n1 0 0 0 0 1 -0.5\n0 1 0 0 0 1 0.5\n"},
    };
    for (const BadInput& c : cases) {
        SCOPED_TRACE(c.name);
        const fs::path in = dir / "in.ply", out = dir / "out.ply";
        if (!c.content.empty()) writeText(in, c.content);
        const std::set<std::string> before = dir.entries();
        const RunResult r = run("refine " + quote(in) + " -l 1 -o " + quote(out));
        std::cout << "[refine, " << c.name << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r));
        EXPECT_FALSE(fs::exists(out));
        EXPECT_EQ(dir.entries(), before) << "files left behind";
        EXPECT_NE(r.err.find(in.string()), std::string::npos) << "the message names the file: " << r.err;
        EXPECT_NE(r.err.find(c.says), std::string::npos)
            << "the message says \"" << c.says << "\": " << r.err;
        fs::remove(in);
    }
}

TEST(CliBadInput, OutputInMissingFolderFailsAndLeavesNothing) {
    const TempDir dir;
    const fs::path out = dir / "no" / "such" / "folder" / "out.ply";
    const std::set<std::string> before = dir.entries();
    const RunResult r = run("refine -l 1 -o " + quote(out));
    std::cout << "[refine, output in a missing folder] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(dir / "no"));
    EXPECT_EQ(dir.entries(), before);
}

TEST(CliBadInput, EvalRejectsBadReferencesAndInputs) {
    const TempDir dir;
    const fs::path refined = dir / "refined.ply", report = dir / "report.json";
    ASSERT_TRUE(writePly(refined, sampleSphereUniform(600, 1.0f)).ok());
    // A malformed spec is a usage error; a mesh file that is not there, a failure.
    const std::vector<std::pair<std::string, Exit>> references = {
        {"sphere:abc", Exit::Usage},
        {"sphere:-1", Exit::Usage},
        {"sphere:", Exit::Usage},
        {"torus:1", Exit::Usage},
        {"torus:0.5,1", Exit::Usage},
        {"cube:2", Exit::Usage},
        {(dir / "missing-mesh.ply").string(), Exit::Failure}};
    for (const auto& [ref, status] : references) {
        SCOPED_TRACE(ref);
        const RunResult r =
            run("eval " + quote(refined) + " --reference " + quote(ref) + " -o " + quote(report));
        std::cout << "[eval --reference " << ref << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r, status));
        EXPECT_FALSE(fs::exists(report));
        EXPECT_EQ(r.out, "");
    }
    // A missing refined file and a missing --input.
    const RunResult noRefined =
        run("eval " + quote(dir / "missing.ply") + " --reference sphere:1 -o " + quote(report));
    std::cout << "[eval missing.ply] exit " << noRefined.exitCode << ": " << noRefined.err;
    EXPECT_TRUE(failsCleanly(noRefined));
    const RunResult noInput = run("eval " + quote(refined) + " --reference sphere:1 --input " +
                                  quote(dir / "missing-input.ply") + " -o " + quote(report));
    std::cout << "[eval --input missing-input.ply] exit " << noInput.exitCode << ": " << noInput.err;
    EXPECT_TRUE(failsCleanly(noInput));
    EXPECT_FALSE(fs::exists(report));
}

// ---------------------------------------------------------------------------------------------

TEST(CliEval, SphereRefinementPreservesInputAndIsAccurate) {
    const TempDir dir;
    const fs::path in = dir / "sphere-600.ply", out = dir / "refined.ply", other = dir / "sphere-601.ply",
                   report = dir / "report.json";
    ASSERT_TRUE(writePly(in, sampleSphereUniform(600, 1.0f)).ok());
    ASSERT_TRUE(writePly(other, sampleSphereUniform(601, 1.0f)).ok());
    const RunResult refine = run("refine " + quote(in) + " -l 3 -o " + quote(out));
    ASSERT_TRUE(refine.exited && refine.exitCode == 0) << refine.err;

    const RunResult eval = run("eval " + quote(out) + " --reference sphere:1 --input " + quote(in));
    ASSERT_TRUE(eval.exited && eval.exitCode == 0) << eval.err;
    std::cout << "[eval, sphere 600 refined 3 levels] " << eval.out;
    EXPECT_EQ(eval.err, ""); // a set on its surface gets no note
    EXPECT_NE(eval.out.find("\"input_preserved\": true"), std::string::npos) << eval.out;
    EXPECT_NE(eval.out.find("\"input_missing\": 0"), std::string::npos) << eval.out;
    EXPECT_NE(eval.out.find("\"input_points\": 600"), std::string::npos) << eval.out;
    EXPECT_NE(eval.out.find("\"holes\": 0,"), std::string::npos) << eval.out;
    EXPECT_EQ(eval.out.front(), '{');
    EXPECT_EQ(eval.out.substr(eval.out.size() - 2), "}\n");

    // The same report to a file.
    const RunResult toFile =
        run("eval " + quote(out) + " --reference sphere:1 --input " + quote(in) + " -o " + quote(report));
    ASSERT_TRUE(toFile.exited && toFile.exitCode == 0) << toFile.err;
    EXPECT_EQ(toFile.out, "");
    EXPECT_EQ(readText(report), eval.out);

    // The refinement written as text (x y z nx ny nz ...) reports the same: bit-exact round trips.
    const fs::path text = dir / "refined.xyz";
    const RunResult asText = run("refine " + quote(in) + " -l 3 -o " + quote(text));
    ASSERT_TRUE(asText.exited && asText.exitCode == 0) << asText.err;
    const RunResult evalText = run("eval " + quote(text) + " --reference sphere:1 --input " + quote(in));
    ASSERT_TRUE(evalText.exited && evalText.exitCode == 0) << evalText.err;
    EXPECT_EQ(evalText.out, eval.out);

    // Oracle for the check itself: another sampling is not preserved.
    const RunResult wrong = run("eval " + quote(out) + " --reference sphere:1 --input " + quote(other));
    ASSERT_TRUE(wrong.exited && wrong.exitCode == 0) << wrong.err;
    EXPECT_NE(wrong.out.find("\"input_preserved\": false"), std::string::npos) << wrong.out;

    // A set in other units (millimetres against metres): the report, and a note naming the cause.
    PointSet millimetres = sampleSphereUniform(600, 1.0f);
    for (glm::vec3& x : millimetres.position) x *= 1000.0f;
    const fs::path scaled = dir / "sphere-mm.ply";
    ASSERT_TRUE(writePly(scaled, millimetres).ok());
    const RunResult units = run("eval " + quote(scaled) + " --reference sphere:1");
    ASSERT_TRUE(units.exited && units.exitCode == 0) << units.err;
    ASSERT_FALSE(units.out.empty());
    EXPECT_EQ(units.out.front(), '{');
    EXPECT_NE(
        units.err.find(": its points lie on average 288.4 times the reference's diagonal (3.464) from the "
                       "reference's surface, and their own box's diagonal is 3458: are the two in the same "
                       "units and place?"),
        std::string::npos)
        << units.err;
    // And the other way: a sphere in metres against one in millimetres, on its surface, a box a thousandth
    // the size.
    const RunResult metres = run("eval " + quote(in) + " --reference " + quote(scaled));
    ASSERT_TRUE(metres.exited && metres.exitCode == 0) << metres.err;
    EXPECT_NE(metres.err.find("are the two in the same units and place?"), std::string::npos) << metres.err;
}

// --hole-map: the refined points in grey, then the reference samples counted as holes (here the
// removed cap, gaps: red), as discs of the hole distance. A map that cannot be written fails the
// command before any report is written.
TEST(CliEval, HoleMapMarksTheRemovedCap) {
    const TempDir dir;
    const fs::path holed = dir / "holed.ply", map = dir / "map.ply", report = dir / "report.json";
    PointSet sphere = sampleSphereUniform(20000, 1.0f);
    estimateRadii(sphere, 2);
    PointSet withoutCap;
    for (std::size_t i = 0; i < sphere.size(); ++i)
        if (sphere.position[i].z <= 0.8f) withoutCap.appendFrom(sphere, i);
    ASSERT_TRUE(writePly(holed, withoutCap).ok());
    const RunResult r = run("eval " + quote(holed) + " --reference sphere:1 --hole-map " + quote(map));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    auto read = readPly(map);
    ASSERT_TRUE(read.ok()) << read.error().message;
    const PointSet& m = read->points;
    ASSERT_TRUE(m.hasColour() && m.hasRadius());
    ASSERT_GT(m.size(), withoutCap.size() + 14000); // about 9 % of 200,000 samples
    std::cout << "[eval --hole-map, sphere without its cap] " << m.size() - withoutCap.size()
              << " holes marked\n";
    for (std::size_t i = 0; i < withoutCap.size(); ++i) {
        ASSERT_EQ(m.position[i], withoutCap.position[i]);
        ASSERT_EQ(m.colour[i], glm::u8vec3(200, 200, 200));
    }
    std::size_t gaps = 0;
    for (std::size_t i = withoutCap.size(); i < m.size(); ++i) {
        ASSERT_GT(m.position[i].z, 0.8f) << i;
        ASSERT_EQ(m.radius[i], m.radius.back());
        gaps += m.colour[i] == glm::u8vec3(255, 0, 0);
    }
    EXPECT_GT(gaps, (m.size() - withoutCap.size()) * 9 / 10); // the rest off-surface, along the rim
    EXPECT_GT(m.radius.back(), 0.0f);

    const RunResult unwritable = run("eval " + quote(holed) + " --reference sphere:1 -o " + quote(report) +
                                     " --hole-map " + quote(dir / "missing" / "map.ply"));
    std::cout << "[eval --hole-map missing/map.ply] exit " << unwritable.exitCode << ": " << unwritable.err;
    EXPECT_TRUE(failsCleanly(unwritable));
    EXPECT_FALSE(fs::exists(report));
}

// The refinement benchmark on a tiny case: every configuration, the phase split and the speed-up.
TEST(CliBench, RefineWritesEveryConfiguration) {
    const TempDir dir;
    const fs::path out = dir / "bench.json";
    const RunResult r =
        run("bench refine --sphere-points 200 --target-points 4000 --repeat 1 -o " + quote(out));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::string json = readText(out);
    for (const char* key :
         {"\"benchmark\": \"refine\"", "\"two_thread_speedup\": {\"full\": ", "\"name\": \"full\"",
          "\"name\": \"fast (all variants)\"", "\"name\": \"variant 1 euclidean geodesic\"",
          "\"name\": \"variant 2 plain angle\"", "\"name\": \"variant 3 fuzzy neighbourhood\"",
          "\"name\": \"variant 4 centroid candidates\"",
          "\"phase_share\": {\"neighbourhood\": ", "\"page_faults_median\": ",
          "\"full_one_thread_by_processor\": {\"0\": ", "\"two_thread_ideal_speedup\": "})
        EXPECT_NE(json.find(key), std::string::npos) << key << " missing from " << json;
    std::size_t runs = 0;
    for (std::size_t at = json.find("\"points_per_second_median\""); at != std::string::npos;
         at = json.find("\"points_per_second_median\"", at + 1))
        ++runs;
    EXPECT_EQ(runs, 8u); // six configurations on one thread, two on two
}

// The numbers of the object {"1": 12, "2": 34} that is the value of the first `key` in `json`, by
// their keys (empty when `key` is absent).
std::map<std::string, double> numbersOf(const std::string& json, const std::string& key) {
    std::map<std::string, double> values;
    const std::string opening = "\"" + key + "\": {";
    const std::size_t at = json.find(opening);
    if (at == std::string::npos) return values;
    const std::size_t end = json.find('}', at);
    for (std::size_t name = json.find('"', at + opening.size()); name < end; name = json.find('"', name)) {
        const std::size_t nameEnd = json.find('"', name + 1);
        values[json.substr(name + 1, nameEnd - name - 1)] = std::stod(json.substr(nameEnd + 2));
        name = nameEnd + 1;
    }
    return values;
}

// bench refine --input: per level, points/s at each thread count, candidates scanned and the
// neighbourhood per refined point (the counters of LevelStats), the phase split. No wall time is
// asserted on, only that rates are positive.
TEST(CliBench, RefineInputReportsEveryLevelAndThreadCount) {
    const TempDir dir;
    const fs::path in = dir / "torus.ply", out = dir / "bench.json";
    PointSet torus = sampleTorusUniform(400, 1.0f, 0.4f);
    torus.radius.clear(); // estimated on reading, as `refine` does
    ASSERT_TRUE(writePly(in, torus).ok());
    const RunResult r = run("bench refine --input " + quote(in) + " --levels 2 --repeat 1 -o " + quote(out));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::string json = readText(out);
    EXPECT_NE(json.find("\"threads\": [1, 2]"), std::string::npos) << json;
    EXPECT_EQ(jsonField(json, "name"), "torus") << json;
    EXPECT_EQ(jsonField(json, "points_in"), "400") << json;
    std::vector<std::size_t> levels;
    for (std::size_t at = json.find("{\"level\": "); at != std::string::npos;
         at = json.find("{\"level\": ", at + 1))
        levels.push_back(at);
    ASSERT_EQ(levels.size(), 2u) << json;
    for (std::size_t l = 0; l < levels.size(); ++l) {
        SCOPED_TRACE(l + 1);
        const std::string level = json.substr(levels[l], json.find("}}", levels[l]) + 2 - levels[l]);
        EXPECT_EQ(jsonField(level, "level"), std::to_string(l + 1));
        EXPECT_GT(std::stod(jsonField(level, "inserted")), 0.0) << level;
        const double scanned = std::stod(jsonField(level, "scanned_per_point"));
        const double neighbourhood = std::stod(jsonField(level, "neighbourhood_per_point"));
        EXPECT_GT(neighbourhood, 0.0) << level;
        EXPECT_GE(scanned, neighbourhood) << level;
        const std::map<std::string, double> rates = numbersOf(level, "points_per_second");
        ASSERT_EQ(rates.size(), 2u) << level;
        EXPECT_GT(rates.at("1"), 0.0) << level;
        EXPECT_GT(rates.at("2"), 0.0) << level;
        const std::map<std::string, double> shares = numbersOf(level, "phase_share");
        EXPECT_EQ(shares.size(), 4u) << level;
        double sum = 0.0;
        for (const auto& [phase, share] : shares) sum += share;
        EXPECT_NEAR(sum, 1.0, 0.01) << level;
    }
}

// A missing --input file is one line and a failure, and so is a run larger than --max-points; the
// options of the inputs without inputs and a target the input reaches already are usage errors; the
// default models missing beside the working directory are skipped, each named.
TEST(CliBench, RefineInputErrorsAndMissingModels) {
    const TempDir dir;
    RunResult r = run("bench refine --input " + quote(dir / "missing.ply") + " --repeat 1");
    std::cout << "[bench refine --input missing.ply] exit " << r.exitCode << ": " << r.err;
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_NE(r.err.find("missing.ply"), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
    r = run("bench refine --levels 2 --repeat 1");
    EXPECT_TRUE(failsCleanly(r, Exit::Usage));
    const fs::path sphere = dir / "sphere.ply";
    ASSERT_TRUE(writePly(sphere, sampleSphereUniform(200, 1.0f)).ok());
    r = run("bench refine --input " + quote(sphere) + " --levels 3 --max-points 1000 --repeat 1");
    EXPECT_TRUE(failsCleanly(r)) << "a run larger than --max-points";
    EXPECT_NE(r.err.find("--max-points 1000"), std::string::npos) << r.err;
    r = run("bench refine --input " + quote(sphere) + " --target-points 200 --repeat 1");
    EXPECT_TRUE(failsCleanly(r, Exit::Usage)) << "a target the input reaches";
    // With a target and no --levels, levels go on past the default 4 until it is reached (200 points
    // reach about 16,000 in 4 levels).
    r = run("bench refine --input " + quote(sphere) + " --target-points 20000 --threads 1 --repeat 1");
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("\"levels\": 16, \"target_points\": 20000"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("{\"level\": 5,"), std::string::npos) << "stopped before the target: " << r.out;
    // From a folder of the temporary directory, whose ../shared is the directory's own (absent)
    // rather than one beside the temporary directory's parent.
    const fs::path work = dir / "work";
    fs::create_directories(work);
    r = runShell("cd " + quote(work) + " && " + program() +
                 " bench refine --models default --sphere-points 100 --levels 1 --threads 1 --repeat 1");
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("\"name\": \"sphere-100-uniform\""), std::string::npos) << r.out;
    for (const char* model : {"bunny-3500-random", "fandisk-1500-uniform"}) {
        EXPECT_NE(r.err.find(fmt::format("../shared/data/{}.ply not found", model)), std::string::npos)
            << r.err;
        EXPECT_EQ(r.out.find(model), std::string::npos) << r.out;
    }
}

TEST(CliRender, RendersComparesAndFailsPastTheThreshold) {
    const TempDir dir;
    const fs::path a = dir / "a.png", b = dir / "b.png", heat = dir / "heat.png";
    RunResult r = run("render --width 64 --height 48 --validation -o " + quote(a));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    r = run("render --width 64 --height 48 --validation --orbit 90 --path graphics -o " + quote(b));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    r = run("diff " + quote(a) + " " + quote(a));
    EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("\"psnr\": null"), std::string::npos) << r.out;
    r = run("diff " + quote(a) + " " + quote(b) + " --max-rmse 0.5 --heatmap " + quote(heat));
    EXPECT_TRUE(failsCleanly(r, Exit::Differs)) << r.out;
    EXPECT_NE(r.err.find("RMSE"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(heat));
}

TEST(CliBadInput, RenderAndDiffFailWithOneLineAndNoOutput) {
    const TempDir dir;
    const fs::path in = dir / "in.ply", out = dir / "out.png";
    struct Case {
        std::string name, content, args;
        std::string says = ""; // a phrase the message must contain, when not empty
        Exit status = Exit::Failure;
    };
    const std::vector<Case> cases = {
        {"missing file", "", ""},
        {"NaN coordinate", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\nnan 1 0 0 0 1\n1 1 0 0 0 1\n", ""},
        {"empty set", headerAscii(0), ""},
        {"truncated", headerAscii(4) + "0 0 0 0 0 1\n1 0", ""},
        {"zero-sized image", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n", "--width 0",
         "--width", Exit::Usage},
        {"eye on the target", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n",
         "--camera 1,1,1,1,1,1,0,1,0", "eye is on the target", Exit::Usage},
        {"up along the line of sight", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n",
         "--camera 0,0,5,0,0,0,0,0,1", "--camera", Exit::Usage},
        {"unknown up axis", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n", "--up w", "--up",
         Exit::Usage},
        {"--camera with --frame", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n",
         "--camera 0,0,5,0,0,0,0,1,0 --frame x.ply", "excludes", Exit::Usage},
        {"missing --frame file", headerAscii(3) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n",
         "--frame missing-frame.ply", "missing-frame.ply"},
        {"extent too large to measure", // with radii: the estimate would fail first
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty float radius\nend_header\n"
         "-3e38 0 0 0 0 1 1\n3e38 0 0 0 0 1 1\n0 3e38 0 0 0 1 1\n",
         "", "bounding sphere overflows"},
        {"coincident points", headerAscii(3) + "1 2 3 0 0 1\n1 2 3 0 0 1\n1 2 3 0 0 1\n", "",
         "1 distinct position"},
        {"three numbers for a hole", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0 0 0 1\n",
         "--fill-hole 1,2,3", "expected X,Y,Z,R", Exit::Usage},
        {"a radius zero as a float", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0 0 0 1\n",
         "--fill-hole 1,2,3,1e-50", "expected X,Y,Z,R", Exit::Usage},
        {"a centre beyond floats", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0 0 0 1\n",
         "--fill-hole 1e39,2,3,1", "expected X,Y,Z,R", Exit::Usage},
        {"a point inside the hole", headerAscii(4) + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 0 0 0 1\n",
         "--fill-hole 0.1,0,0,0.5", "lies inside hole 1"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        if (!c.content.empty()) writeText(in, c.content);
        const RunResult r = run("render " + quote(in) + " " + c.args + " -o " + quote(out));
        std::cout << "[render, " << c.name << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r, c.status));
        EXPECT_NE(r.err.find(c.says), std::string::npos)
            << "the message says \"" << c.says << "\": " << r.err;
        EXPECT_FALSE(fs::exists(out));
        fs::remove(in);
    }
    // A missing image is a failure (3), not "the images differ" (1).
    const RunResult r = run("diff " + quote(dir / "none.png") + " " + quote(dir / "none.png"));
    EXPECT_TRUE(failsCleanly(r));
    EXPECT_NE(r.err.find("none.png"), std::string::npos) << r.err;
}

// ---------------------------------------------------------------------------------------------
// Exit statuses (issue 20): 0 success, 1 `diff` differs, 2 usage errors, 3 failures; documented in
// --help. A mistyped command is named with the nearest one.

TEST(CliExit, UsageErrorsExitWithTwoAndSuggestTheCommand) {
    const RunResult help = run("--help");
    ASSERT_TRUE(help.exited && help.exitCode == 0);
    EXPECT_NE(help.out.find("Exit status: 0 success; 1 `diff` found the images differ"), std::string::npos)
        << help.out;
    EXPECT_NE(help.out.find("2 usage error"), std::string::npos) << help.out;
    EXPECT_NE(help.out.find("3 failure"), std::string::npos) << help.out;
    struct Case {
        std::string args, says;
    };
    const std::vector<Case> cases = {
        {"rendr", "'rendr' is not a pnsplat command; did you mean 'render'?"},
        {"refien -l 2", "did you mean 'refine'?"},
        {"bench rendr", "'rendr' is not a pnsplat bench command; did you mean 'render'?"},
        {"xyz", "(commands: refine, eval, render, view, diff, bench)"},
        {"", "subcommand is required"},
        {"render --bogus", "--bogus"},
        {"diff only-one.png", "B.png is required"},
        {"render --up w", "--up"},
        {"refine --levels 0", "--levels"},
        {"refine in.ply --levle 3", "'--levle' is not an option of pnsplat refine; did you mean '--levels'?"},
        {"bench view --camera-pth orbit",
         "'--camera-pth' is not an option of pnsplat bench view; did you mean '--camera-path'?"},
        {"render --threshold=2 --widht 640", "did you mean '--width'?"},
        {"bench settle -o x.json", "'-o' is not an option of pnsplat bench settle"},
        {"render --frobnicate", "'--frobnicate' is not an option of pnsplat render"},
        {"render --orbit -30 -q", "'-q' is not an option of pnsplat render"},
    };
    for (const Case& c : cases) {
        const RunResult r = run(c.args);
        std::cout << "[" << c.args << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r, Exit::Usage)) << c.args;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << ": " << r.err;
        EXPECT_EQ(r.out, "") << c.args;
    }
}

// --target-points at or below the input's size would refine nothing: a usage error, no output.
TEST(CliRefine, TargetPointsNotAboveTheInputIsAUsageError) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    for (const std::string& target : {std::to_string(kDefaultModelPoints), std::string("500")}) {
        const RunResult r = run("refine --target-points " + target + " -o " + quote(out));
        std::cout << "[refine --target-points " << target << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r, Exit::Usage));
        EXPECT_NE(r.err.find(fmt::format("the default model has {} points", kDefaultModelPoints)),
                  std::string::npos)
            << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
    const RunResult above =
        run(fmt::format("refine --target-points {} -o {}", kDefaultModelPoints + 1, quote(out)));
    EXPECT_TRUE(above.exited && above.exitCode == 0) << above.err;
}

// --json: the summary as one JSON line on stdout, its counts those of the file written.
TEST(CliRefine, JsonSummaryIsOneLine) {
    const TempDir dir;
    const fs::path out = dir / "out.ply";
    const RunResult r = run("refine -l 1 --json -o " + quote(out));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    std::cout << "[refine -l 1 --json] " << r.out;
    ASSERT_EQ(lines(r.out).size(), 1u) << r.out;
    EXPECT_EQ(r.out.front(), '{');
    EXPECT_EQ(r.out.substr(r.out.size() - 2), "}\n");
    const auto data = readPly(out);
    ASSERT_TRUE(data.ok());
    EXPECT_EQ(jsonField(r.out, "points_out"), std::to_string(data->points.size()));
    EXPECT_EQ(jsonField(r.out, "points_in"), std::to_string(kDefaultModelPoints));
    EXPECT_EQ(jsonField(r.out, "levels"), "1");
    EXPECT_EQ(jsonField(r.out, "input"), "null");
    EXPECT_EQ(jsonField(r.out, "output"), out.string());
    for (const char* key : {"distinct_in", "evening_out_levels", "hole_filling_levels", "holes", "rim_points",
                            "refine_seconds", "seconds", "points_per_second", "capped_neighbourhoods"})
        EXPECT_NE(jsonField(r.out, key), "") << key << " missing from " << r.out;
}

// Acceptance 5 of issue 20: `render --frame` gives a sparse file and its refinement the same camera,
// printed (as a --camera value, in the JSON summary and in the prose one) and asserted; the sparse
// file framed by itself is the default; the printed value gives the same picture again.
TEST(CliRender, FrameGivesASparseFileAndItsRefinementTheSameCamera) {
    const TempDir dir;
    const fs::path sparse = dir / "sparse.ply", refined = dir / "refined.ply";
    // A tall, bent body, positions only (normals and radii estimated, as for a scan).
    std::ostringstream text;
    text
        << "ply\nformat ascii 1.0\nelement vertex 800\nproperty float x\nproperty float y\nproperty float z\n"
        << "end_header\n"
        << std::setprecision(9);
    for (const glm::vec3& p : sampleSphereUniform(800, 1.0f).position)
        text << 0.6f * p.x << " " << 2.0f * p.y + 0.3f * p.x * p.x << " " << 1.2f * p.z << "\n";
    writeText(sparse, text.str());
    RunResult r = run("refine " + quote(sparse) + " -l 2 -o " + quote(refined));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const auto render = [&](const std::string& args, const fs::path& png) {
        const RunResult result = run("render " + args + " --width 96 --height 64 --json -o " + quote(png));
        EXPECT_TRUE(result.exited && result.exitCode == 0) << args << ": " << result.err;
        EXPECT_EQ(lines(result.out).size(), 1u) << result.out;
        std::cout << "[render " << args << "] " << result.out;
        return result.out;
    };
    const std::string own = render(quote(sparse), dir / "own.png");
    const std::string sparseFramed = render(quote(sparse) + " --frame " + quote(sparse), dir / "sparse.png");
    const std::string refinedFramed =
        render(quote(refined) + " --frame " + quote(sparse), dir / "refined.png");
    const std::string refinedOwn = render(quote(refined), dir / "refined-own.png");
    const std::string camera = jsonField(sparseFramed, "camera");
    ASSERT_EQ(std::count(camera.begin(), camera.end(), ','), 8) << sparseFramed;
    EXPECT_EQ(jsonField(refinedFramed, "camera"), camera);
    EXPECT_EQ(jsonField(own, "camera"), camera);
    EXPECT_EQ(jsonField(refinedFramed, "frame"), sparse.string());
    EXPECT_EQ(jsonField(own, "frame"), "null");
    EXPECT_EQ(jsonField(refinedFramed, "up"), "+y");
    EXPECT_EQ(jsonField(refinedFramed, "eye_side"), "+x"); // x is the thinnest: its broad side
    EXPECT_NE(jsonField(refinedFramed, "splats"), jsonField(sparseFramed, "splats"));
    EXPECT_NE(jsonField(refinedOwn, "camera"), camera); // framed by its own bounds, as before --frame

    // The printed value is a ready --camera: the same picture, bit for bit.
    render(quote(refined) + " --camera " + camera, dir / "again.png");
    r = run("diff " + quote(dir / "refined.png") + " " + quote(dir / "again.png"));
    EXPECT_TRUE(r.exited && r.exitCode == 0) << r.err;
    EXPECT_NE(r.out.find("\"psnr\": null"), std::string::npos) << r.out;

    // Without --json: the summary, then the camera line.
    r = run("render " + quote(refined) + " --frame " + quote(sparse) + " --width 96 --height 64 -o " +
            quote(dir / "prose.png"));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    ASSERT_EQ(lines(r.out).size(), 2u) << r.out;
    EXPECT_EQ(lines(r.out)[1].rfind("camera: --camera " + camera + " (up +y", 0), 0u) << r.out;
}

// render --compare (issue 26): one picture of three panels from one camera — the input as points,
// as splats, and refined for that camera — over a caption strip; the panels differ, and the
// refined one is at least 6 dB closer (PSNR) than the splats to the render of the default model's
// dense version from the same camera, measured here on the panels and the reference written out.
TEST(CliRender, CompareShowsThreePanelsAndTheRefinementIsCloserToTheDenseRender) {
    const TempDir dir;
    const fs::path picture = dir / "compare.png", reference = dir / "reference.png";
    constexpr std::uint32_t kWidth = 320, kHeight = 270;
    const RunResult r =
        run(fmt::format("render --compare --width {} --height {} --json -o {} --reference-png {}", kWidth,
                        kHeight, quote(picture), quote(reference)));
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    ASSERT_EQ(lines(r.out).size(), 1u) << r.out;
    std::cout << "[render --compare] " << r.out;
    const auto image = engine::readPng(picture);
    const auto truth = engine::readPng(reference);
    ASSERT_TRUE(image.ok() && truth.ok());
    // Three panels side by side over a strip of captions (18 px under panels this narrow).
    EXPECT_EQ(image->width, 3 * kWidth);
    EXPECT_EQ(image->height, kHeight + 18);
    EXPECT_EQ(truth->width, kWidth);
    EXPECT_EQ(truth->height, kHeight);
    engine::RgbaImage panels[3];
    for (std::uint32_t k = 0; k < 3; ++k) {
        panels[k] = engine::RgbaImage(kWidth, kHeight);
        for (std::uint32_t y = 0; y < kHeight; ++y)
            std::copy_n(&image->pixels[(std::size_t{y} * image->width + k * kWidth) * 4], kWidth * 4,
                        &panels[k].pixels[std::size_t{y} * kWidth * 4]);
    }
    const auto difference = [](const engine::RgbaImage& a, const engine::RgbaImage& b) {
        auto d = engine::compareImages(a, b);
        EXPECT_TRUE(d.ok());
        return d ? *d : engine::ImageDifference{};
    };
    // Every panel shows something else: dots, the splats' blobs, the refined surface.
    EXPECT_GT(difference(panels[0], panels[1]).differingShare, 0.05);
    EXPECT_GT(difference(panels[1], panels[2]).differingShare, 0.05);
    EXPECT_GT(difference(panels[0], panels[2]).differingShare, 0.05);
    const engine::ImageDifference splats = difference(panels[1], *truth);
    const engine::ImageDifference refined = difference(panels[2], *truth);
    std::cout << "[render --compare] PSNR against the dense render: splats " << splats.psnr << " dB, refined "
              << refined.psnr << " dB\n";
    EXPECT_GT(refined.psnr, splats.psnr + 6.0);
    EXPECT_GT(refined.ssim, splats.ssim);
    // What the program prints is what the pictures say.
    EXPECT_NEAR(std::stod(jsonField(r.out, "psnr_splats")), splats.psnr, 0.01) << r.out;
    EXPECT_NEAR(std::stod(jsonField(r.out, "psnr_refined")), refined.psnr, 0.01) << r.out;
    EXPECT_EQ(jsonField(r.out, "reference"), "default-model-dense");
    EXPECT_EQ(jsonField(r.out, "panel_width"), std::to_string(kWidth));

    // Without a reference (a file input): the panels, no PSNR; --compare with --adaptive is a usage error.
    const fs::path sphere = dir / "sphere.ply", plain = dir / "plain.png";
    ASSERT_TRUE(writePly(sphere, sampleSphereUniform(400, 1.0f)).ok());
    const RunResult f =
        run("render " + quote(sphere) + " --compare --width 96 --height 64 --json -o " + quote(plain));
    ASSERT_TRUE(f.exited && f.exitCode == 0) << f.err;
    EXPECT_EQ(jsonField(f.out, "psnr_splats"), "null") << f.out;
    const auto plainImage = engine::readPng(plain);
    ASSERT_TRUE(plainImage.ok());
    EXPECT_EQ(plainImage->width, 3u * 96u);
    EXPECT_TRUE(failsCleanly(run("render --compare --adaptive -o " + quote(dir / "no.png")), Exit::Usage));
    EXPECT_FALSE(fs::exists(dir / "no.png"));
}

// A camera inside the model or looking away from it gives a picture (the background), not an error.
TEST(CliRender, CameraInsideOrLookingAwayRenders) {
    const TempDir dir;
    for (const std::string camera : {"0,0,0,0,0,-1,0,1,0", "0,0,5,0,0,10,0,1,0"}) {
        const fs::path out = dir / "out.png";
        const RunResult r =
            run("render --width 32 --height 32 --validation --camera " + camera + " -o " + quote(out));
        EXPECT_TRUE(r.exited && r.exitCode == 0) << camera << ": " << r.err;
        EXPECT_TRUE(fs::exists(out));
    }
}

// The real-time engine from the command line: bench view prints one JSON line per frame and a
// summary, captures frames, measures the splats drawn when asked, and refuses bad input in one line
// (acceptance 7 of the real-time issue).
TEST(CliBenchView, PrintsFramesAndASummaryAndCaptures) {
    const TempDir dir;
    const RunResult r =
        run("bench view --frames 4 --width 48 --height 36 --lockstep --validation --threads 1 "
            "--measure-splats --capture " +
            quote(dir / "frames") + kFewWholeLevels);
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::vector<std::string> out = lines(r.out);
    ASSERT_EQ(out.size(), 5u) << r.out;
    for (std::size_t k = 0; k < 4; ++k) {
        for (const char* field :
             {"\"frame_ms\"", "\"visibility_ms\"", "\"splats_drawn\"", "\"nodes_visible\"",
              "\"nodes_refined\"", "\"points_generated\"", "\"cache_bytes_used\"", "\"evictions\"",
              "\"queue_length\"", "\"refine_busy_ms\"", "\"refine_cpu_ms\"", "\"max_splat_px\""})
            EXPECT_NE(out[k].find(field), std::string::npos) << field << " in " << out[k];
        EXPECT_NE(out[k].find("\"settled\": true"), std::string::npos) << out[k]; // lockstep
        EXPECT_NE(jsonField(out[k], "max_splat_px"), "null") << out[k];
        EXPECT_GT(std::stod(jsonField(out[k], "max_splat_px")), 0.0) << out[k];
        // From the frame's start to the next one's, though each frame is done (captured) first.
        EXPECT_GT(std::stod(jsonField(out[k], "frame_ms")), 0.0) << out[k];
        EXPECT_TRUE(fs::exists(dir / "frames" / fmt::format("frame-{:05}.png", k)));
    }
    EXPECT_NE(out[4].find("\"summary\": true"), std::string::npos);
    EXPECT_NE(out[4].find("\"frame_ms_p95\""), std::string::npos);
    EXPECT_NE(out[4].find("\"uploads_per_second\""), std::string::npos);
    EXPECT_NE(out[4].find("\"points_per_second_while_queued\""), std::string::npos);
    EXPECT_NE(out[4].find("\"points_per_cpu_second\""), std::string::npos);
    EXPECT_NE(out[4].find("\"workers\": 1,"), std::string::npos) << out[4]; // --threads is --workers
}

// --hard-edges reaches the engine of bench view: the summary says which silhouette was drawn, and
// the frames differ (the default blends the outer silhouette's pixels toward the background). The
// summary says whether pinholes were filled too (--keep-pinholes).
TEST(CliBenchView, HardEdgesCoverTheSilhouetteWhole) {
    const TempDir dir;
    std::vector<engine::RgbaImage> frames;
    for (const bool hard : {false, true}) {
        const fs::path capture = dir / (hard ? "hard" : "smooth");
        const RunResult r =
            run("bench view --frames 1 --width 64 --height 48 --lockstep --validation --capture " +
                quote(capture) + (hard ? " --hard-edges" : "") + kFewWholeLevels);
        ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
        const std::vector<std::string> out = lines(r.out);
        ASSERT_EQ(out.size(), 2u) << r.out;
        EXPECT_EQ(jsonField(out[1], "smooth_edges"), hard ? "false" : "true") << out[1];
        EXPECT_EQ(jsonField(out[1], "fill_pinholes"), "true") << out[1];
        auto image = engine::readPng(capture / "frame-00000.png");
        ASSERT_TRUE(image.ok()) << image.error().message;
        frames.push_back(std::move(*image));
    }
    ASSERT_EQ(frames[0].pixels.size(), frames[1].pixels.size());
    EXPECT_NE(frames[0].pixels, frames[1].pixels);
    const RunResult kept =
        run("bench view --frames 1 --width 64 --height 48 --lockstep --validation --keep-pinholes" +
            kFewWholeLevels);
    ASSERT_TRUE(kept.exited && kept.exitCode == 0) << kept.err;
    const std::vector<std::string> out = lines(kept.out);
    ASSERT_EQ(out.size(), 2u) << kept.out;
    EXPECT_EQ(jsonField(out[1], "fill_pinholes"), "false") << out[1];
}

// Issue 26's quality figures: every frame counts the pixels it covers; --quality-every K compares
// every K-th frame with the lockstep settled picture of its camera, drawn after the run. In
// lockstep the first frame is that picture (no history yet): PSNR 99, identical; the later ones
// differ where hysteresis kept a node refined. Fails when the frames are not read back (no covered
// pixels) or the reference is not the settled picture. With -o, the file holds the same lines.
TEST(CliBenchView, QualityFramesAgainstTheSettledPicture) {
    const TempDir dir;
    const RunResult r =
        run("bench view --frames 7 --width 64 --height 48 --lockstep --validation --quality-every 3 -o " +
            quote(dir / "run.jsonl") + kFewWholeLevels);
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::vector<std::string> out = lines(r.out);
    ASSERT_EQ(out.size(), 7u + 3u + 1u) << r.out; // frames, quality frames 0, 3 and 6, summary
    EXPECT_EQ(readText(dir / "run.jsonl"), r.out);
    for (std::size_t k = 0; k < 7; ++k) {
        EXPECT_EQ(out[k].find("\"covered_px\": 0,"), std::string::npos) << out[k];
        EXPECT_NE(out[k].find("\"splats_per_covered_px\": "), std::string::npos) << out[k];
    }
    EXPECT_NE(out[7].find("{\"quality_frame\": 0, \"psnr\": 99.000, \"ssim\": 1.00000"), std::string::npos)
        << out[7];
    EXPECT_NE(out[8].find("{\"quality_frame\": 3, \"psnr\": "), std::string::npos) << out[8];
    EXPECT_NE(out[9].find("{\"quality_frame\": 6, \"psnr\": "), std::string::npos) << out[9];
    EXPECT_NE(out[10].find("\"quality_frames\": 3, \"psnr_median\": "), std::string::npos) << out[10];
    EXPECT_EQ(out[10].find("\"psnr_p5\": null"), std::string::npos) << out[10];
    // Every frame a quality frame: more pictures waiting than frames in flight, each read before its
    // slot is reused (engine.image of a reused slot is an error).
    const RunResult every =
        run("bench view --frames 5 --width 32 --height 24 --lockstep --validation --quality-every 1" +
            kFewWholeLevels);
    ASSERT_TRUE(every.exited && every.exitCode == 0) << every.err;
    const std::vector<std::string> everyOut = lines(every.out);
    ASSERT_EQ(everyOut.size(), 5u + 5u + 1u) << every.out;
    for (std::size_t k = 0; k < 5; ++k)
        EXPECT_NE(everyOut[5 + k].find(fmt::format("{{\"quality_frame\": {}, \"psnr\": ", k)),
                  std::string::npos)
            << everyOut[5 + k];
    // Without it: no quality figures; nor, without --measure-splats, the splats' sizes.
    const RunResult plain = run("bench view --frames 2 --width 32 --height 24" + kFewWholeLevels);
    ASSERT_TRUE(plain.exited && plain.exitCode == 0) << plain.err;
    EXPECT_NE(plain.out.find("\"quality_frames\": 0, \"psnr_median\": null"), std::string::npos) << plain.out;
    EXPECT_NE(plain.out.find("\"median_splat_px\": null, \"max_splat_px\": null, \"over_threshold\": null"),
              std::string::npos)
        << plain.out;
    EXPECT_NE(plain.out.find("\"max_splat_px_max\": null, \"over_threshold_max\": null"), std::string::npos)
        << plain.out;
}

// bench settle: per model and camera, the settled adaptive picture against the offline refinement
// (issue 26's lines 1 to 3 in one run): a torus at two cameras gives two records and a summary; the
// pictures match closely (they differ only in the levels drawn), so a reference drawn wrong (another
// camera, the wrong points) would fail the PSNR.
TEST(CliBenchSettle, ComparesTheSettledPictureWithTheOfflineRefinement) {
    const TempDir dir;
    const fs::path in = dir / "torus.ply";
    PointSet torus = sampleTorusUniform(400, 1.0f, 0.4f);
    torus.radius.clear();
    ASSERT_TRUE(writePly(in, torus).ok());
    const RunResult r =
        run("bench settle " + quote(in) + " --cameras framing,grazing --width 64 --height 48 --validation " +
            "--pictures " + quote(dir / "pictures") + kFewWholeLevels);
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    // The settled picture, the offline one at the deepest level drawn, their difference and the
    // offline one a level deeper, side by side over captions.
    for (const char* camera : {"framing", "grazing"}) {
        const auto picture = engine::readPng(dir / "pictures" / fmt::format("torus-{}.png", camera));
        ASSERT_TRUE(picture.ok()) << camera;
        EXPECT_EQ(picture->width, 4u * 64u) << camera;
        EXPECT_GT(picture->height, 48u) << camera;
    }
    const std::vector<std::string> out = lines(r.out);
    ASSERT_EQ(out.size(), 3u) << r.out;
    for (std::size_t k = 0; k < 2; ++k) {
        SCOPED_TRACE(out[k]);
        EXPECT_EQ(jsonField(out[k], "model"), "torus");
        EXPECT_EQ(jsonField(out[k], "camera"), k == 0 ? "framing" : "grazing");
        EXPECT_EQ(jsonField(out[k], "settled"), "true");
        EXPECT_EQ(jsonField(out[k], "smooth_edges"), "true");
        EXPECT_GT(std::stod(jsonField(out[k], "psnr")), 30.0);
        EXPECT_GT(std::stod(jsonField(out[k], "covered_px")), 100.0);
        EXPECT_GT(std::stod(jsonField(out[k], "drawn_per_covered_px")), 0.0);
        EXPECT_GE(std::stod(jsonField(out[k], "made_per_covered_px")),
                  std::stod(jsonField(out[k], "drawn_per_covered_px")));
        // A level deeper moves the silhouettes' pixels of so small a picture (27-37 dB); a blank
        // picture would be below 10.
        EXPECT_GT(std::stod(jsonField(out[k], "psnr_deeper")), 20.0);
        // The references: the offline refinement at the deepest level drawn and one deeper, of
        // the splats in view only.
        const std::string deepest = jsonField(out[k], "deepest_level");
        EXPECT_GE(std::stoi(deepest), 1);
        EXPECT_EQ(jsonField(out[k], "reference_levels"), deepest);
        EXPECT_EQ(std::stoi(jsonField(out[k], "deeper_levels")), std::stoi(deepest) + 1);
        EXPECT_EQ(jsonField(out[k], "deeper_capped"), "false");
        EXPECT_GT(std::stod(jsonField(out[k], "deeper_points_in_view")),
                  std::stod(jsonField(out[k], "reference_points_in_view")));
    }
    // A reference whose next level would pass --max-reference-points stops there, capped.
    const RunResult capped =
        run("bench settle " + quote(in) +
            " --cameras framing --width 64 --height 48 --max-reference-points 100" + kFewWholeLevels);
    ASSERT_TRUE(capped.exited && capped.exitCode == 0) << capped.err;
    const std::string line = lines(capped.out).at(0);
    EXPECT_EQ(jsonField(line, "deeper_capped"), "true") << line;
    EXPECT_LT(std::stoi(jsonField(line, "deeper_levels")), std::stoi(jsonField(line, "deepest_level")) + 1);
    // Past --max-refined-points the levels go on in a box about the picture (here the last: the
    // whole refinement stops at level 3 of 81,000 points): the same reference within 0.5 dB, not
    // capped (a last box cut by a fifth of its size on each side gave 14.3 dB against 41.2).
    const fs::path dense = dir / "dense-torus.ply";
    ASSERT_TRUE(writePly(dense, sampleTorusUniform(3000, 1.0f, 0.4f)).ok());
    const auto closeUp = [&](const std::string& more) {
        const RunResult settled =
            run("bench settle " + quote(dense) + " --cameras close-up --width 160 --height 120" + more +
                kFewWholeLevels);
        EXPECT_TRUE(settled.exited && settled.exitCode == 0) << settled.err;
        return lines(settled.out).at(0);
    };
    const std::string whole = closeUp(""), inBox = closeUp(" --max-refined-points 100000");
    EXPECT_EQ(jsonField(whole, "box_from_level"), "null") << whole;
    EXPECT_EQ(jsonField(inBox, "box_from_level"), "3") << inBox;
    EXPECT_EQ(jsonField(inBox, "deeper_levels"), "4") << inBox;
    EXPECT_EQ(jsonField(inBox, "deeper_levels"), jsonField(whole, "deeper_levels")) << whole;
    EXPECT_EQ(jsonField(inBox, "deeper_capped"), "false") << inBox;
    EXPECT_NEAR(std::stod(jsonField(inBox, "psnr_deeper")), std::stod(jsonField(whole, "psnr_deeper")), 0.5)
        << inBox << "\n"
        << whole;
    EXPECT_EQ(jsonField(out[2], "cases"), "2") << out[2];
    const RunResult wrong = run("bench settle " + quote(in) + " --cameras sideways");
    EXPECT_TRUE(failsCleanly(wrong, Exit::Usage)) << wrong.err;
    const RunResult missing = run("bench settle " + quote(dir / "missing.ply"));
    EXPECT_TRUE(failsCleanly(missing, Exit::Failure)) << missing.err;
}

TEST(CliBadInput, RealTimeEngineRefusesBadInputInOneLine) {
    const TempDir dir;
    writeText(dir / "path.txt", "0 0 0 3 0 0 0\n5 0 0 3 oops 0 0\n");
    writeText(dir / "empty.txt", "# nothing\n");
    writeText(dir / "backwards.txt", "5 0 0 3 0 0 0\n2 0 0 4 0 0 0\n");
    writeText(dir / "degenerate.txt", "0 0 0 0 0 0 0\n");
    struct Case {
        std::string args, says;
        Exit status = Exit::Failure;
    };
    const std::vector<Case> cases = {
        {"bench view --camera-path " + quote(dir / "path.txt"), "path.txt:2: 'oops' is not a number"},
        {"bench view --camera-path " + quote(dir / "empty.txt"), "has no keyframe"},
        {"bench view --camera-path " + quote(dir / "backwards.txt"), "above the previous one"},
        {"bench view --camera-path " + quote(dir / "degenerate.txt"), "not a camera"},
        {"bench view --camera-path " + quote(dir / "missing.txt"), "cannot open the camera path"},
        {"bench view --frames 0", "--frames", Exit::Usage},
        {"bench view --threshold 0", "--threshold", Exit::Usage},
        {"bench view --threshold -2", "--threshold", Exit::Usage},
        {"bench view --cache-mb 0.001 --frames 1", "cannot hold the input's"},
        {"bench view --frames 3 -o " + quote(dir / "no" / "x.jsonl"), "its folder does not exist"},
        {"render --adaptive --cache-mb 0.001 -o " + quote(dir / "x.png"), "cannot hold the input's"},
        {"render --adaptive --threshold 0 -o " + quote(dir / "x.png"), "--threshold", Exit::Usage},
    };
    for (const Case& c : cases) {
        const RunResult r = run(c.args);
        std::cout << "[" << c.args << "] exit " << r.exitCode << ": " << r.err;
        EXPECT_TRUE(failsCleanly(r, c.status)) << c.args;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << ": " << r.err;
    }
    EXPECT_FALSE(fs::exists(dir / "x.png"));
}

// A path file's frames between two equal keyframes, and a keyframe's own frame, draw that camera
// exactly, so a camera held still comes to rest (interpolated as a (1 - t) + b t, it moved by
// rounding and never did; frame 5 as 3 + (0.7 - 3) 1 missed 0.7); each frame's line gives its
// camera as render --camera takes it.
TEST(CliBenchView, APathHeldStillDrawsOneCamera) {
    const TempDir dir;
    writeText(dir / "hold.txt", "0 3 0.1 2.9 0 0 0\n5 0.7 0.1 2.9 0 0 0\n40 0.7 0.1 2.9 0 0 0\n");
    const RunResult r =
        run("bench view --width 32 --height 24 --camera-path " + quote(dir / "hold.txt") + kFewWholeLevels);
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::vector<std::string> out = lines(r.out);
    ASSERT_EQ(out.size(), 42u) << r.out;
    EXPECT_EQ(jsonField(out[0], "camera"), "3,0.1,2.9,0,0,0,0,1,0") << out[0];
    EXPECT_EQ(jsonField(out[0], "fov_degrees"), "40") << out[0];
    for (std::size_t k = 1; k < 5; ++k)
        EXPECT_NE(jsonField(out[k], "camera"), jsonField(out[k - 1], "camera"));
    for (std::size_t k = 5; k <= 40; ++k) {
        EXPECT_EQ(jsonField(out[k], "camera"), "0.7,0.1,2.9,0,0,0,0,1,0") << out[k];
        EXPECT_EQ(jsonField(out[k], "fov_degrees"), "40") << out[k];
    }
}

// A path that leaves the model behind the camera: background frames, no error.
TEST(CliBenchView, PathThatLeavesTheModelBehindDrawsBackground) {
    const TempDir dir;
    writeText(dir / "away.txt", "0 0 0 3 0 0 0\n3 0 0 3 0 0 6\n");
    const RunResult r = run("bench view --width 32 --height 24 --validation --camera-path " +
                            quote(dir / "away.txt") + kFewWholeLevels);
    ASSERT_TRUE(r.exited && r.exitCode == 0) << r.err;
    const std::vector<std::string> out = lines(r.out);
    ASSERT_EQ(out.size(), 5u) << r.out;
    EXPECT_NE(out[3].find("\"splats_drawn\": 0,"), std::string::npos)
        << out[3]; // the last keyframe looks away
}

} // namespace
} // namespace pnsplat
