// Reading a model for rendering and parsing render options: shared by `render` and `bench render`.
#pragma once

#include <string>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/splat_renderer.h"
#include "pnsplat/refine/point_set.h"

namespace pnsplat::tools {

// The points of `input` (a PLY file, or the embedded default model when empty) with radii
// (estimated when the file has none); CommandError on bad input. `name` receives a name for messages.
PointSet loadForRendering(const std::string& input, std::string& name);

// "compute" or "graphics"; anything else is a CommandError.
engine::RenderPath parseRenderPath(const std::string& text);

} // namespace pnsplat::tools
