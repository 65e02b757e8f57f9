#include "engine_setup.h"

#include <fmt/core.h>

#include "commands.h"
#include "pnsplat/refine/angles.h"
#include "pnsplat/refine/io/ply.h"
#include "pnsplat/refine/shapes/shapes.h"
#include "refine_run.h"

namespace pnsplat::tools {

PointSet loadForRendering(const std::string& input, const InputOptions& options, std::string& name,
                          const std::vector<std::string>& columns, InputCompletion* completion,
                          glm::dvec3* origin) {
    glm::dvec3 fileOrigin(0.0);
    if (!origin) origin = &fileOrigin; // for the notes' places
    PointSet points;
    std::vector<std::string> comments;
    if (input.empty()) {
        name = "the default model";
        points = makeDefaultModel();
    } else {
        name = inputName(input);
        points = readInput(input, &comments, columns, origin);
    }
    // The engine draws no attributes (PointSet::attributes): its node tree need not copy them.
    points.attributes.clear();
    InputOptions completing = options;
    if (writtenByPnsplat(comments) && points.hasNormal() && points.hasRadius()) {
        // pnsplat's own output, such as a refinement, completed when it was made: drawn as written.
        completing.asWritten = true;
        fmt::print(stderr,
                   "pnsplat: {}: written by pnsplat, with normals and radii: drawn as written (not searched "
                   "for outliers or flipped normals)\n",
                   name);
    }
    const InputCompletion done = completeInput(points, 0, name, completing, *origin);
    if (completion) *completion = done;
    return points;
}

PointSet loadBeside(const std::string& path, const InputOptions& options, std::string& name,
                    glm::dvec3 origin) {
    glm::dvec3 own(0.0);
    PointSet points = loadForRendering(path, options, name, {}, nullptr, &own);
    moveToOrigin(points.position, own, origin);
    return points;
}

void addSizeOptions(CLI::App& cmd, EngineArgs& args, const std::string& what, unsigned minimum) {
    for (const bool width : {true, false})
        cmd.add_option(width ? "--width" : "--height", width ? args.width : args.height,
                       fmt::format(fmt::runtime(what), width ? "width" : "height"))
            ->check(CLI::Range(minimum, 16384u))
            ->capture_default_str();
}

void addBackgroundOption(CLI::App& cmd, std::vector<float>& background) {
    cmd.add_option("--background", background, "background colour r,g,b in [0, 1]")
        ->delimiter(',')
        ->expected(3)
        ->check(finiteRange(0.0, 1.0));
}

void addEngineOptions(CLI::App& cmd, EngineArgs& args, bool adaptive, bool requiresFlag) {
    cmd.add_option("--path", args.path,
                   "compute (atomics), graphics (raster pipeline), or auto: compute where the device can")
        ->check(CLI::IsMember({"auto", "compute", "graphics"}))
        ->capture_default_str();
    cmd.add_option("--device", args.device,
                   "Vulkan device whose name contains this text (default: a GPU, else lavapipe)");
    cmd.add_flag("--validation", args.validation,
                 "load the Vulkan validation layer; any message fails the command");
    cmd.add_option("--radius-scale", args.radiusScale, "splat radius as a multiple of the point radius")
        ->check(finiteRange(0.01, 100.0))
        ->capture_default_str();
    cmd.add_flag("--hard-edges", args.hardEdges,
                 "cover each pixel of the outer silhouette whole (default: blended toward the background by "
                 "its splats' weight, antialiased)");
    cmd.add_flag("--keep-pinholes", args.keepPinholes,
                 "draw a pixel no splat reached as background even where splats reached its four neighbours "
                 "(default: such a pinhole is drawn as its horizontal neighbour)");
    if (!adaptive) return;
    const std::string with = requiresFlag ? "with --adaptive: " : "";
    cmd.add_option("--threshold", args.threshold,
                   with + "splat diameter wanted on screen, pixels: the median splat drawn (silhouettes are "
                          "refined finer)")
        ->check(finiteRange(0.01, 1000.0))
        ->capture_default_str();
    cmd.add_option("--cache-mb", args.cacheMb, with + "the GPU cache of points, MiB (32 bytes a point)")
        ->check(finiteRange(0.001, 1048576.0))
        ->capture_default_str();
    // bench view and view also take --threads, the name (render's --threads would be
    // ambiguous beside --refine-levels, whose refinement uses every core).
    cmd.add_option(requiresFlag ? "--workers" : "--workers,--threads", args.workers,
                   with + "refinement worker threads")
        ->check(CLI::Range(1u, 64u))
        ->capture_default_str();
    cmd.add_option("--worker-nice", args.workerNice,
                   with + "nice value added to the workers' (Linux; 0: the same priority as drawing)")
        ->check(CLI::Range(0, 19))
        ->capture_default_str();
    cmd.add_option("--whole-levels", args.wholeLevelPoints,
                   with + "refine whole levels of the model first, while the next holds at most about this "
                          "many points (they are the offline refinement's; nodes refine the levels after; 0: "
                          "none; at most half the points the tree keeps, 2 x the cache's)")
        ->check(CLI::Range(std::size_t{0}, std::size_t{1} << 32))
        ->capture_default_str();
    cmd.add_flag("--fast", args.fast, with + "the paper's faster variants (all four) for the levels refined");
    cmd.add_option("--target-fps", args.targetFps,
                   with + "keep this frame rate: where frames are slower, splats larger than --threshold are "
                          "drawn (the threshold in force is reported); 0: never")
        ->check(finiteRange(0.0, 1000.0))
        ->capture_default_str();
}

CLI::Option* addCameraOptions(CLI::App& cmd, CameraArgs& args) {
    CLI::Option* camera =
        cmd.add_option("--camera", args.camera,
                       "eye, target and up: ex,ey,ez,tx,ty,tz,ux,uy,uz, in the file's coordinates (as render "
                       "prints it)")
            ->delimiter(',')
            ->expected(9)
            ->check(finiteRange(-1e30, 1e30));
    cmd.add_option("--up", args.up,
                   "the model's up axis; auto: the axis of its broadest base, else y (see README, Use)")
        ->check(CLI::IsMember({"auto", "x", "y", "z"}))
        ->excludes(camera)
        ->capture_default_str();
    cmd.add_option("--orbit", args.orbitDegrees, "turn the framing camera about the up axis, degrees")
        ->check(finiteRange(-1e6, 1e6))
        ->excludes(camera)
        ->capture_default_str();
    cmd.add_option("--elevation", args.elevationDegrees,
                   "raise the framing camera towards the up axis, degrees")
        ->check(finiteRange(-89.0, 89.0))
        ->excludes(camera)
        ->capture_default_str();
    cmd.add_option("--fov", args.fovDegrees, "vertical field of view, degrees")
        ->check(finiteRange(1.0, 179.0))
        ->capture_default_str();
    return camera;
}

engine::Camera chooseCamera(const CameraArgs& args, const PointSet& frame, float aspect,
                            std::optional<engine::Viewpoint>& view, glm::dvec3 origin) {
    const float fov = static_cast<float>(radians(args.fovDegrees));
    engine::Camera camera;
    if (!args.camera.empty()) {
        const auto at = [&](int first) {
            return glm::dvec3(args.camera[first], args.camera[first + 1], args.camera[first + 2]);
        };
        camera.eye = glm::vec3(at(0) - origin);
        camera.target = glm::vec3(at(3) - origin);
        camera.up = glm::vec3(at(6));
        camera.fovY = fov;
        if (!camera.valid())
            throw CommandError("--camera: the eye is on the target, or up lies along the line of sight",
                               kExitUsage);
        return camera;
    }
    std::optional<glm::vec3> up;
    if (args.up != "auto") {
        up = glm::vec3(0.0f);
        (*up)[args.up[0] - 'x'] = 1.0f;
    }
    view = engine::chooseViewpoint(frame.position, frame.normal, up);
    return engine::frameSphere(engine::boundingSphere(frame.position), aspect, fov,
                               static_cast<float>(radians(args.orbitDegrees)), *view,
                               static_cast<float>(radians(args.elevationDegrees)));
}

std::unique_ptr<engine::Context> createContext(const EngineArgs& args, engine::ContextOptions options) {
    options.deviceName = args.device;
#ifndef NDEBUG
    options.validation = true;
#endif
    options.validation |= args.validation;
    return unwrap(engine::Context::create(options));
}

engine::RenderPath choosePath(const std::string& path, const engine::Context& context) {
    if (path == "graphics") return engine::RenderPath::Graphics;
    if (path == "compute" || !engine::computePathProblem(context)) return engine::RenderPath::Compute;
    return engine::RenderPath::Graphics;
}

engine::EngineSettings engineSettings(const EngineArgs& args, const engine::Context& context, bool adaptive) {
    engine::EngineSettings settings;
    settings.render.width = args.width;
    settings.render.height = args.height;
    settings.render.path = choosePath(args.path, context);
    settings.adaptive = adaptive;
    settings.render.radiusScale = args.radiusScale;
    settings.render.smoothEdges = !args.hardEdges;
    settings.render.fillPinholes = !args.keepPinholes;
    settings.threshold = args.threshold;
    settings.cacheBytes = static_cast<std::size_t>(args.cacheMb * double(1 << 20));
    settings.workers = args.workers;
    settings.workerNice = args.workerNice;
    settings.wholeLevelPoints = args.wholeLevelPoints;
    if (args.fast) settings.nodes.refine = RefineOptions::fast();
    settings.targetFrameMs = args.targetFps > 0.0 ? static_cast<float>(1000.0 / args.targetFps) : 0.0f;
    return settings;
}

void checkValidation(const engine::Context& context) {
    if (context.validationMessages() > 0)
        throw CommandError(fmt::format("{} validation message(s); the last: {}", context.validationMessages(),
                                       context.lastValidationMessage()));
}

} // namespace pnsplat::tools
