#include "pnsplat/engine/image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "pnsplat/refine/io/output_file.h"

namespace pnsplat::engine {

Result<void> writePng(const std::filesystem::path& path, const RgbaImage& image) {
    const std::string name = outputName(path);
    if (image.width == 0 || image.height == 0) return Error{name + ": cannot write an empty image"};
    Result<OutputFile> out = OutputFile::open(path, OutputContent::Binary);
    if (!out) return out.error();
    // stb encodes the whole image, then hands it over (in one call or a few).
    struct Sink {
        OutputFile& file;
        Result<void> written;
    } sink{*out, {}};
    const auto write = [](void* context, void* data, int size) {
        Sink& s = *static_cast<Sink*>(context);
        if (s.written)
            s.written = s.file.write({static_cast<const char*>(data), static_cast<std::size_t>(size)});
    };
    const int stride = static_cast<int>(image.width) * 4;
    if (stbi_write_png_to_func(write, &sink, static_cast<int>(image.width), static_cast<int>(image.height), 4,
                               image.pixels.data(), stride) == 0)
        return Error{name + ": cannot encode the PNG image (out of memory?)"};
    if (!sink.written) return sink.written;
    return out->commit();
}

Result<RgbaImage> readPng(const std::filesystem::path& path) {
    std::error_code error;
    if (!std::filesystem::exists(path, error) && !error) return Error{path.string() + ": no such file"};
    int width = 0, height = 0, channels = 0;
    stbi_uc* data = stbi_load(path.c_str(), &width, &height, &channels, 4);
    if (data == nullptr) {
        const char* reason = stbi_failure_reason();
        return Error{path.string() + ": cannot read the image (" +
                     (reason != nullptr ? reason : "unknown reason") + ")"};
    }
    RgbaImage image(static_cast<std::uint32_t>(width), static_cast<std::uint32_t>(height));
    std::copy(data, data + image.pixels.size(), image.pixels.begin());
    stbi_image_free(data);
    return image;
}

namespace {

// Separable Gaussian blur of a float image with zero weight outside; `out` is normalised by the
// weight inside, so borders are averages over the window's part in the image.
std::vector<double> blur(const std::vector<double>& in, std::uint32_t w, std::uint32_t h) {
    constexpr int kRadius = 5;
    constexpr double kSigma = 1.5;
    std::array<double, 2 * kRadius + 1> kernel{};
    for (int k = -kRadius; k <= kRadius; ++k)
        kernel[k + kRadius] = std::exp(-0.5 * k * k / (kSigma * kSigma));
    std::vector<double> tmp(in.size()), out(in.size());
    const auto pass = [&](const std::vector<double>& src, std::vector<double>& dst, bool horizontal) {
        for (std::uint32_t y = 0; y < h; ++y)
            for (std::uint32_t x = 0; x < w; ++x) {
                double sum = 0.0, weight = 0.0;
                for (int k = -kRadius; k <= kRadius; ++k) {
                    const long sx = horizontal ? long{x} + k : long{x};
                    const long sy = horizontal ? long{y} : long{y} + k;
                    if (sx < 0 || sy < 0 || sx >= long{w} || sy >= long{h}) continue;
                    sum += kernel[k + kRadius] *
                           src[static_cast<std::size_t>(sy) * w + static_cast<std::size_t>(sx)];
                    weight += kernel[k + kRadius];
                }
                dst[std::size_t{y} * w + x] = sum / weight;
            }
    };
    pass(in, tmp, true);
    pass(tmp, out, false);
    return out;
}

glm::u8vec4 heat(int difference) {
    // Black to red over 0..85, red to yellow over 85..170, yellow to white over 170..255.
    const int d = std::clamp(difference * 3, 0, 765);
    return {static_cast<std::uint8_t>(std::min(d, 255)),
            static_cast<std::uint8_t>(std::clamp(d - 255, 0, 255)),
            static_cast<std::uint8_t>(std::clamp(d - 510, 0, 255)), 255};
}

} // namespace

Result<ImageDifference> compareImages(const RgbaImage& a, const RgbaImage& b, int pixelThreshold) {
    if (a.width != b.width || a.height != b.height)
        return Error{"images differ in size: " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                     " and " + std::to_string(b.width) + "x" + std::to_string(b.height)};
    const std::size_t count = std::size_t{a.width} * a.height;
    if (count == 0) return Error{"cannot compare empty images"};

    ImageDifference result;
    result.heatmap = RgbaImage(a.width, a.height);
    double squared = 0.0;
    std::size_t differing = 0;
    std::vector<double> la(count), lb(count);
    for (std::size_t i = 0; i < count; ++i) {
        int largest = 0;
        for (int c = 0; c < 3; ++c) {
            const int d = int{a.pixels[4 * i + c]} - int{b.pixels[4 * i + c]};
            squared += double(d) * d;
            largest = std::max(largest, std::abs(d));
        }
        if (largest > pixelThreshold) ++differing;
        const glm::u8vec4 h = heat(largest);
        std::copy(&h[0], &h[0] + 4, &result.heatmap.pixels[4 * i]);
        const auto luma = [&](const RgbaImage& img) {
            return 0.299 * img.pixels[4 * i] + 0.587 * img.pixels[4 * i + 1] + 0.114 * img.pixels[4 * i + 2];
        };
        la[i] = luma(a);
        lb[i] = luma(b);
    }
    const double mse = squared / (3.0 * double(count));
    result.rmse = std::sqrt(mse);
    result.psnr =
        mse > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
    result.differingShare = double(differing) / double(count);

    // SSIM with the usual constants C1 = (0.01 · 255)², C2 = (0.03 · 255)².
    std::vector<double> aa(count), bb(count), ab(count);
    for (std::size_t i = 0; i < count; ++i) {
        aa[i] = la[i] * la[i];
        bb[i] = lb[i] * lb[i];
        ab[i] = la[i] * lb[i];
    }
    const auto ma = blur(la, a.width, a.height), mb = blur(lb, a.width, a.height);
    const auto saa = blur(aa, a.width, a.height), sbb = blur(bb, a.width, a.height),
               sab = blur(ab, a.width, a.height);
    constexpr double kC1 = 6.5025, kC2 = 58.5225;
    double sum = 0.0;
    for (std::size_t i = 0; i < count; ++i) {
        const double varA = saa[i] - ma[i] * ma[i], varB = sbb[i] - mb[i] * mb[i],
                     cov = sab[i] - ma[i] * mb[i];
        sum += ((2.0 * ma[i] * mb[i] + kC1) * (2.0 * cov + kC2)) /
               ((ma[i] * ma[i] + mb[i] * mb[i] + kC1) * (varA + varB + kC2));
    }
    result.ssim = sum / double(count);
    return result;
}

glm::u8vec3 backgroundPixel(glm::vec3 background) {
    const auto channel = [](float c) {
        // Halves to even (the default rounding mode), as Mesa's packUnorm4x8 and its conversion
        // of a float to an 8-bit unorm target: 0.3 · 255 is 76.5 in single precision, 76.
        return static_cast<std::uint8_t>(std::nearbyint(std::clamp(c, 0.0f, 1.0f) * 255.0f));
    };
    return {channel(background.x), channel(background.y), channel(background.z)};
}

std::size_t coveredPixels(std::span<const std::uint8_t> rgba, glm::u8vec3 background) {
    std::size_t covered = 0;
    for (std::size_t i = 0; i + 3 < rgba.size(); i += 4)
        covered += rgba[i] != background.x || rgba[i + 1] != background.y || rgba[i + 2] != background.z;
    return covered;
}

namespace {

constexpr std::uint32_t kOutside = UINT32_MAX; // not enclosed background (or reached from the border)

// Per pixel: the index of the enclosed background region it belongs to, else kOutside; `regions`
// receives the regions.
std::vector<std::uint32_t> labelEnclosedBackground(const RgbaImage& image, glm::u8vec3 background,
                                                   std::vector<ImageRegion>& regions) {
    const std::uint32_t w = image.width, h = image.height;
    const std::size_t count = std::size_t{w} * h;
    constexpr std::uint32_t kUnvisited = UINT32_MAX - 1;
    std::vector<std::uint32_t> label(count, kOutside);
    if (count == 0) return label;
    for (std::size_t i = 0; i < count; ++i)
        if (image.pixels[4 * i] == background.x && image.pixels[4 * i + 1] == background.y &&
            image.pixels[4 * i + 2] == background.z)
            label[i] = kUnvisited;
    std::vector<std::size_t> stack;
    // Gives every unvisited background pixel 4-connected to `seed` the label `value`; returns the
    // region it filled.
    const auto fill = [&](std::size_t seed, std::uint32_t value) {
        ImageRegion region{0, w, h, 0, 0};
        label[seed] = value;
        stack.push_back(seed);
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            const auto x = static_cast<std::uint32_t>(i % w), y = static_cast<std::uint32_t>(i / w);
            ++region.pixels;
            region.x0 = std::min(region.x0, x);
            region.y0 = std::min(region.y0, y);
            region.x1 = std::max(region.x1, x);
            region.y1 = std::max(region.y1, y);
            const auto visit = [&](std::size_t j) {
                if (label[j] == kUnvisited) {
                    label[j] = value;
                    stack.push_back(j);
                }
            };
            if (x > 0) visit(i - 1);
            if (x + 1 < w) visit(i + 1);
            if (y > 0) visit(i - w);
            if (y + 1 < h) visit(i + w);
        }
        return region;
    };
    // The background reached from the border is not enclosed.
    const auto fromBorder = [&](std::uint32_t x, std::uint32_t y) {
        const std::size_t i = std::size_t{y} * w + x;
        if (label[i] == kUnvisited) fill(i, kOutside);
    };
    for (std::uint32_t x = 0; x < w; ++x) fromBorder(x, 0), fromBorder(x, h - 1);
    for (std::uint32_t y = 0; y < h; ++y) fromBorder(0, y), fromBorder(w - 1, y);
    for (std::size_t i = 0; i < count; ++i)
        if (label[i] == kUnvisited) {
            const auto index = static_cast<std::uint32_t>(regions.size());
            regions.push_back(fill(i, index));
        }
    return label;
}

} // namespace

