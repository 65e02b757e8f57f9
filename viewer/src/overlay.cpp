#include "pnsplat/viewer/overlay.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>

#include <stb_easy_font.h>

namespace pnsplat::viewer {

namespace {

constexpr int kMargin = 4;      // font units around the text
constexpr int kLineHeight = 12; // font units from one line to the next

// stb_easy_font_print's vertex: x, y, z and an RGBA colour; four to a quad.
struct FontVertex {
    float x, y, z;
    unsigned char rgba[4];
};

// The text stb_easy_font can draw: it indexes a table of the 95 printable ASCII characters by the
// byte, so any other byte (UTF-8 in a file name, a tab) becomes '?'.
std::string printable(const std::string& text) {
    std::string out = text;
    for (char& c : out)
        if (c != '\n' && (c < 32 || c > 126)) c = '?';
    return out;
}

} // namespace

engine::RgbaImage drawPanel(std::span<const TextLine> lines, int scale) {
    assert(!lines.empty() && scale >= 1);
    int widthUnits = 0;
    for (const TextLine& line : lines) {
        std::string text = printable(line.text);
        widthUnits = std::max(widthUnits, stb_easy_font_width(text.data()));
    }
    const int width = (widthUnits + 2 * kMargin) * scale;
    const int height = (int(lines.size()) * kLineHeight + 2 * kMargin - 2) * scale;
    engine::RgbaImage panel{static_cast<std::uint32_t>(width), static_cast<std::uint32_t>(height)};
    for (std::size_t i = 0; i < panel.pixels.size(); i += 4) {
        panel.pixels[i] = kPanelBackground.x;
        panel.pixels[i + 1] = kPanelBackground.y;
        panel.pixels[i + 2] = kPanelBackground.z;
        panel.pixels[i + 3] = 255;
    }
    std::vector<FontVertex> quads;
    for (std::size_t k = 0; k < lines.size(); ++k) {
        std::string text = printable(lines[k].text);
        // About 270 bytes a character (stb_easy_font.h); four vertices per quad.
        quads.resize(text.size() * 300 / sizeof(FontVertex) + 4);
        const int count =
            stb_easy_font_print(float(kMargin), float(kMargin + int(k) * kLineHeight), text.data(), nullptr,
                                quads.data(), int(quads.size() * sizeof(FontVertex)));
        for (int q = 0; q < count; ++q) {
            // Each quad is an axis-aligned rectangle of whole font units.
            const FontVertex* v = &quads[std::size_t(q) * 4];
            const float x0 = std::min(v[0].x, v[2].x), x1 = std::max(v[0].x, v[2].x);
            const float y0 = std::min(v[0].y, v[2].y), y1 = std::max(v[0].y, v[2].y);
            const int px0 = std::max(0, int(std::lround(x0 * float(scale))));
            const int px1 = std::min(width, int(std::lround(x1 * float(scale))));
            const int py0 = std::max(0, int(std::lround(y0 * float(scale))));
            const int py1 = std::min(height, int(std::lround(y1 * float(scale))));
            for (int y = py0; y < py1; ++y)
                for (int x = px0; x < px1; ++x) {
                    std::uint8_t* p =
                        &panel.pixels[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4];
                    p[0] = lines[k].colour.x;
                    p[1] = lines[k].colour.y;
                    p[2] = lines[k].colour.z;
                }
        }
    }
    return panel;
}

void paste(engine::RgbaImage& image, const PlacedPanel& panel) {
    const int x0 = std::max(0, panel.x), y0 = std::max(0, panel.y);
    const int x1 = std::min(int(image.width), panel.x + int(panel.pixels.width));
    const int y1 = std::min(int(image.height), panel.y + int(panel.pixels.height));
    if (x0 >= x1 || y0 >= y1) return;
    for (int y = y0; y < y1; ++y) {
        const std::uint8_t* from =
            &panel.pixels
                 .pixels[(std::size_t(y - panel.y) * panel.pixels.width + std::size_t(x0 - panel.x)) * 4];
        std::uint8_t* to = &image.pixels[(std::size_t(y) * image.width + std::size_t(x0)) * 4];
        std::memcpy(to, from, std::size_t(x1 - x0) * 4);
    }
}

} // namespace pnsplat::viewer
