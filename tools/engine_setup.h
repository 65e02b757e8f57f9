// What `render`, `bench view` and `view` share to set up the real-time engine: loading the points,
// the Vulkan context, and the engine's options on the command line.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/input.h"
#include "pnsplat/refine/point_set.h"

namespace CLI {
class App;
class Option;
} // namespace CLI

namespace pnsplat::tools {

// The points of `input` (a point file: readInput, refine_run.h; or the embedded default model when
// empty) completed as `refine` completes them (completeInput): outliers left out unless
// options.keepOutliers, normals and radii estimated when the file has none, flipped normals turned
// back unless options.keepNormals; a file pnsplat wrote with normals and radii (a refinement) is
// taken as written (InputOptions::asWritten). `columns` names a text file's columns (--columns). `name`
// receives a name for messages; `completion`, when given, what was done. The real-time engine's
// loader: `render`, `bench view` and `view` (a dropped file too). `origin`, when given, receives
// the points' origin (PlyData::origin), for files drawn together; the engine draws them less it.
PointSet loadForRendering(const std::string& input, const InputOptions& options, std::string& name,
                          const std::vector<std::string>& columns = {}, InputCompletion* completion = nullptr,
                          glm::dvec3* origin = nullptr);

// `path` (render's --frame or --reference) for drawing beside points stored less `origin`.
PointSet loadBeside(const std::string& path, const InputOptions& options, std::string& name,
                    glm::dvec3 origin);

// The engine's options that the commands share.
struct EngineArgs {
    std::uint32_t width = 1280, height = 720;
    std::string path = "auto";
    std::string device;
    bool validation = false;
    float threshold = 3.0f;
    float radiusScale = 1.0f;  // splat radius = point radius × this
    bool hardEdges = false;    // RenderSettings::smoothEdges off
    bool keepPinholes = false; // RenderSettings::fillPinholes off
    double cacheMb = 96.0;
    unsigned workers = 2;
    int workerNice = engine::kWorkerNice;
    bool fast = false;      // the paper's faster variants for the levels the engine refines
    double targetFps = 0.0; // keep this frame rate by raising the threshold where needed (0: none)
    std::size_t wholeLevelPoints = engine::kWholeLevelPoints;
};
// Registers --width and --height on `cmd`: of `what` ("image width in pixels"), from 1 or `minimum`.
void addSizeOptions(CLI::App& cmd, EngineArgs& args, const std::string& what, unsigned minimum);
// Registers --background r,g,b (each in [0, 1]) on `cmd`, into `background`.
void addBackgroundOption(CLI::App& cmd, std::vector<float>& background);
// Registers --path, --device, --validation, --radius-scale on `cmd`; with `adaptive`, also --threshold,
// --cache-mb,
// --workers and --fast (their help says "with --adaptive" when `requiresFlag`).
void addEngineOptions(CLI::App& cmd, EngineArgs& args, bool adaptive, bool requiresFlag);

// The camera options that `render` and `view` share: --camera, or the framing camera's --up,
// --orbit and --elevation; --fov for both.
struct CameraArgs {
    std::vector<double> camera; // eye, target, up (9 values) or empty; in the file's coordinates
    std::string up = "auto";    // auto, x, y or z
    double orbitDegrees = 0.0;
    double elevationDegrees = 0.0;
    double fovDegrees = 40.0;
};
// Registers them on `cmd`; returns --camera (which the framing options exclude).
CLI::Option* addCameraOptions(CLI::App& cmd, CameraArgs& args);
// The camera of --camera, or the one chosen for `frame` (the points to frame: a model as loaded,
// before any refinement) in an image of the given aspect (width / height):
// engine::chooseViewpoint, then frameSphere about boundingSphere(frame.position). `view`
// receives the viewpoint chosen (unset for --camera). --camera is in the file's coordinates: less
// `origin` (PlyData::origin, where `frame` is held less it). Throws a usage error for a --camera
// whose eye is on its target or whose up lies along the line of sight.
engine::Camera chooseCamera(const CameraArgs& args, const PointSet& frame, float aspect,
                            std::optional<engine::Viewpoint>& view, glm::dvec3 origin = glm::dvec3(0.0));

// The Vulkan context for the args (validation layer with --validation, and always in debug builds);
// `options` adds what else it needs (a window's extensions).
std::unique_ptr<engine::Context> createContext(const EngineArgs& args, engine::ContextOptions options = {});
// "auto" is the compute path where the device has what it needs (on lavapipe it is several times
// faster than the raster pipeline), else the graphics path.
engine::RenderPath choosePath(const std::string& path, const engine::Context& context);
// Engine settings from the args (render size and path; threshold, cache, workers, variants).
engine::EngineSettings engineSettings(const EngineArgs& args, const engine::Context& context, bool adaptive);
// Throws a CommandError when the context's validation layer reported anything.
void checkValidation(const engine::Context& context);

} // namespace pnsplat::tools
