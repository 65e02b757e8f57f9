// Writes the fuzz targets' starting corpora (scripts/fuzz.sh): small valid files of every kind the
// reader takes — ascii and binary, with and without radii, colours, second normals, attributes and
// faces, positions only, points too far apart to measure — made here rather than stored. fuzz_ply's folder
// gets the files; fuzz_refine's gets each one several times behind the byte that picks the variant
// (refine_fuzz.cpp); fuzz_points's gets text and PCD files (point_file.h) of the same sets, and a few
// hand-written ones.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/io/point_file.h"
#include "pnsplat/refine/shapes/shapes.h"

using namespace pnsplat;
namespace fs = std::filesystem;

namespace {

bool write(const fs::path& path, const PointSet& points, PlyFormat format) {
    const Result<void> written = writePly(path, points, format);
    if (!written) std::fprintf(stderr, "fuzz_seeds: %s\n", written.error().message.c_str());
    return written.ok();
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: fuzz_seeds PLY_FOLDER REFINE_FOLDER POINTS_FOLDER\n");
        return 2;
    }
    const fs::path folder = argv[1], refineFolder = argv[2], pointsFolder = argv[3];
    fs::create_directories(folder);
    fs::create_directories(refineFolder);
    fs::create_directories(pointsFolder);
    PointSet sphere = sampleSphereUniform(60, 1.0f);
    PointSet torus = sampleTorusRandom(120, 1.0f, 0.4f, 3);
    PointSet model = makeBumpySphere();
    model.position.resize(150), model.normal.resize(150), model.colour.resize(150);
    PointSet cylinder = sampleCappedCylinder(12, 1.0f, 1.5f);
    PointSet withRadii = sphere;
    withRadii.radius.assign(withRadii.size(), 0.4f);
    PointSet withAttributes = torus; // an extra float and an extra uchar (PointSet::attributes)
    withAttributes.attributes = {Attribute{"intensity", ScalarType::Float32, {}},
                                 Attribute{"quality", ScalarType::UInt8, {}}};
    for (std::size_t i = 0; i < withAttributes.size(); ++i) {
        withAttributes.attributes[0].values.push_back(0.5 * static_cast<double>(i));
        withAttributes.attributes[1].values.push_back(static_cast<double>(i * 7 % 256));
    }
    PointSet positionsOnly = torus;
    positionsOnly.normal.clear();
    const PointSet farApart = farApartTriangles(20);
    bool ok = true;
    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        const std::string suffix = format == PlyFormat::Ascii ? "-ascii.ply" : "-binary.ply";
        ok = ok && write(folder / ("sphere" + suffix), sphere, format) &&
             write(folder / ("torus" + suffix), torus, format) &&
             write(folder / ("coloured" + suffix), model, format) &&
             write(folder / ("creases" + suffix), cylinder, format) &&
             write(folder / ("radii" + suffix), withRadii, format) &&
             write(folder / ("attributes" + suffix), withAttributes, format) &&
             write(folder / ("far-apart" + suffix), farApart, format);
    }
    // Positions only and a small mesh: writePly needs normals and writes no faces.
    std::ofstream bare(folder / "positions-ascii.ply");
    bare << "ply\nformat ascii 1.0\nelement vertex " << positionsOnly.size()
         << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    for (const glm::vec3& x : positionsOnly.position) bare << x.x << ' ' << x.y << ' ' << x.z << '\n';
    std::ofstream mesh(folder / "mesh-ascii.ply");
    mesh << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n0 1 0\n1 1 0.2\n3 0 1 2\n3 1 3 2\n";
    ok = ok && bare.good() && mesh.good();
    bare.close();
    mesh.close();
    // The full method, the faster variants, the fuzzy neighbourhood, no smoothing, no boundaries.
    for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
        std::ifstream in(entry.path(), std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        for (const int variant : {0, 1, 2, 4, 8}) {
            std::ofstream out(refineFolder /
                                  (std::to_string(variant) + "-" + entry.path().filename().string()),
                              std::ios::binary);
            out << static_cast<char>(variant) << bytes;
            ok = ok && out.good();
        }
    }
    // Text and PCD files (fuzz_points): every attribute, in each flavour and encoding.
    for (const char* name : {"coloured.xyz", "coloured.csv", "coloured.pts", "coloured.pcd", "creases.txt",
                             "creases.pcd", "radii.pcd", "attributes.xyz", "attributes.pcd"}) {
        const std::string file = name;
        const PointSet& points = file.starts_with("coloured")     ? model
                                 : file.starts_with("creases")    ? cylinder
                                 : file.starts_with("attributes") ? withAttributes
                                                                  : withRadii;
        for (const bool ascii : {false, true}) {
            const Result<void> written =
                writePointFile(pointsFolder / ((ascii ? "ascii-" : "") + file), points, ascii);
            if (!written) std::fprintf(stderr, "fuzz_seeds: %s\n", written.error().message.c_str());
            ok = ok && written.ok();
        }
    }
    std::ofstream cloudCompare(pointsFolder / "cloudcompare.txt");
    cloudCompare
        << "//X,Y,Z,Rf,Gf,Bf,Nx,Ny,Nz\n0,0,0,0.5,0.25,1,0,0,1\n1,0,0,1.0,0,0,0,0,1\n0,1,0,0,1,0,0,0,1\n";
    std::ofstream pts(pointsFolder / "leica.pts");
    pts << "2\n0 0 0 -1200 255 0 0\n1 0 0 300 0 255 0\n1\n0 1 0 0 0 0 255\n";
    std::ofstream pcd(pointsFolder / "organised.pcd");
    pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb curvature\nSIZE 4 4 4 4 4\nTYPE F F F U F\n"
           "COUNT 1 1 1 1 1\nWIDTH 2\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n"
           "0 0 0 16711680 0\nnan nan nan 0 0\n1 0 0 65280 0.1\n0 1 0 255 0.2\n";
    ok = ok && cloudCompare.good() && pts.good() && pcd.good();
    return ok ? 0 : 1;
}