std::vector<ImageRegion> enclosedBackground(const RgbaImage& image, glm::u8vec3 background) {
    std::vector<ImageRegion> regions;
    labelEnclosedBackground(image, background, regions);
    return regions;
}

Result<std::vector<ImageRegion>>
enclosedBackgroundAbsentIn(const RgbaImage& image, const RgbaImage& reference, glm::u8vec3 background) {
    if (image.width != reference.width || image.height != reference.height)
        return Error{"images differ in size: " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " and " + std::to_string(reference.width) + "x" +
                     std::to_string(reference.height)};
    std::vector<ImageRegion> regions, referenceRegions;
    const std::vector<std::uint32_t> label = labelEnclosedBackground(image, background, regions);
    const std::vector<std::uint32_t> referenceLabel =
        labelEnclosedBackground(reference, background, referenceRegions);
    std::vector<std::uint8_t> shared(regions.size(), 0);
    for (std::size_t i = 0; i < label.size(); ++i)
        if (label[i] != kOutside && referenceLabel[i] != kOutside) shared[label[i]] = 1;
    std::vector<ImageRegion> absent;
    for (std::size_t k = 0; k < regions.size(); ++k)
        if (!shared[k]) absent.push_back(regions[k]);
    return absent;
}

} // namespace pnsplat::engine
