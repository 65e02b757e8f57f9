#include "pnsplat/engine/splat_scene.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <span>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "gpu_types.h"

namespace pnsplat::engine {

namespace {

// Spreads the low 10 bits of v to every third bit.
std::uint32_t spread(std::uint32_t v) {
    v &= 0x3FFu;
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

Sphere boundingSphere(std::span<const glm::vec3> positions, const std::uint32_t* order, std::size_t count) {
    glm::vec3 lo(positions[order[0]]), hi(lo);
    for (std::size_t k = 1; k < count; ++k) {
        lo = glm::min(lo, positions[order[k]]);
        hi = glm::max(hi, positions[order[k]]);
    }
    Sphere sphere{(lo + hi) * 0.5f, 0.0f};
    for (std::size_t k = 0; k < count; ++k)
        sphere.radius = std::max(sphere.radius, glm::length(positions[order[k]] - sphere.centre));
    return sphere;
}

} // namespace

Result<SplatScene> SplatScene::create(Context& context, const PointSet& points) {
    const std::size_t count = points.size();
    if (count > 0 && (points.normal.size() != count || points.radius.size() != count))
        return Error{"splat scene: every point needs a normal and a radius"};
    const VkDeviceSize bytes = std::max<std::size_t>(count, 1) * sizeof(gpu::Splat);
    if (bytes > context.properties().limits.maxStorageBufferRange)
        return Error{std::to_string(count) + " splats exceed the device's storage buffer range of " +
                     std::to_string(context.properties().limits.maxStorageBufferRange / sizeof(gpu::Splat)) +
                     " splats"};

    SplatScene scene;
    scene.size_ = count;
    std::vector<std::uint32_t> order(count);
    std::iota(order.begin(), order.end(), 0u);
    std::vector<std::uint32_t> code(count);
    if (count > 0) {
        scene.bounds_ = boundingSphere(points.position, order.data(), count);
        const Sphere& bounds = scene.bounds_;
        if (!std::isfinite(bounds.radius) || !std::isfinite(bounds.centre.x) ||
            !std::isfinite(bounds.centre.y) || !std::isfinite(bounds.centre.z))
            return Error{"the points spread farther than can be measured (their bounding sphere overflows "
                         "3.4e38); scale the model down"};
        // Morton codes on a 1024³ grid over the bounding cube; ties keep input order.
        const glm::vec3 lo = scene.bounds_.centre - glm::vec3(scene.bounds_.radius);
        const float scale = scene.bounds_.radius > 0.0f ? 1023.0f / (2.0f * scene.bounds_.radius) : 0.0f;
        for (std::size_t i = 0; i < count; ++i) {
            const glm::vec3 g =
                glm::clamp((points.position[i] - lo) * scale, glm::vec3(0.0f), glm::vec3(1023.0f));
            code[i] = spread(static_cast<std::uint32_t>(g.x)) | spread(static_cast<std::uint32_t>(g.y)) << 1 |
                      spread(static_cast<std::uint32_t>(g.z)) << 2;
        }
        std::stable_sort(order.begin(), order.end(),
                         [&](std::uint32_t a, std::uint32_t b) { return code[a] < code[b]; });
    }

    std::vector<gpu::Splat> splats(std::max<std::size_t>(count, 1), gpu::Splat{});
    for (std::size_t k = 0; k < count; ++k) {
        const std::uint32_t i = order[k];
        std::uint32_t colour = kDefaultColour;
        if (points.hasColour()) {
            const glm::u8vec3 c = points.colour[i];
            colour = std::uint32_t{c.x} | std::uint32_t{c.y} << 8 | std::uint32_t{c.z} << 16;
        }
        splats[k] = {points.position[i], points.radius[i], points.normal[i], colour};
        scene.maxRadius_ = std::max(scene.maxRadius_, points.radius[i]);
    }
    // Nodes: the cells of an octree over the Morton codes, split until a cell holds at most
    // kChunkSize splats (cells are contiguous ranges of the sorted order, and compact in space, so
    // their bounding spheres cull well); a full-depth cell with more is cut by count.
    std::vector<std::uint32_t> sortedCode(count);
    for (std::size_t k = 0; k < count; ++k) sortedCode[k] = code[order[k]];
    const auto addNode = [&](std::size_t first, std::size_t n) {
        scene.nodes_.push_back({boundingSphere(points.position, order.data() + first, n),
                                static_cast<std::uint32_t>(first), static_cast<std::uint32_t>(n)});
    };
    const auto split = [&](const auto& self, std::size_t begin, std::size_t end, int shift) -> void {
        if (end - begin <= gpu::kChunkSize || shift < 0) {
            for (std::size_t first = begin; first < end; first += gpu::kChunkSize)
                addNode(first, std::min<std::size_t>(gpu::kChunkSize, end - first));
            return;
        }
        std::size_t first = begin;
        while (first < end) {
            const std::uint32_t cell = sortedCode[first] >> shift;
            std::size_t last = first;
            while (last < end && (sortedCode[last] >> shift) == cell) ++last;
            self(self, first, last, shift - 3);
            first = last;
        }
    };
    if (count > 0) split(split, 0, count, 27);
    try {
        scene.buffer_ = createBuffer(context, bytes,
                                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                     MemoryUse::Device);
        upload(context, scene.buffer_, splats.data(), bytes);
    } catch (const VulkanError& e) {
        return Error{std::string("Vulkan: ") + e.what()};
    }
    return scene;
}

} // namespace pnsplat::engine
