// The viewer's text overlay (docs/VIEWER.md, "Overlay"): lines of text drawn on the CPU into opaque
// panels, which the presenter copies over the picture (and screenshots may include). The glyphs
// are stb_easy_font's (Debian's libstb-dev): ASCII, 6 units to a digit, 12 to a line. No Vulkan and
// no window here. Thread use: any thread; the functions share no state.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <glm/gtc/type_precision.hpp>

#include "pnsplat/engine/image.h"

namespace pnsplat::viewer {

struct TextLine {
    std::string text; // ASCII; other bytes draw nothing
    glm::u8vec3 colour{230, 230, 230};
};

// Colours of the panels.
inline constexpr glm::u8vec3 kPanelBackground{24, 26, 30};
inline constexpr glm::u8vec3 kTextColour{230, 230, 230};
inline constexpr glm::u8vec3 kDimColour{150, 156, 166};
inline constexpr glm::u8vec3 kErrorColour{255, 120, 100};

// The panel of `lines` (at least one) at `scale` pixels per font unit (>= 1): opaque, kPanelBackground
// with a margin of 4 units around the text, 12 units per line, as wide as the widest line.
engine::RgbaImage drawPanel(std::span<const TextLine> lines, int scale);

// A panel and where its top left corner goes in the picture (pixels).
struct PlacedPanel {
    engine::RgbaImage pixels;
    int x = 0, y = 0;
};

// Copies `panel` into `image` at its place; what falls outside `image` is cut off.
void paste(engine::RgbaImage& image, const PlacedPanel& panel);

} // namespace pnsplat::viewer
