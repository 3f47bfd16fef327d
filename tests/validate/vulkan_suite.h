// One Vulkan context per test suite, under the Khronos validation layer: any message the layer
// gives fails the test that caused it. A device that cannot be opened fails every test of the
// suite: a throw out of SetUpTestSuite would make gtest skip them, and ctest count the skips as
// a pass. `Suite` is the deriving fixture (each suite its own context).
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <exception>
#include <string>

#include "pipeline/validate.h"
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

    // validate() of `sc` with `technique_json` in a session of its own, without the cache; prints
    // each light's scored pixels and class counts (the numbers the docs quote).
    static ValidateResult judge(const Scenario& sc, const nlohmann::json& technique_json) {
        const raster::Technique technique = raster::parse_technique(technique_json, "test: technique");
        ValidateOptions options;
        options.use_cache = false;
        raster::RasterSession session(sc, *ctx_);
        ValidateResult r = validate(sc, technique, metrics::Gate{}, options, &session, nullptr);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
            const metrics::LightScore& l = r.score.lights[li];
            std::string counts;
            for (metrics::PixelClass c : metrics::kErrorClasses)
                counts += fmt::format(", {} {}", metrics::to_string(c), l.count(c));
            std::printf("  [%s %s] light %zu scored %llu%s\n",
                        ::testing::UnitTest::GetInstance()->current_test_info()->name(), technique_json.dump().c_str(),
                        li, static_cast<unsigned long long>(l.pixels.scored), counts.c_str());
        }
        return r;
    }

    static inline raster::VulkanContext* ctx_ = nullptr;
    static inline std::string setup_error_;
};

}  // namespace penumbra::test
