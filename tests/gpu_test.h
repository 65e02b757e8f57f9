// The Vulkan context of the GPU tests: one per test program, on lavapipe where no GPU exists, with
// the validation layer loaded. GpuTest fails any test during which the layer reported a message.
#pragma once

#include <memory>

#include <gtest/gtest.h>

#include "pnsplat/engine/context.h"
#include "pnsplat/engine/engine.h"
#include "pnsplat/engine/image.h"

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

    // Renders `points` (normals and radii filled) as they are (the engine without refinement) with
    // `settings` from `camera`; fails the test on error. `report` receives the frame's report.
    engine::RgbaImage render(const PointSet& points, const engine::RenderSettings& settings,
                             const engine::Camera& camera, engine::FrameReport* report = nullptr) {
        engine::EngineSettings engineSettings;
        engineSettings.render = settings;
        engineSettings.adaptive = false;
        auto engine = engine::Engine::create(context(), points, engineSettings);
        EXPECT_TRUE(engine.ok()) << engine.error().message;
        if (!engine) return {};
        return frameOf(**engine, camera, report);
    }

  public:
    // One frame of `engine`, read back; fails the test on error.
    engine::RgbaImage frameOf(engine::Engine& engine, const engine::Camera& camera,
                              engine::FrameReport* report = nullptr, bool lockstep = true) {
        engine::FrameOptions options;
        options.readBack = true;
        options.lockstep = lockstep;
        auto drawn = engine.frame(camera, options);
        EXPECT_TRUE(drawn.ok()) << drawn.error().message;
        if (!drawn) return {};
        if (report != nullptr) *report = *drawn;
        auto image = engine.image(drawn->frame);
        EXPECT_TRUE(image.ok()) << image.error().message;
        return image ? std::move(image).value() : engine::RgbaImage{};
    }

  private:
    std::uint32_t messagesBefore_ = 0;
};

} // namespace pnsplat::test
