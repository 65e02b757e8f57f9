// What `render`, `bench view` and `view` share to set up the real-time engine: loading the points,
// the Vulkan context, and the engine's options on the command line.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/point_set.h"

namespace CLI {
class App;
}

namespace pnsplat::tools {

// The points of `input` (a PLY file, or the embedded default model when empty) with normals and
// radii (estimated when the file has none), flipped normals turned back unless `keepNormals`;
// `name` receives a name for messages.
PointSet loadForRendering(const std::string& input, bool keepNormals, std::string& name);

// The engine's options that the commands share.
struct EngineArgs {
    std::uint32_t width = 1280, height = 720;
    std::string path = "auto";
    std::string device;
    bool validation = false;
    float threshold = 2.0f;
    double cacheMb = 96.0;
    unsigned workers = 1;
    int workerNice = 0;
    bool fast = false;      // the paper's faster variants for the levels the engine refines
    double targetFps = 0.0; // keep this frame rate by raising the threshold where needed (0: none)
};
// Registers --path, --device, --validation on `cmd`; with `adaptive`, also --threshold, --cache-mb,
// --workers and --fast (their help says "with --adaptive" when `requiresFlag`).
void addEngineOptions(CLI::App& cmd, EngineArgs& args, bool adaptive, bool requiresFlag);

// The Vulkan context for the args (validation layer with --validation, and always in debug builds).
std::unique_ptr<engine::Context> createContext(const EngineArgs& args);
// "auto" is the compute path where the device has what it needs (on lavapipe it is several times
// faster than the raster pipeline), else the graphics path.
engine::RenderPath choosePath(const std::string& path, const engine::Context& context);
// Engine settings from the args (render size and path; threshold, cache, workers, variants).
engine::EngineSettings engineSettings(const EngineArgs& args, const engine::Context& context, bool adaptive);
// Throws a CommandError when the context's validation layer reported anything.
void checkValidation(const engine::Context& context);

} // namespace pnsplat::tools
