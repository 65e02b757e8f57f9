#include "pnsplat/viewer/viewer.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <future>
#include <optional>
#include <set>
#include <stdexcept>
#include <utility>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <fmt/core.h>

#include "pnsplat/viewer/camera_control.h"
#include "pnsplat/viewer/overlay.h"
#include "pnsplat/viewer/script.h"
#include "presenter.h"

namespace pnsplat::viewer {

namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

// The last error GLFW reported (GLFW calls back on the thread that called it: the render thread).
std::string& glfwLastError() {
    static std::string error;
    return error;
}
void onGlfwError(int, const char* description) {
    glfwLastError() = description;
}

constexpr double kMessageSeconds = 5.0;       // how long a message stays on screen
constexpr float kThresholdStep = 1.41421356f; // + and - multiply and divide the threshold by this
constexpr float kMinThreshold = 0.5f, kMaxThreshold = 256.0f;
constexpr double kSettleSeconds = 600.0; // a script's settle, or the final screenshot, waits at most this
// Frames in a row in which nothing refined joined, nothing was uploaded and no job was queued: the
// refinement cannot go on for this view (a full cache), and the picture will not change.
constexpr std::size_t kStalledFrames = 8;
constexpr double kScriptFrameSeconds = 1.0 / 30.0; // a script's frame, for flying and while minimized
constexpr double kIdleWaitSeconds = 0.5; // while nothing changes, events are awaited this long at most
constexpr float kShiftFactor = 4.0f;     // Shift flies this much faster

// The controls, for the help panel (README and docs/VIEWER.md have the same table).
const std::vector<std::pair<const char*, const char*>> kControls = {
    {"left drag", "orbit about the model (fly mode: look around)"},
    {"right or middle drag", "pan"},
    {"wheel", "zoom to the cursor"},
    {"W A S D, E C", "fly forward, left, back, right, up, down (Shift: faster)"},
    {"Tab", "orbit or fly mode (what the left drag does)"},
    {"F / R", "frame the model / reset the camera"},
    {"Space", "refinement on or off (restarts from the input)"},
    {"+ / -", "threshold up / down (x 1.41)"},
    {"N", "neighbourhood: accurate or fuzzy (restarts)"},
    {"V", "the faster variants on or off (restarts)"},
    {"G", "render path: compute or graphics"},
    {"O", "raw points (each point one pixel)"},
    {"M", "heat map of splat size"},
    {"P", "screenshot (PNG in the current folder)"},
    {"I / H", "statistics / this help"},
    {"Esc, Q", "quit"},
};

struct WindowDeleter {
    void operator()(GLFWwindow* window) const { glfwDestroyWindow(window); }
};

class Session {
  public:
    Session(engine::Context& context, Model model, const ViewerOptions& options, const ModelLoader& loader,
            const FrameSink& sink);
    ~Session();
    Result<ViewerSummary> run();

  private:
    // Input.
    void handle(const Event& event);
    void changed();
    void keyPressed(int key);
    static void onKey(GLFWwindow* window, int key, int scancode, int action, int mods);
    static void onButton(GLFWwindow* window, int button, int action, int mods);
    static void onCursor(GLFWwindow* window, double x, double y);
    static void onScroll(GLFWwindow* window, double x, double y);
    static void onDrop(GLFWwindow* window, int count, const char** paths);
    static void onIconify(GLFWwindow* window, int iconified);
    static void onRefresh(GLFWwindow* window);
    glm::vec2 windowSize() const;

    // The engine.
    bool startEngine(const PointSet& points, const engine::EngineSettings& settings);
    void restartEngine();
    void setRender(const engine::RenderSettings& render, const std::string& what);
    void setThreshold(float px);
    void collectReports(bool all);
    void checkLoad();

    // A frame.
    bool resizeIfNeeded();
    void fly(double seconds);
    std::vector<PlacedPanel> panels() const;
    std::vector<TextLine> statistics() const;
    void message(std::string text, glm::u8vec3 colour = kTextColour);
    std::string nextScreenshotName() const;
    bool busy() const;
    Result<void> writeScreenshot(const std::string& path, const engine::FrameReport& report,
                                 const std::vector<PlacedPanel>& shown);

