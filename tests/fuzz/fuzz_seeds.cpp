// Writes the fuzz targets' starting corpora (scripts/fuzz.sh): small valid files of every kind the
// reader takes — ascii and binary, with and without radii, colours, second normals and faces,
// positions only — made here rather than stored. fuzz_ply's folder gets the files; fuzz_refine's
// gets each one several times behind the byte that picks the variant (refine_fuzz.cpp).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "pnsplat/refine/ply.h"
#include "pnsplat/refine/shapes.h"

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
    if (argc != 3) {
        std::fprintf(stderr, "usage: fuzz_seeds PLY_FOLDER REFINE_FOLDER\n");
        return 2;
    }
    const fs::path folder = argv[1], refineFolder = argv[2];
    fs::create_directories(folder);
    fs::create_directories(refineFolder);
    PointSet sphere = sampleSphereUniform(60, 1.0f);
    PointSet torus = sampleTorusRandom(120, 1.0f, 0.4f, 3);
    PointSet model = makeBumpySphere();
    model.position.resize(150), model.normal.resize(150), model.colour.resize(150);
    PointSet cylinder = sampleCappedCylinder(12, 1.0f, 1.5f);
    PointSet withRadii = sphere;
    withRadii.radius.assign(withRadii.size(), 0.4f);
    PointSet positionsOnly = torus;
    positionsOnly.normal.clear();
    bool ok = true;
    for (const PlyFormat format : {PlyFormat::Ascii, PlyFormat::BinaryLittleEndian}) {
        const std::string suffix = format == PlyFormat::Ascii ? "-ascii.ply" : "-binary.ply";
        ok = ok && write(folder / ("sphere" + suffix), sphere, format) &&
             write(folder / ("torus" + suffix), torus, format) &&
             write(folder / ("coloured" + suffix), model, format) &&
             write(folder / ("creases" + suffix), cylinder, format) &&
             write(folder / ("radii" + suffix), withRadii, format);
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
    return ok ? 0 : 1;
}
