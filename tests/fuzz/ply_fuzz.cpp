// libFuzzer target: any bytes through parsePly, with the defaults and with faces and without
// required normals. Every input is either read into a consistent point set (finite positions,
// unit normals, attribute arrays of the right size, face indices in range) or rejected with one
// line that names the file; never a crash, a hang or an unbounded allocation.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <glm/geometric.hpp>

#include "fuzz_check.h"
#include "pnsplat/refine/ply.h"

using pnsplat::fuzz::check;

namespace {

void checkRead(std::string_view bytes, const pnsplat::PlyReadOptions& options) {
    const pnsplat::Result<pnsplat::PlyData> read = pnsplat::parsePly(bytes, "input", options);
    if (!read) {
        const std::string& message = read.error().message;
        check(message.rfind("input: ", 0) == 0, "an error names the file first");
        check(message.size() > 7 && message.find('\n') == std::string::npos, "an error is one non-empty line");
        return;
    }
    const pnsplat::PointSet& points = read->points;
    const std::size_t n = points.size();
    check(n > 0, "a file read has points");
    check(points.normal.size() == n || (points.normal.empty() && !options.requireNormals), "normals for every point");
    check(points.radius.empty() || points.radius.size() == n, "radii for every point or none");
    check(points.colour.empty() || points.colour.size() == n, "colours for every point or none");
    check(points.crease.empty() || points.crease.size() == n, "second normals for every point or none");
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 x = points.position[i];
        check(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z), "finite positions");
        if (points.hasNormal()) check(std::abs(glm::length(points.normal[i]) - 1.0f) < 1e-5f, "unit normals");
        if (points.hasRadius()) check(std::isfinite(points.radius[i]) && points.radius[i] >= 0.0f, "finite radii >= 0");
        if (points.isCrease(i)) check(std::abs(glm::length(points.crease[i]) - 1.0f) < 1e-5f, "unit second normals");
    }
    check(options.readFaces || read->triangles.empty(), "no triangles unless asked for");
    for (const glm::u32vec3& t : read->triangles) check(t.x < n && t.y < n && t.z < n, "face indices in range");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    checkRead(bytes, {});
    pnsplat::PlyReadOptions lenient;
    lenient.readFaces = true;
    lenient.requireNormals = false;
    checkRead(bytes, lenient);
    return 0;
}
