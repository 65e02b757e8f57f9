// The standalone viewer, `pnsplat view` (docs/VIEWER.md): a GLFW window with a Vulkan swapchain
// showing the real-time engine (engine.h) as it refines, with camera controls (camera_control.h),
// toggles, live statistics in a text overlay (overlay.h) and scripted runs (script.h).
//
// Only this library opens windows; pnsplat::engine and the offscreen commands never need a display.
// Thread use: the render thread (the one that called WindowSystem::open) for everything; dropped
// files load on a thread of their own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pnsplat/engine/camera.h"
#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/refine/point_set.h"
#include "pnsplat/refine/result.h"

namespace pnsplat::viewer {

// The window system (GLFW: X11 with Debian's libglfw3), once per program.
class WindowSystem {
  public:
    // Fails, with one line that says why, when there is no display to open windows on (DISPLAY
    // unset, or its server unreachable) or no Vulkan loader.
    static Result<std::unique_ptr<WindowSystem>> open();
    ~WindowSystem();
    WindowSystem(const WindowSystem&) = delete;
    WindowSystem& operator=(const WindowSystem&) = delete;

    // The instance extensions a window's surface needs (VK_KHR_surface and the platform's), and the
    // device extension of swapchains: what the engine's Context must be created with.
    std::vector<std::string> instanceExtensions() const;
    static std::vector<std::string> deviceExtensions();

  private:
    WindowSystem() = default;
};

// A model to show.
struct Model {
    PointSet points;        // with normals and radii; with refinement, valid for it (Engine::create)
    std::string name;       // for messages and the window's title
    engine::Camera camera;  // where the view starts and R returns to
    engine::Sphere bounds;  // what F frames (the points' boundingSphere)
    glm::dvec3 origin{0.0}; // the file's coordinates are origin + position (PlyData::origin)
};

// Loads the model of a file dropped on the window, framed for a view of aspect `aspect` (width /
// height). Runs on a thread of its own; throws std::exception with a one-line message that names
// the file when it cannot.
using ModelLoader = std::function<Model(const std::string& path, float aspect)>;

// Receives each frame's report once the frame has finished on the GPU (its pass times filled), in
// order, with the frame's time (the wall time from its start to the next frame's, milliseconds) and
// the model's Model::origin (its camera is held less it).
using FrameSink = std::function<void(const engine::FrameReport& report, double frameMs, glm::dvec3 origin)>;

struct ViewerOptions {
    std::uint32_t width = 1280, height = 720; // the window, in screen units
    bool vsync = true;                        // wait for the display (FIFO); off: immediate or mailbox
    // The engine's settings; the render size follows the window's framebuffer (high-DPI: larger).
    engine::EngineSettings engine;
    std::string script;     // a script file to replay (script.h), or empty
    std::size_t frames = 0; // draw this many frames, then quit (0: until closed)
    // After `frames` frames (at least one), the first frame drawn once the refinement has settled is
    // written here (a PNG), then the viewer quits; empty: no screenshot.
    std::string screenshot;
    bool screenshotOverlay = false; // screenshots include the overlay's panels as shown
};

struct ViewerSummary {
    std::size_t frames = 0;          // drawn
    double seconds = 0.0;            // from the first frame's start to the end
    engine::EngineSettings settings; // the engine's at the end (after the toggles)
};

// Opens the window on `context` (created with the window system's extensions), shows `model` and
// runs until the window closes (its close button, Esc or Q, a script's quit, `frames`). Errors
// (one line): the device cannot present to the window, a script that cannot be read, the engine's
// errors, a screenshot that cannot be written.
Result<ViewerSummary> run(WindowSystem& windows, engine::Context& context, Model model,
                          const ViewerOptions& options, const ModelLoader& loader, const FrameSink& sink);

} // namespace pnsplat::viewer