    engine::Context& context_;
    Model model_;
    glm::dvec3 engineOrigin_{0.0}; // the origin of the model engine_ draws (its reports' cameras)
    ViewerOptions options_;
    const ModelLoader& loader_;
    const FrameSink& sink_;
    std::unique_ptr<GLFWwindow, WindowDeleter> window_;
    std::unique_ptr<Presenter> presenter_;
    std::unique_ptr<engine::Engine> engine_;
    engine::EngineSettings settings_;                            // what the next engine is made with
    engine::RenderPath splatPath_ = engine::RenderPath::Compute; // the path the raw points view returns to
    CameraControl control_;
    engine::Camera lastValidCamera_; // the camera of the last frame drawn
    std::optional<Script> script_;

    std::vector<Event> events_; // from the window, not yet handled
    glm::dvec2 cursor_{0.0};
    std::array<bool, GLFW_MOUSE_BUTTON_LAST + 1> buttons_{};
    std::set<int> keys_;
    bool fly_ = false, help_ = false, stats_ = true;
    bool minimized_ = false, quit_ = false, rebuild_ = false;

    std::uint64_t scriptFrame_ = 0;
    bool settling_ = false;
    Clock::time_point settleStart_{};
    // For the next frame drawn; a script's that cannot be written end the session, P's show an error.
    struct Screenshot {
        std::string path;
        bool fromScript = false;
    };
    std::vector<Screenshot> screenshots_;
    std::size_t framesDrawn_ = 0;
    Clock::time_point firstFrame_{}, lastTick_{};
    bool settledView_ = false;      // the last frame drawn was settled and nothing changed since
    std::size_t stalledFrames_ = 0; // frames in a row that changed nothing, unsettled (kStalledFrames)
    std::size_t quietFrames_ = 0;   // frames drawn since the last change

    struct Message {
        std::string text;
        glm::u8vec3 colour;
        Clock::time_point until;
    };
    std::optional<Message> message_;
    std::future<Model> loading_;
    std::string loadingPath_;

