// OutputTransaction's commit: files land under their names, replacing what was there.
#include "common/output_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "tests/test_support.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

std::string read_all(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void commit_text(const fs::path& dir, const std::string& name, const std::string& text) {
    OutputTransaction out(dir);
    out.write_text(name, text);
    out.commit();
}

std::size_t entries(const fs::path& dir) {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// A second run into the same folder: the old file is removed before the new one is renamed into
// place (ext4 flushes a file renamed over another, common/output_files.cpp).
TEST(OutputTransaction, CommitReplacesTheFileOfAnEarlierRun) {
    TempDir dir;
    commit_text(dir / "out", "a.txt", "first run");
    commit_text(dir / "out", "a.txt", "second");
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "second");
    EXPECT_EQ(entries(dir / "out"), 1u);  // no temporary left behind
}

TEST(OutputTransaction, CommitReplacesASymlinkNotTheFileItPointsTo) {
    TempDir dir;
    fs::create_directories(dir / "out");
    { std::ofstream(dir / "elsewhere.txt") << "keep me"; }
    fs::create_symlink(dir / "elsewhere.txt", dir / "out" / "a.txt");
    commit_text(dir / "out", "a.txt", "new");
    EXPECT_FALSE(fs::is_symlink(dir / "out" / "a.txt"));
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "new");
    EXPECT_EQ(read_all(dir / "elsewhere.txt"), "keep me");
}

TEST(OutputTransaction, WithoutCommitNothingIsReplaced) {
    TempDir dir;
    commit_text(dir / "out", "a.txt", "kept");
    {
        OutputTransaction out(dir / "out");
        out.write_text("a.txt", "abandoned");
    }
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "kept");
    EXPECT_EQ(entries(dir / "out"), 1u);
}

}  // namespace
}  // namespace penumbra
