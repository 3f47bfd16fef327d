// One Vulkan context per test suite, under the Khronos validation layer: any message the layer
// gives fails the test that caused it. A device that cannot be opened fails every test of the
// suite: a throw out of SetUpTestSuite would make gtest skip them, and ctest count the skips as
// a pass. `Suite` is the deriving fixture (each suite its own context).
#pragma once

#include <gtest/gtest.h>

#include <exception>
#include <string>

#include "raster/vulkan_context.h"

namespace penumbra::test {

template <class Suite>
class VulkanSuite : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        raster::ContextOptions co;
        co.validation = true;
        try {
            ctx_ = new raster::VulkanContext(co);
        } catch (const std::exception& e) {
            setup_error_ = e.what();
        }
    }
    static void TearDownTestSuite() {
        delete ctx_;
        ctx_ = nullptr;
    }
    void SetUp() override { ASSERT_TRUE(ctx_) << "no Vulkan device: " << setup_error_; }
    void TearDown() override {
        if (!ctx_) return;
        EXPECT_TRUE(ctx_->validation_messages().empty()) << ctx_->validation_messages().front();
    }

    static inline raster::VulkanContext* ctx_ = nullptr;
    static inline std::string setup_error_;
};

}  // namespace penumbra::test
