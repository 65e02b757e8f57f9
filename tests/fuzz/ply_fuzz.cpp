// libFuzzer target: any bytes through parsePly, with the defaults and with faces and without
// required normals. Every input is either read into a consistent point set (finite positions,
// unit normals, attribute arrays of the right size, face indices in range) or rejected with one
// line that names the file; never a crash, a hang or an unbounded allocation.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.h"
#include "oracles.h"
#include "pnsplat/refine/io/ply.h"

using pnsplat::fuzz::check;

namespace {

void checkRead(std::string_view bytes, const pnsplat::PlyReadOptions& options) {
    const pnsplat::Result<pnsplat::PlyData> read = pnsplat::parsePly(bytes, "input", options);
    if (!read) {
        const std::string& message = read.error().message;
        check(message.rfind("input: ", 0) == 0, "an error names the file first");
        check(message.size() > 7 && message.find('\n') == std::string::npos,
              "an error is one non-empty line");
        return;
    }
    const pnsplat::PointSet& points = read->points;
    const std::size_t n = points.size();
    check(n > 0, "a file read has points");
    check(points.hasNormal() || !options.requireNormals, "normals where required");
    const std::string defect = pnsplat::test::pointSetDefect(points);
    check(defect.empty(), defect.c_str());
    check(options.readFaces || read->triangles.empty(), "no triangles unless asked for");
    for (const glm::u32vec3& t : read->triangles)
        check(t.x < n && t.y < n && t.z < n, "face indices in range");
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
