// 8-bit RGBA images on the CPU: what the renderer reads back, PNG files in and out, and the
// comparison behind `pnsplat diff`. No Vulkan here.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include <glm/gtc/type_precision.hpp>

#include "pnsplat/refine/result.h"

namespace pnsplat::engine {

struct RgbaImage {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> pixels; // RGBA, rows top to bottom, 4 · width · height bytes

    RgbaImage() = default;
    RgbaImage(std::uint32_t w, std::uint32_t h) : width(w), height(h), pixels(std::size_t{4} * w * h, 0) {}
    glm::u8vec4 at(std::uint32_t x, std::uint32_t y) const {
        const std::uint8_t* p = &pixels[(std::size_t{y} * width + x) * 4];
        return {p[0], p[1], p[2], p[3]};
    }
};

// Writes an RGBA PNG through OutputFile (refine/io/output_file.h): complete or not at all, "-" for
// standard output, links followed, devices and pipes written through, never to a terminal.
Result<void> writePng(const std::filesystem::path& path, const RgbaImage& image);
// Reads any PNG (converted to RGBA); a one-line error names the file.
Result<RgbaImage> readPng(const std::filesystem::path& path);

struct ImageDifference {
    double rmse = 0.0;           // over R, G, B, in 0..255 units
    double psnr = 0.0;           // dB over R, G, B; +infinity for identical images
    double ssim = 1.0;           // mean SSIM of luma (11×11 Gaussian window, σ 1.5; Wang et al. 2004)
    double differingShare = 0.0; // share of pixels whose largest channel difference exceeds the threshold
    RgbaImage heatmap;           // per-pixel largest difference: black (none), red, yellow, white (255)
};

// Compares two images of the same size (else an error). Alpha is ignored.
Result<ImageDifference> compareImages(const RgbaImage& a, const RgbaImage& b, int pixelThreshold = 2);

// The pixel the renderer writes where no splat is (RenderSettings::background, sRGB in [0, 1]):
// each channel c · 255 rounded to the nearest integer, halves to even, in single precision. Both
// paths write this very pixel (gpu::FrameUniforms::picture), whatever the device's own rounding.
glm::u8vec3 backgroundPixel(glm::vec3 background);

// The pixels of an RGBA8 picture (4 bytes a pixel: RgbaImage::pixels, or a read-back buffer) whose
// colour (R, G, B) is not `background`: those a splat covers.
std::size_t coveredPixels(std::span<const std::uint8_t> rgba, glm::u8vec3 background);

// A 4-connected set of pixels: its size and its bounding box (inclusive).
struct ImageRegion {
    std::size_t pixels = 0;
    std::uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// Enclosed background: the 4-connected regions of pixels of colour `background` (R, G, B exactly;
// alpha ignored) that no path of background pixels joins to the image's border (a flood fill from
// the border). Holes in a surface show as such regions, and so do openings the model itself
// encloses. In the order of their first pixel (rows top to bottom); none in an empty image.
std::vector<ImageRegion> enclosedBackground(const RgbaImage& image, glm::u8vec3 background);

// The enclosed background regions of `image` that `reference` lacks: those with no pixel in an
// enclosed background region of `reference` (images of the same size, else an error). A hole of
// a rendering that the reference picture does not show.
Result<std::vector<ImageRegion>>
enclosedBackgroundAbsentIn(const RgbaImage& image, const RgbaImage& reference, glm::u8vec3 background);

} // namespace pnsplat::engine
