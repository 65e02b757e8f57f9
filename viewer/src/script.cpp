#include "pnsplat/viewer/script.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <GLFW/glfw3.h>
#include <fmt/format.h>

namespace pnsplat::viewer {

namespace {

std::string lower(std::string_view text) {
    std::string out(text);
    std::transform(out.begin(), out.end(), out.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return out;
}

// The words of a line up to a `#` that starts a word.
std::vector<std::string> words(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> out;
    std::string word;
    while (in >> word) {
        if (word.front() == '#') break;
        out.push_back(word);
    }
    return out;
}

// The text of `line` after its first `count` words, up to a `#` that starts a word, trimmed (a file
// name with spaces).
std::string rest(const std::string& line, std::size_t count) {
    std::size_t at = 0;
    for (std::size_t k = 0; k < count && at != std::string::npos; ++k) {
        at = line.find_first_not_of(" \t", at);
        at = line.find_first_of(" \t", at);
    }
    if (at == std::string::npos) return {};
    std::string text = line.substr(at);
    for (std::size_t hash = text.find('#'); hash != std::string::npos; hash = text.find('#', hash + 1))
        if (text[hash - 1] == ' ' || text[hash - 1] == '\t') {
            text.erase(hash);
            break;
        }
    const std::size_t begin = text.find_first_not_of(" \t\r");
    if (begin == std::string::npos) return {};
    return text.substr(begin, text.find_last_not_of(" \t\r") + 1 - begin);
}

std::optional<int> buttonCode(std::string_view name) {
    const std::string n = lower(name);
    if (n == "left") return GLFW_MOUSE_BUTTON_LEFT;
    if (n == "right") return GLFW_MOUSE_BUTTON_RIGHT;
    if (n == "middle") return GLFW_MOUSE_BUTTON_MIDDLE;
    return std::nullopt;
}

// The largest frame number and the most events a script may hold (a drag adds one a frame).
constexpr unsigned long long kMaxFrame = 1'000'000'000ull;
constexpr std::size_t kMaxSteps = 1'000'000;

constexpr const char* kCommands = "key, keydown, keyup, move, press, release, drag, wheel, resize, minimize, "
                                  "restore, drop, screenshot, settle, quit";

} // namespace

std::optional<int> keyCode(std::string_view name) {
    if (name.size() == 1) {
        const char c = char(std::toupper(static_cast<unsigned char>(name[0])));
        if (c >= 'A' && c <= 'Z') return GLFW_KEY_A + (c - 'A');
        if (c >= '0' && c <= '9') return GLFW_KEY_0 + (c - '0');
        if (c == '+' || c == '=') return GLFW_KEY_EQUAL;
        if (c == '-') return GLFW_KEY_MINUS;
        return std::nullopt;
    }
    const std::string n = lower(name);
    if (n == "esc" || n == "escape") return GLFW_KEY_ESCAPE;
    if (n == "tab") return GLFW_KEY_TAB;
    if (n == "space") return GLFW_KEY_SPACE;
    if (n == "enter") return GLFW_KEY_ENTER;
    if (n == "shift") return GLFW_KEY_LEFT_SHIFT;
    if (n == "plus") return GLFW_KEY_EQUAL;
    if (n == "minus") return GLFW_KEY_MINUS;
    if (n.size() >= 2 && n.size() <= 3 && n[0] == 'f') {
        char* end = nullptr;
        const long k = std::strtol(n.c_str() + 1, &end, 10);
        if (*end == '\0' && k >= 1 && k <= 12) return GLFW_KEY_F1 + int(k - 1);
    }
    return std::nullopt;
}

Result<Script> Script::parse(std::istream& in, const std::string& name) {
    Script script;
    std::string line;
    std::uint64_t lastFrame = 0;
    std::size_t lastLine = 0;
    for (std::size_t number = 1; std::getline(in, line); ++number) {
        const std::vector<std::string> w = words(line);
        if (w.empty()) continue;
        const auto fail = [&](const std::string& what) {
            return Error{fmt::format("{}:{}: {}", name, number, what)};
        };
        char* end = nullptr;
        const unsigned long long frame = std::strtoull(w[0].c_str(), &end, 10);
        if (*end != '\0' || !std::isdigit(static_cast<unsigned char>(w[0][0])))
            return fail(fmt::format("'{}' is not a frame number (lines read FRAME COMMAND ...)", w[0]));
        if (frame > kMaxFrame) return fail(fmt::format("frame {} is past the last, {}", w[0], kMaxFrame));
        if (lastLine > 0 && frame < lastFrame)
            return fail(fmt::format("frame {} comes after frame {} of line {}: frames must not decrease",
                                    frame, lastFrame, lastLine));
        lastFrame = frame;
        lastLine = number;
        if (w.size() < 2) return fail(fmt::format("frame {} has no command ({})", frame, kCommands));
        const std::string command = lower(w[1]);
        const std::vector<std::string> args(w.begin() + 2, w.end());
        // The arguments as numbers: exactly `count` of them, finite.
        const auto numbers = [&](std::size_t first, std::size_t count, const char* usage,
                                 std::vector<double>& out) -> std::optional<Error> {
            if (args.size() != first + count) return fail(fmt::format("{}: expected {}", command, usage));
            for (std::size_t k = first; k < args.size(); ++k) {
                char* stop = nullptr;
                const double v = std::strtod(args[k].c_str(), &stop);
                if (*stop != '\0' || stop == args[k].c_str() || !std::isfinite(v))
                    return fail(
                        fmt::format("{}: '{}' is not a number (expected {})", command, args[k], usage));
                out.push_back(v);
            }
            return std::nullopt;
        };
        const auto add = [&](std::uint64_t at, Event event) {
            script.steps_.push_back({at, std::move(event)});
        };
        Event event;
        std::vector<double> v;
        if (command == "key" || command == "keydown" || command == "keyup") {
            if (args.size() != 1) return fail(command + ": expected one key name");
            const std::optional<int> code = keyCode(args[0]);
            if (!code)
                return fail(
                    fmt::format("{}: unknown key '{}' (a letter, a digit, +, -, Esc, Tab, Space, Enter, "
                                "Shift, F1 ... F12)",
                                command, args[0]));
            event.kind = Event::Kind::Key;
            event.code = *code;
            event.down = command != "keyup";
            add(frame, event);
            if (command == "key") {
                event.down = false;
                add(frame, event);
            }
        } else if (command == "press" || command == "release") {
            const std::optional<int> button = args.size() == 1 ? buttonCode(args[0]) : std::nullopt;
            if (!button) return fail(command + ": expected a button: left, right or middle");
            event.kind = Event::Kind::Button;
            event.code = *button;
            event.down = command == "press";
            add(frame, event);
        } else if (command == "move" || command == "resize") {
            if (auto error = numbers(0, 2, command == "move" ? "X Y" : "WIDTH HEIGHT", v)) return *error;
            if (command == "resize" && (v[0] < 1.0 || v[1] < 1.0 || v[0] > 16384.0 || v[1] > 16384.0 ||
                                        v[0] != std::floor(v[0]) || v[1] != std::floor(v[1])))
                return fail("resize: the size must be whole numbers from 1 to 16384");
            event.kind = command == "move" ? Event::Kind::Move : Event::Kind::Resize;
            event.position = {v[0], v[1]};
            add(frame, event);
        } else if (command == "wheel") {
            if (auto error = numbers(0, 1, "STEPS", v)) return *error;
            event.kind = Event::Kind::Wheel;
            event.position = {0.0, v[0]};
            add(frame, event);
        } else if (command == "drag") {
            const std::optional<int> button = args.empty() ? std::nullopt : buttonCode(args[0]);
            if (!button)
                return fail("drag: expected BUTTON X0 Y0 X1 Y1 FRAMES (BUTTON: left, right or middle)");
            if (auto error = numbers(1, 5, "BUTTON X0 Y0 X1 Y1 FRAMES", v)) return *error;
            if (v[4] < 1.0 || v[4] != std::floor(v[4]) || v[4] > 1e6)
                return fail("drag: FRAMES must be a whole number of at least 1");
            const auto frames = static_cast<std::uint64_t>(v[4]);
            if (script.steps_.size() + frames > kMaxSteps)
                return fail(fmt::format("drag: the script would hold more than {} events", kMaxSteps));
            const glm::dvec2 from{v[0], v[1]}, to{v[2], v[3]};
            add(frame, Event{Event::Kind::Move, 0, false, from, {}});
            add(frame, Event{Event::Kind::Button, *button, true, {}, {}});
            for (std::uint64_t k = 1; k <= frames; ++k)
                add(frame + k,
                    Event{
                        Event::Kind::Move, 0, false, from + (to - from) * (double(k) / double(frames)), {}});
            add(frame + frames, Event{Event::Kind::Button, *button, false, {}, {}});
        } else if (command == "minimize" || command == "restore" || command == "settle" ||
                   command == "quit") {
            if (!args.empty()) return fail(command + ": takes no arguments");
            event.kind = command == "minimize"  ? Event::Kind::Minimize
                         : command == "restore" ? Event::Kind::Restore
                         : command == "settle"  ? Event::Kind::Settle
                                                : Event::Kind::Quit;
            add(frame, event);
        } else if (command == "drop" || command == "screenshot") {
            event.text = rest(line, 2);
            if (event.text.empty()) return fail(command + ": expected a file name");
            event.kind = command == "drop" ? Event::Kind::Drop : Event::Kind::Screenshot;
            add(frame, event);
        } else {
            return fail(fmt::format("unknown command '{}' (commands: {})", w[1], kCommands));
        }
    }
    std::stable_sort(script.steps_.begin(), script.steps_.end(),
                     [](const Step& a, const Step& b) { return a.frame < b.frame; });
    return script;
}

Result<Script> Script::load(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) return Error{path.string() + ": cannot open the script"};
    return parse(in, path.string());
}

std::vector<Event> Script::take(std::uint64_t frame) {
    std::vector<Event> due;
    while (next_ < steps_.size() && steps_[next_].frame <= frame) {
        due.push_back(steps_[next_++].event);
        if (due.back().kind == Event::Kind::Settle) break; // what follows waits for the settling
    }
    return due;
}

} // namespace pnsplat::viewer
