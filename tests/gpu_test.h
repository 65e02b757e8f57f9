// The Vulkan context of the GPU tests: one per test program, on lavapipe where no GPU exists, with
// the validation layer loaded. GpuTest fails any test during which the layer reported a message.
#pragma once

#include <memory>

#include <gtest/gtest.h>

#include "pnsplat/engine/context.h"
#include "pnsplat/engine/image.h"
#include "pnsplat/engine/splat_renderer.h"

namespace pnsplat::test {

// Creating the context is part of what is tested: failure fails the calling test.
inline engine::Context* gpuContext() {
    static std::unique_ptr<engine::Context> context = [] {
        engine::ContextOptions options;
        options.validation = true;
        auto created = engine::Context::create(options);
        if (!created) ADD_FAILURE() << created.error().message;
        return created ? std::move(created).value() : nullptr;
    }();
    return context.get();
}

class GpuTest : public ::testing::Test {
  protected:
    void SetUp() override {
        ASSERT_NE(gpuContext(), nullptr);
        messagesBefore_ = gpuContext()->validationMessages();
    }
    void TearDown() override {
        if (gpuContext() != nullptr) {
            EXPECT_EQ(gpuContext()->validationMessages(), messagesBefore_)
                << "validation: " << gpuContext()->lastValidationMessage();
        }
    }
    engine::Context& context() { return *gpuContext(); }

    // Renders `points` (normals and radii filled) with `settings` from `camera`; fails the test on error.
    engine::RgbaImage render(const PointSet& points, const engine::RenderSettings& settings,
                             const engine::Camera& camera, engine::FrameStats* stats = nullptr) {
        auto scene = engine::SplatScene::create(context(), points);
        EXPECT_TRUE(scene.ok()) << scene.error().message;
        if (!scene) return {};
        auto renderer = engine::SplatRenderer::create(context(), settings);
        EXPECT_TRUE(renderer.ok()) << renderer.error().message;
        if (!renderer) return {};
        auto image = (*renderer)->render(*scene, camera, stats);
        EXPECT_TRUE(image.ok()) << image.error().message;
        return image ? std::move(image).value() : engine::RgbaImage{};
    }

  private:
    std::uint32_t messagesBefore_ = 0;
};

} // namespace pnsplat::test
