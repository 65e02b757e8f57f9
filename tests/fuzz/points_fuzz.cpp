// libFuzzer target: any bytes through the readers of PCD and text point files (parsePointFile),
// as their content shows them and as each kind, text with columns named by the options too. Every
// input is either read into a consistent point set (finite positions, unit normals, attribute
// arrays of the right size) or rejected with one line that names the file; never a crash, a hang
// or an unbounded allocation.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "fuzz_check.h"
#include "oracles.h"
#include "pnsplat/refine/io/point_file.h"

using pnsplat::fuzz::check;

namespace {

void checkRead(std::string_view bytes, std::optional<pnsplat::PointFileKind> kind,
               const pnsplat::PointFileOptions& options) {
    const pnsplat::Result<pnsplat::PointFileData> read =
        pnsplat::parsePointFile(bytes, "input", kind, options);
    if (!read) {
        const std::string& message = read.error().message;
        check(message.rfind("input: ", 0) == 0, "an error names the file first");
        check(message.size() > 7 && message.find('\n') == std::string::npos,
              "an error is one non-empty line");
        return;
    }
    const pnsplat::PointSet& points = read->data.points;
    check(!points.empty(), "a file read has points");
    check(points.hasNormal() || !options.requireNormals, "normals where required");
    const std::string defect = pnsplat::test::pointSetDefect(points);
    check(defect.empty(), defect.c_str());
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    pnsplat::PointFileOptions lenient;
    lenient.requireNormals = false;
    checkRead(bytes, std::nullopt, lenient);
    checkRead(bytes, pnsplat::PointFileKind::Pcd, {});
    checkRead(bytes, pnsplat::PointFileKind::Text, {});
    pnsplat::PointFileOptions named = lenient;
    named.columns = {"nx", "ny", "nz", "x", "y", "z", "r", "g", "b"};
    checkRead(bytes, pnsplat::PointFileKind::Text, named);
    return 0;
}
