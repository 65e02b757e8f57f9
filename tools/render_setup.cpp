#include "render_setup.h"

#include "commands.h"
#include "pnsplat/refine/ply.h"
#include "pnsplat/refine/radius_estimation.h"
#include "pnsplat/refine/shapes.h"

namespace pnsplat::tools {

PointSet loadForRendering(const std::string& input, std::string& name) {
    PointSet points;
    if (input.empty()) {
        name = "the default model";
        points = makeDefaultModel();
    } else {
        name = input;
        points = unwrap(readPly(input)).points;
    }
    if (!points.hasRadius()) estimateRadii(points);
    return points;
}

engine::RenderPath parseRenderPath(const std::string& text) {
    if (text == "compute") return engine::RenderPath::Compute;
    if (text == "graphics") return engine::RenderPath::Graphics;
    throw CommandError("unknown render path '" + text + "' (compute or graphics)");
}

} // namespace pnsplat::tools
