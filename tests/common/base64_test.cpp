// base64_encode (data: URIs in report.html) against RFC 4648's test vectors (section 10): every
// tail length, so the padding of a 1- and a 2-byte tail is pinned.
#include <gtest/gtest.h>

#include "common/output_files.h"

namespace penumbra {
namespace {

TEST(Base64, MatchesTheRfc4648TestVectors) {
    EXPECT_EQ(base64_encode(""), "");
    EXPECT_EQ(base64_encode("f"), "Zg==");
    EXPECT_EQ(base64_encode("fo"), "Zm8=");
    EXPECT_EQ(base64_encode("foo"), "Zm9v");
    EXPECT_EQ(base64_encode("foob"), "Zm9vYg==");
    EXPECT_EQ(base64_encode("fooba"), "Zm9vYmE=");
    EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
    EXPECT_EQ(base64_encode(std::string_view("\xff\xfe\x00", 3)), "//4A");
}

}  // namespace
}  // namespace penumbra