    // Frames submitted and not yet reported, with their starts; the recent finished ones, for the
    // statistics.
    std::deque<std::pair<std::uint64_t, Clock::time_point>> starts_;
    struct Finished {
        engine::FrameReport report;
        double ms;
        Clock::time_point at;
    };
    std::deque<Finished> recent_;
};

Session* sessionOf(GLFWwindow* window) {
    return static_cast<Session*>(glfwGetWindowUserPointer(window));
}

Session::Session(engine::Context& context, Model model, const ViewerOptions& options,
                 const ModelLoader& loader, const FrameSink& sink)
    : context_(context), model_(std::move(model)), options_(options), loader_(loader), sink_(sink),
      settings_(options.engine), control_(model_.camera, model_.bounds), lastValidCamera_(model_.camera) {
    if (settings_.render.path == engine::RenderPath::PlainPoints)
        settings_.render.path = engine::RenderPath::Compute;
    splatPath_ = settings_.render.path;
}

Session::~Session() {
    if (loading_.valid() && loading_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
        // The loader cannot be stopped midway: the window goes now, the process when it ends.
        if (window_) glfwHideWindow(window_.get());
        fmt::print(stderr, "pnsplat: waiting for {} to finish loading\n", loadingPath_);
        loading_.wait();
    }
    if (engine_) engine_->finish();
    engine_.reset();
    presenter_.reset();
}

glm::vec2 Session::windowSize() const {
    int width = 0, height = 0;
    glfwGetWindowSize(window_.get(), &width, &height);
    return {float(std::max(width, 1)), float(std::max(height, 1))};
}

void Session::message(std::string text, glm::u8vec3 colour) {
    if (colour == kErrorColour)
        fmt::print(stderr, "pnsplat: {}\n", text);
    else
        fmt::print("{}\n", text);
    std::fflush(stdout);
    message_ = Message{std::move(text), colour,
                       Clock::now() + std::chrono::milliseconds(int(kMessageSeconds * 1000))};
}

// Window callbacks: events are queued and handled in order at the start of the next frame.
void Session::onKey(GLFWwindow* window, int key, int, int action, int) {
    if (action == GLFW_REPEAT) return;
    sessionOf(window)->events_.push_back({Event::Kind::Key, key, action == GLFW_PRESS, {}, {}});
}
void Session::onButton(GLFWwindow* window, int button, int action, int) {
    sessionOf(window)->events_.push_back({Event::Kind::Button, button, action == GLFW_PRESS, {}, {}});
}
void Session::onCursor(GLFWwindow* window, double x, double y) {
    sessionOf(window)->events_.push_back({Event::Kind::Move, 0, false, {x, y}, {}});
}
void Session::onScroll(GLFWwindow* window, double x, double y) {
    sessionOf(window)->events_.push_back({Event::Kind::Wheel, 0, false, {x, y}, {}});
}
void Session::onDrop(GLFWwindow* window, int count, const char** paths) {
    Session& session = *sessionOf(window);
    if (count > 1) session.message(fmt::format("{} files dropped: opening the first", count));
    if (count > 0) session.events_.push_back({Event::Kind::Drop, 0, false, {}, paths[0]});
}
void Session::onRefresh(GLFWwindow* window) {
    sessionOf(window)->changed(); // uncovered: draw again
}
void Session::onIconify(GLFWwindow* window, int iconified) {
    Session& session = *sessionOf(window);
    session.minimized_ = iconified == GLFW_TRUE;
    if (!session.minimized_) session.rebuild_ = true;
}

// The picture may change: frames are drawn again until it has settled.
void Session::changed() {
    settledView_ = false;
    quietFrames_ = 0;
}

void Session::handle(const Event& event) {
    // A cursor that moves without a button held changes nothing.
    if (event.kind != Event::Kind::Move || buttons_[GLFW_MOUSE_BUTTON_LEFT] ||
        buttons_[GLFW_MOUSE_BUTTON_RIGHT] || buttons_[GLFW_MOUSE_BUTTON_MIDDLE])
        changed();
    const glm::vec2 size = windowSize();
    switch (event.kind) {
    case Event::Kind::Key:
        if (event.down) {
            keys_.insert(event.code);
            keyPressed(event.code);
        } else {
            keys_.erase(event.code);
        }
        break;
    case Event::Kind::Button:
        if (event.code >= 0 && event.code <= GLFW_MOUSE_BUTTON_LAST)
            buttons_[std::size_t(event.code)] = event.down;
        break;
    case Event::Kind::Move: {
        const glm::vec2 delta = glm::vec2(event.position - cursor_);
        cursor_ = event.position;
        if (buttons_[GLFW_MOUSE_BUTTON_LEFT]) {
            if (fly_)
                control_.look(delta, size);
            else
                control_.orbit(delta, size);
        } else if (buttons_[GLFW_MOUSE_BUTTON_RIGHT] || buttons_[GLFW_MOUSE_BUTTON_MIDDLE]) {
            control_.pan(delta, size);
        }
        break;
    }
    case Event::Kind::Wheel:
        control_.zoom(float(event.position.y), glm::vec2(cursor_), size);
        break;
    case Event::Kind::Resize:
        glfwSetWindowSize(window_.get(), int(event.position.x), int(event.position.y));
        break;
    case Event::Kind::Minimize:
        // A script minimizes as the window manager would; without one (a bare X server) the
        // request does nothing, so the state is set here too.
        glfwIconifyWindow(window_.get());
        minimized_ = true;
        break;
    case Event::Kind::Restore:
        glfwRestoreWindow(window_.get());
        minimized_ = false;
        rebuild_ = true;
        break;
    case Event::Kind::Drop:
        if (loading_.valid()) {
            message(event.text + ": still opening " + loadingPath_ + "; drop it again afterwards",
                    kErrorColour);
            break;
        }
        loadingPath_ = event.text;
        message("opening " + event.text + " ...");
        loading_ = std::async(std::launch::async, loader_, event.text, size.x / size.y);
        break;
    case Event::Kind::Screenshot:
        screenshots_.push_back({event.text, true});
        break;
    case Event::Kind::Settle:
        settling_ = true;
        settleStart_ = Clock::now();
        break;
    case Event::Kind::Quit:
        quit_ = true;
        break;
    }
}

void Session::keyPressed(int key) {
    const glm::vec2 size = windowSize();
    engine::RenderSettings render = engine_->settings().render;
    auto& refine = settings_.nodes.refine;
    switch (key) {
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q:
        quit_ = true;
        break;
    case GLFW_KEY_F:
        control_.frame(size);
        break;
    case GLFW_KEY_R:
        control_.reset(model_.camera);
        break;
    case GLFW_KEY_TAB:
        fly_ = !fly_;
        message(fly_ ? "fly mode: the left drag looks around"
                     : "orbit mode: the left drag turns about the model");
        break;
    case GLFW_KEY_SPACE:
        settings_.adaptive = !settings_.adaptive;
        restartEngine();
        break;
    case GLFW_KEY_EQUAL:
    case GLFW_KEY_KP_ADD:
        setThreshold(settings_.threshold * kThresholdStep);
        break;
    case GLFW_KEY_MINUS:
    case GLFW_KEY_KP_SUBTRACT:
        setThreshold(settings_.threshold / kThresholdStep);
        break;
    case GLFW_KEY_N:
        refine.neighbourhood = refine.neighbourhood == NeighbourhoodKind::Fuzzy ? NeighbourhoodKind::Accurate
                                                                                : NeighbourhoodKind::Fuzzy;
        restartEngine();
        break;
    case GLFW_KEY_V: {
        const bool on = !refine.euclideanGeodesic;
        refine.euclideanGeodesic = refine.plainAngle = refine.centroidCandidates = on;
        restartEngine();
        break;
    }
    case GLFW_KEY_G:
        splatPath_ = splatPath_ == engine::RenderPath::Compute ? engine::RenderPath::Graphics
                                                               : engine::RenderPath::Compute;
        if (render.path != engine::RenderPath::PlainPoints) render.path = splatPath_;
        setRender(render, fmt::format("render path: {}",
                                      splatPath_ == engine::RenderPath::Compute ? "compute" : "graphics"));
        break;
    case GLFW_KEY_O:
        render.path =
            render.path == engine::RenderPath::PlainPoints ? splatPath_ : engine::RenderPath::PlainPoints;
        setRender(render, render.path == engine::RenderPath::PlainPoints
                              ? "raw points: each point drawn as one pixel"
                              : "splats");
        break;
    case GLFW_KEY_M:
        render.heatMapPx = render.heatMapPx > 0.0f ? 0.0f : settings_.threshold;
        setRender(render, render.heatMapPx > 0.0f ? "heat map of splat size" : "heat map off");
        break;
    case GLFW_KEY_P:
        screenshots_.push_back({nextScreenshotName(), false});
        break;
    case GLFW_KEY_H:
        help_ = !help_;
        break;
    case GLFW_KEY_I:
        stats_ = !stats_;
        break;
    default:
        break;
    }
}

std::string Session::nextScreenshotName() const {
    for (int k = 1;; ++k) {
        std::string name = fmt::format("pnsplat-{:03}.png", k);
        if (!std::filesystem::exists(name) &&
            std::none_of(screenshots_.begin(), screenshots_.end(),
                         [&](const Screenshot& shot) { return shot.path == name; }))
            return name;
    }
}

void Session::setRender(const engine::RenderSettings& render, const std::string& what) {
    const auto set = engine_->setRenderSettings(render);
    if (!set) {
        message(set.error().message, kErrorColour);
        return;
    }
    settings_.render = render;
    message(what);
}

void Session::setThreshold(float px) {
    px = std::clamp(px, kMinThreshold, kMaxThreshold);
    if (const auto set = engine_->setThreshold(px); !set) {
        message(set.error().message, kErrorColour);
        return;
    }
    settings_.threshold = px;
    engine::RenderSettings render = engine_->settings().render;
    if (render.heatMapPx > 0.0f) {
        render.heatMapPx = px;
        (void)engine_->setRenderSettings(render); // the uniforms only: cannot fail for a positive size
        settings_.render = render;
    }
    message(fmt::format("threshold {:.2f} px", px));
}

// A new engine for `points` with `settings` (the render size of the current one); the current one
// stays when it cannot be made. Its reports are delivered first.
bool Session::startEngine(const PointSet& points, const engine::EngineSettings& settings) {
    engine::EngineSettings s = settings;
    if (engine_) {
        s.render.width = engine_->settings().render.width;
        s.render.height = engine_->settings().render.height;
    }
    auto created = engine::Engine::create(context_, points, s);
    if (!created) {
        message(model_.name + ": " + created.error().message, kErrorColour);
        return false;
    }
    if (engine_) {
        collectReports(true);
        engine_.reset();
        presenter_->finished();
    }
    engine_ = std::move(created).value();
    engineOrigin_ = model_.origin;
    settings_ = s;
    return true;
}

void Session::restartEngine() {
    const auto& refine = settings_.nodes.refine;
    if (startEngine(model_.points, settings_))
        message(fmt::format("refinement {} ({} neighbourhood, {}): restarted from the input",
                            settings_.adaptive ? "on" : "off",
                            refine.neighbourhood == NeighbourhoodKind::Fuzzy ? "fuzzy" : "accurate",
                            refine.euclideanGeodesic ? "faster variants" : "full method"));
}

// A dropped file that has finished loading: its model replaces the current one, or its error shows.
void Session::checkLoad() {
    if (!loading_.valid() || loading_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    try {
        Model model = loading_.get();
        std::swap(model_, model);
        if (startEngine(model_.points, settings_)) {
            control_.reset(model_.camera, model_.bounds);
            glfwSetWindowTitle(window_.get(), ("pnsplat view - " + model_.name).c_str());
            message(fmt::format("{}: {} points", model_.name, model_.points.size()));
        } else {
            std::swap(model_, model); // keep the current model
        }
    } catch (const std::exception& e) {
        message(e.what(), kErrorColour);
    }
}

void Session::collectReports(bool all) {
    if (all) engine_->finish();
    for (const engine::FrameReport& report : engine_->reports()) {
        // Its start, and the next frame's (or now, for the last one).
        while (!starts_.empty() && starts_.front().first < report.frame) starts_.pop_front();
        const Clock::time_point now = Clock::now();
        double ms = 0.0;
        if (!starts_.empty() && starts_.front().first == report.frame) {
            const Clock::time_point end = starts_.size() > 1 ? starts_[1].second : now;
            ms = std::chrono::duration<double, std::milli>(end - starts_.front().second).count();
            starts_.pop_front();
        }
        presenter_->finished(report.frame);
        if (sink_) sink_(report, ms, engineOrigin_);
        recent_.push_back({report, ms, now});
        while (!recent_.empty() && secondsBetween(recent_.front().at, now) > 1.0 && recent_.size() > 2)
            recent_.pop_front();
    }
    if (all) starts_.clear();
}

bool Session::resizeIfNeeded() {
    int width = 0, height = 0;
    glfwGetFramebufferSize(window_.get(), &width, &height);
    const VkExtent2D extent = presenter_->extent();
    if (!rebuild_ && presenter_->ready() && extent.width == std::uint32_t(width) &&
        extent.height == std::uint32_t(height))
        return true;
    rebuild_ = false;
    if (!presenter_->rebuild()) return false; // no area: nothing to draw
    const VkExtent2D size = presenter_->extent();
    engine::RenderSettings render = engine_->settings().render;
    if (render.width != size.width || render.height != size.height) {
        render.width = size.width;
        render.height = size.height;
        const auto set = engine_->setRenderSettings(render);
        if (set) {
            settings_.render = render;
        } else {
            // The device cannot draw this size (its largest buffer or image): the picture keeps its
            // size and the blit scales it to the window.
            render = engine_->settings().render;
            message(fmt::format("{}x{}: {}; drawing at {}x{}, scaled", size.width, size.height,
                                set.error().message, render.width, render.height),
                    kErrorColour);
        }
    }
    presenter_->setCanvas({render.width, render.height});
    return true;
}

void Session::fly(double seconds) {
    glm::vec3 direction{0.0f};
    const auto held = [&](int key) { return keys_.count(key) > 0 ? 1.0f : 0.0f; };
    direction.x = held(GLFW_KEY_D) - held(GLFW_KEY_A);
    direction.y = held(GLFW_KEY_E) - held(GLFW_KEY_C);
    direction.z = held(GLFW_KEY_W) - held(GLFW_KEY_S);
    if (direction == glm::vec3(0.0f)) return;
    const float factor = held(GLFW_KEY_LEFT_SHIFT) + held(GLFW_KEY_RIGHT_SHIFT) > 0.0f ? kShiftFactor : 1.0f;
    control_.fly(direction * factor, float(seconds));
    changed();
}

// Whether frames must be drawn: anything moving, refining, scripted, counted or awaited. A still,
// settled view waits for events instead (a viewer left open costs nothing).
bool Session::busy() const {
    if (script_ || options_.frames > 0 || !options_.screenshot.empty() || !screenshots_.empty() || sink_ ||
        loading_.valid() || !keys_.empty() || message_)
        return true;
    return !settledView_ || quietFrames_ <= engine::kFramesInFlight;
}

std::vector<TextLine> Session::statistics() const {
    std::vector<TextLine> lines;
    const engine::EngineSettings& s = engine_->settings();
    const char* path = s.render.path == engine::RenderPath::Compute    ? "compute path"
                       : s.render.path == engine::RenderPath::Graphics ? "graphics path"
                                                                       : "raw points";
    lines.push_back(
        {fmt::format("{}: {} points, {}, {}x{}", std::filesystem::path(model_.name).filename().string(),
                     model_.points.size(), path, s.render.width, s.render.height),
         kTextColour});
    lines.push_back(
        {fmt::format("{} ({} present)", context_.deviceName(), presenter_->presentModeName()), kDimColour});
    if (recent_.empty()) {
        lines.push_back({"first frames under way ...", kDimColour});
        return lines;
    }
    const engine::FrameReport& r = recent_.back().report;
    double sum = 0.0, points = 0.0;
    for (const Finished& f : recent_) {
        sum += f.ms;
        points += double(f.report.pointsGenerated);
    }
    const double seconds = std::max(1e-3, sum * 1e-3);
    lines.push_back({fmt::format("{:.1f} fps, frame {:.1f} ms: selection {:.1f}, upload {:.1f}",
                                 sum > 0.0 ? double(recent_.size()) / seconds : 0.0, recent_.back().ms,
                                 r.selectionMs, r.uploadMs),
                     kTextColour});
    lines.push_back(
        {fmt::format("passes {:.1f} ms: visibility {:.1f}, accumulation {:.1f}, normalization {:.1f}",
                     r.gpu.visibilityMs + r.gpu.accumulationMs + r.gpu.normalizationMs, r.gpu.visibilityMs,
                     r.gpu.accumulationMs, r.gpu.normalizationMs),
         kTextColour});
    lines.push_back({fmt::format("{} splats drawn ({} nodes)", r.splatsDrawn, r.nodesVisible), kTextColour});
    // The state of the level of detail: moving (the frame-time target may draw coarser), at rest
    // (the target let go: refining to the threshold), settled (the lockstep picture).
    const char* state = r.settled ? "settled" : r.resting ? "at rest, refining" : "moving";
    lines.push_back(
        {fmt::format("threshold {:.2f} px (in force {:.2f}), {}", s.threshold, r.thresholdPx, state),
         kTextColour});
    const auto& refine = s.nodes.refine;
    if (s.adaptive) {
        lines.push_back({fmt::format("refinement on: {} neighbourhood, {}",
                                     refine.neighbourhood == NeighbourhoodKind::Fuzzy ? "fuzzy" : "accurate",
                                     refine.euclideanGeodesic ? "faster variants" : "full method"),
                         kTextColour});
        lines.push_back({fmt::format("{:.0f} points/s, queue {}, tree {} points", points / seconds,
                                     r.queueLength, r.treePoints),
                         kTextColour});
    } else {
        lines.push_back({"refinement off: the input as it is", kTextColour});
    }
    lines.push_back(
        {fmt::format("cache {:.1f} of {:.1f} MiB, {}, {} mode", double(r.cacheBytesUsed) / double(1 << 20),
                     double(s.cacheBytes) / double(1 << 20), r.settled ? "settled" : "refining",
                     fly_ ? "fly" : "orbit"),
         kTextColour});
    if (s.render.heatMapPx > 0.0f)
        lines.push_back(
            {fmt::format("heat map: blue <= {:.2g} px < green < {:.2g} px < yellow < {:.2g} px <= red",
                         s.render.heatMapPx / 4.0f, s.render.heatMapPx, s.render.heatMapPx * 4.0f),
             kTextColour});
    lines.push_back({"H: controls, I: hide this", kDimColour});
    return lines;
}

std::vector<PlacedPanel> Session::panels() const {
    std::vector<PlacedPanel> placed;
    const VkExtent2D size = {engine_->settings().render.width, engine_->settings().render.height};
    // Text scale: the window system's content scale (high-DPI), and twice from 1400 pixels up.
    float xscale = 1.0f, yscale = 1.0f;
    glfwGetWindowContentScale(window_.get(), &xscale, &yscale);
    const int scale = std::max(1, int(std::lround(yscale))) * (size.height >= 1400 ? 2 : 1);
    const int margin = 6 * scale;
    if (stats_) placed.push_back({drawPanel(statistics(), scale), margin, margin});
    if (help_) {
        std::vector<TextLine> lines{{"Controls", kTextColour}};
        for (const auto& [keys, what] : kControls)
            lines.push_back({fmt::format("{:<22} {}", keys, what), kTextColour});
        engine::RgbaImage panel = drawPanel(lines, scale);
        const int x = std::max(margin, int(size.width) - int(panel.width) - margin);
        placed.push_back(
            {std::move(panel), x, stats_ ? int(placed.back().pixels.height) + 2 * margin : margin});
    }
    if (message_ && Clock::now() < message_->until) {
        const std::vector<TextLine> lines{{message_->text, message_->colour}};
        engine::RgbaImage panel = drawPanel(lines, scale);
        const int y = int(size.height) - int(panel.height) - margin;
        placed.push_back({std::move(panel), margin, y});
    }
    return placed;
}

Result<void> Session::writeScreenshot(const std::string& path, const engine::FrameReport& report,
                                      const std::vector<PlacedPanel>& shown) {
    auto image = engine_->image(report.frame);
    if (!image) return image.error();
    if (options_.screenshotOverlay)
        for (const PlacedPanel& panel : shown) paste(*image, panel);
    return engine::writePng(path, *image);
}

Result<ViewerSummary> Session::run() {
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    window_.reset(glfwCreateWindow(int(options_.width), int(options_.height),
                                   ("pnsplat view - " + model_.name).c_str(), nullptr, nullptr));
    if (!window_) return Error{"cannot open a window: " + glfwLastError()};
    glfwSetWindowUserPointer(window_.get(), this);
    glfwSetKeyCallback(window_.get(), onKey);
    glfwSetMouseButtonCallback(window_.get(), onButton);
    glfwSetCursorPosCallback(window_.get(), onCursor);
    glfwSetScrollCallback(window_.get(), onScroll);
    glfwSetDropCallback(window_.get(), onDrop);
    glfwSetWindowIconifyCallback(window_.get(), onIconify);
    glfwSetWindowRefreshCallback(window_.get(), onRefresh);
    if (!options_.script.empty()) {
        auto loaded = Script::load(options_.script);
        if (!loaded) return loaded.error();
        script_ = std::move(loaded).value();
    }
    try {
        presenter_ = std::make_unique<Presenter>(context_, window_.get(), options_.vsync);
        if (!presenter_->rebuild()) return Error{"the window has no area"};
        settings_.render.width = presenter_->extent().width;
        settings_.render.height = presenter_->extent().height;
        auto created = engine::Engine::create(context_, model_.points, settings_);
        if (!created) return Error{model_.name + ": " + created.error().message};
        engine_ = std::move(created).value();
        engineOrigin_ = model_.origin;
        presenter_->setCanvas(presenter_->extent());

        ViewerSummary summary;
        const std::size_t screenshotAfter = std::max<std::size_t>(options_.frames, 1);
        Clock::time_point finalSince{};
        lastTick_ = Clock::now();
        while (!quit_ && !glfwWindowShouldClose(window_.get())) {
            if (busy())
                glfwPollEvents();
            else
                glfwWaitEventsTimeout(kIdleWaitSeconds);
            const Clock::time_point now = Clock::now();
            const double tick = script_ ? kScriptFrameSeconds : std::min(0.1, secondsBetween(lastTick_, now));
            lastTick_ = now;
            for (const Event& event : std::exchange(events_, {})) handle(event);
            if (script_ && !settling_)
                for (const Event& event : script_->take(scriptFrame_)) handle(event);
            if (message_ && now >= message_->until) {
                message_.reset();
                changed();
            }
            checkLoad();
            if (quit_) break;
            if (settling_ && secondsBetween(settleStart_, now) > kSettleSeconds) {
                message(fmt::format("settle: the refinement did not settle in {:.0f} s; the script goes on",
                                    kSettleSeconds),
                        kErrorColour);
                settling_ = false;
            }
            if (minimized_ || !resizeIfNeeded()) {
                // Nothing to draw on; a script's clock goes on.
                glfwWaitEventsTimeout(kScriptFrameSeconds);
                if (script_ && !settling_) ++scriptFrame_;
                continue;
            }
            if (!busy()) continue; // a still, settled view: nothing to draw until something changes
            fly(tick);
            // Input can take the camera where it is no longer one (a zoom to the float spacing far
            // from the origin, an overflowing drag): it stays where it was.
            if (control_.camera().valid())
                lastValidCamera_ = control_.camera();
            else
                control_.reset(lastValidCamera_);

            const bool finalShot = !options_.screenshot.empty() && framesDrawn_ + 1 >= screenshotAfter;
            if (finalShot && finalSince == Clock::time_point{}) finalSince = now;
            const std::vector<PlacedPanel> shown = panels();
            const Clock::time_point start = Clock::now();
            if (!presenter_->acquire()) {
                rebuild_ = true;
                continue;
            }
            engine::FrameOptions frameOptions;
            frameOptions.readBack = finalShot || !screenshots_.empty();
            frameOptions.output.record = [&](VkCommandBuffer cmd, const engine::FrameOutput::Source& source) {
                presenter_->record(cmd, source, shown);
            };
            frameOptions.output.wait = presenter_->wait();
            frameOptions.output.waitStage = VK_PIPELINE_STAGE_TRANSFER_BIT;
            frameOptions.output.signal = presenter_->signal();
            auto drawn = engine_->frame(control_.camera(), frameOptions);
            if (!drawn) return drawn.error();
            const engine::FrameReport& report = *drawn;
            presenter_->submitted(report.frame);
            starts_.emplace_back(report.frame, start);
            if (framesDrawn_ == 0) firstFrame_ = start;
            ++framesDrawn_;
            if (!presenter_->present()) rebuild_ = true;

            for (const Screenshot& shot : std::exchange(screenshots_, {})) {
                if (auto written = writeScreenshot(shot.path, report, shown); !written) {
                    if (shot.fromScript) return written.error();
                    fmt::print(stderr, "pnsplat: {}\n", written.error().message);
                    message(written.error().message, kErrorColour);
                    continue;
                }
                message(fmt::format("screenshot: {} (camera: --camera {})", shot.path,
                                    engine::cameraText(control_.camera(), model_.origin)));
            }
            const bool idle =
                report.nodesRefined == 0 && report.nodesUploaded == 0 && report.queueLength == 0;
            // A threshold in force raised by the frame-time target is not a stall, nor are nodes held
            // by the hysteresis: the camera's rest (half a second) lets both go, and the picture goes
            // on to the settled one (engine.h, FrameReport::resting).
            const bool awaitingRest =
                report.thresholdPx > engine_->settings().threshold || report.heldByHysteresis > 0;
            stalledFrames_ = !report.settled && idle && !awaitingRest ? stalledFrames_ + 1 : 0;
            const bool still = report.settled || stalledFrames_ >= kStalledFrames;
            if (stalledFrames_ == kStalledFrames)
                message(fmt::format(
                            "the refinement stops short of {:.2f} px here: the cache is full (--cache-mb)",
                            engine_->settings().threshold),
                        kErrorColour);
            if (finalShot && (still || secondsBetween(finalSince, Clock::now()) > kSettleSeconds)) {
                if (!still)
                    fmt::print(stderr,
                               "pnsplat: the refinement did not settle in {:.0f} s; writing {} as it is\n",
                               kSettleSeconds, options_.screenshot);
                if (auto written = writeScreenshot(options_.screenshot, report, shown); !written)
                    return written.error();
                quit_ = true;
            }
            // The script's clock stands still while it settles, and for the frame that ends it: the
            // rest of the settle's frame comes next.
            const bool settled = still && settling_ && !loading_.valid();
            if (settled) settling_ = false;
            settledView_ = still && !settling_;
            ++quietFrames_;
            if (script_ && !settling_ && !settled) ++scriptFrame_;
            if (options_.screenshot.empty() && options_.frames > 0 && framesDrawn_ >= options_.frames)
                quit_ = true;
            collectReports(false);
        }
        collectReports(true);
        summary.frames = framesDrawn_;
        summary.seconds = framesDrawn_ > 0 ? secondsBetween(firstFrame_, Clock::now()) : 0.0;
        summary.settings = engine_->settings();
        return summary;
    } catch (const engine::VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    } catch (const std::runtime_error& e) {
        return Error{e.what()};
    }
}

} // namespace

Result<std::unique_ptr<WindowSystem>> WindowSystem::open() {
    glfwSetErrorCallback(onGlfwError);
    if (glfwInit() != GLFW_TRUE)
        return Error{
            fmt::format("view needs a display to open its window, and there is none ({}); offscreen, "
                        "`pnsplat render` draws pictures and `pnsplat bench view` measures frame rates",
                        glfwLastError())};
    if (glfwVulkanSupported() != GLFW_TRUE) {
        glfwTerminate();
        return Error{"view cannot use Vulkan for windows: " + glfwLastError()};
    }
    return std::unique_ptr<WindowSystem>(new WindowSystem());
}

WindowSystem::~WindowSystem() {
    glfwTerminate();
}

std::vector<std::string> WindowSystem::instanceExtensions() const {
    std::uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    return std::vector<std::string>(names, names + count);
}

std::vector<std::string> WindowSystem::deviceExtensions() {
    return {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
}

Result<ViewerSummary> run(WindowSystem&, engine::Context& context, Model model, const ViewerOptions& options,
                          const ModelLoader& loader, const FrameSink& sink) {
    Session session(context, std::move(model), options, loader, sink);
    return session.run();
}

} // namespace pnsplat::viewer
