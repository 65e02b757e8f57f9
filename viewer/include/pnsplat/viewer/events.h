// What the viewer reacts to: the window's input (GLFW callbacks) and the actions of a script
// (script.h) become the same events, handled in order on the render thread (docs/VIEWER.md).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <glm/vec2.hpp>

namespace pnsplat::viewer {

struct Event {
    enum class Kind {
        Key,        // code: a GLFW key (GLFW_KEY_*), down: pressed or released
        Button,     // code: a GLFW mouse button, down: pressed or released (at the cursor)
        Move,       // the cursor to `position`, window coordinates (screen units, origin top left)
        Wheel,      // `position`: the wheel's x and y offsets (y > 0: away from the user, closer)
        Resize,     // the window to `position` (width, height; screen units), as a user would drag it
        Minimize,   // the window minimized (iconified), as by the window manager
        Restore,    // and restored
        Drop,       // `text`: a file dropped on the window
        Screenshot, // script: `text` receives the picture of the next frame drawn
        Settle,     // script: the script's clock stops until the view has settled (and a dropped file loaded)
        Quit,       // close the window
    };
    Kind kind = Kind::Key;
    int code = 0;
    bool down = false;
    glm::dvec2 position{0.0};
    std::string text;
};

// The GLFW key of a key's name in a script: a letter or digit ("W", "7"), "+", "-", or one of Esc,
// Tab, Space, Enter, Shift, Plus, Minus, F1 ... F12 (case-insensitive); nothing for other names.
std::optional<int> keyCode(std::string_view name);

} // namespace pnsplat::viewer
