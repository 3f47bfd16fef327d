// OutputTransaction's commit: files land under their names, replacing what was there.
#include "common/output_files.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "common/errors.h"
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

// A second run into the same folder: the new file is swapped with the old one (ext4 flushes a
// file renamed over another, common/output_files.cpp) and the old one removed.
TEST(OutputTransaction, CommitReplacesTheFileOfAnEarlierRun) {
    TempDir dir;
    commit_text(dir / "out", "a.txt", "first run");
    commit_text(dir / "out", "a.txt", "second");
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "second");
    EXPECT_EQ(entries(dir / "out"), 1u);  // no temporary left behind
}

// A symbolic link where an output goes is the user's: refused (exit 2) and left, never followed
// nor replaced (#50).
TEST(OutputTransaction, CommitRefusesASymlinkAndLeavesWhatItPointsTo) {
    TempDir dir;
    fs::create_directories(dir / "out");
    { std::ofstream(dir / "elsewhere.txt") << "keep me"; }
    fs::create_symlink(dir / "elsewhere.txt", dir / "out" / "a.txt");
    EXPECT_THROW(commit_text(dir / "out", "a.txt", "new"), InputError);
    EXPECT_TRUE(fs::is_symlink(dir / "out" / "a.txt"));
    EXPECT_EQ(read_all(dir / "elsewhere.txt"), "keep me");
    EXPECT_EQ(entries(dir / "out"), 1u);  // the temporary went too
}

// A link planted at the name a temporary used to have (.NAME.tmp-PID) is never written through:
// temporaries have unpredictable names and are created with O_EXCL|O_NOFOLLOW.
TEST(OutputTransaction, APlantedTemporaryNameIsNotFollowed) {
    TempDir dir;
    fs::create_directories(dir / "out");
    { std::ofstream(dir / "elsewhere.txt") << "keep me"; }
    fs::create_symlink(dir / "elsewhere.txt", dir / "out" / fmt::format(".a.txt.tmp-{}", ::getpid()));
    commit_text(dir / "out", "a.txt", "new");
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "new");
    EXPECT_EQ(read_all(dir / "elsewhere.txt"), "keep me");
}

TEST(ExclusiveTemporary, NamesAreFreshAndRegular) {
    TempDir dir;
    const ExclusiveTemporary a = create_exclusive_temporary(dir.path(), "x.bin");
    const ExclusiveTemporary b = create_exclusive_temporary(dir.path(), "x.bin");
    ::close(a.fd);
    ::close(b.fd);
    EXPECT_NE(a.path, b.path);
    EXPECT_TRUE(a.path.filename().string().starts_with(fmt::format(".x.bin.tmp-{}-", ::getpid())));
    EXPECT_TRUE(is_same_file(a.path, a.device, a.inode));
    EXPECT_FALSE(is_same_file(b.path, a.device, a.inode));
    remove_if_same_file(b.path, a.device, a.inode);  // not the file a made: stays
    EXPECT_TRUE(fs::exists(b.path));
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

// All or nothing: a folder where one output goes fails the commit before any file moves, and
// the earlier run's files stay as they were.
TEST(OutputTransaction, AFolderInTheWayFailsTheCommitBeforeAnythingMoves) {
    TempDir dir;
    OutputTransaction first(dir / "out");
    first.write_text("a.txt", "old a");
    first.write_text("z.txt", "old z");
    first.commit();
    fs::create_directory(dir / "out" / "m.txt");
    {
        OutputTransaction second(dir / "out");
        second.write_text("a.txt", "new a");
        second.write_text("m.txt", "new m");
        second.write_text("z.txt", "new z");
        EXPECT_THROW(second.commit(), InputError);
    }
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "old a");
    EXPECT_EQ(read_all(dir / "out" / "z.txt"), "old z");
    EXPECT_TRUE(fs::is_directory(dir / "out" / "m.txt"));
    EXPECT_EQ(entries(dir / "out"), 3u);  // the temporaries went with the transaction
}

// The same name staged twice is one file: moved into place once, with the last text.
TEST(OutputTransaction, StagingANameTwiceWritesItOnce) {
    TempDir dir;
    commit_text(dir / "out", "a.txt", "first run");
    OutputTransaction out(dir / "out");
    out.write_text("a.txt", "one");
    out.write_text("a.txt", "two");
    out.commit();
    EXPECT_EQ(read_all(dir / "out" / "a.txt"), "two");
    EXPECT_EQ(entries(dir / "out"), 1u);
}

// Ctrl-C or a kill while outputs are being written: the temporaries and the folder the run made
// are removed, and the signal still ends the process.
TEST(OutputTransaction, AnInterruptRemovesTemporariesAndTheFolderItMade) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    TempDir dir;
    for (int sig : {SIGINT, SIGTERM}) {
        const fs::path out_dir = dir / ("out" + std::to_string(sig));
        fs::create_directories(out_dir);
        EXPECT_EXIT(
            {
                install_interrupt_cleanup();
                OutputTransaction out(out_dir / "nested");
                out.write_text("report.json", std::string(1 << 20, 'x'));
                out.write_text("report.html", "<html>");
                std::raise(sig);
                out.commit();  // never reached
            },
            testing::KilledBySignal(sig), "");
        EXPECT_TRUE(fs::is_directory(out_dir)) << "a folder that existed before stays";
        EXPECT_FALSE(fs::exists(out_dir / "nested")) << "the folder the run made is removed";
    }
    // Into a folder that existed: only the temporaries go.
    fs::create_directories(dir / "kept");
    commit_text(dir / "kept", "old.txt", "old");
    EXPECT_EXIT(
        {
            install_interrupt_cleanup();
            OutputTransaction out(dir / "kept");
            out.write_text("new.txt", "new");
            std::raise(SIGTERM);
        },
        testing::KilledBySignal(SIGTERM), "");
    EXPECT_EQ(read_all(dir / "kept" / "old.txt"), "old");
    EXPECT_EQ(entries(dir / "kept"), 1u);
}

TEST(OutputFolder, ProblemsAreFoundBeforeAnyWork) {
    TempDir dir;
    EXPECT_EQ(output_folder_problem((dir / "new" / "deeper").string()), "");
    fs::create_directories(dir / "there");
    EXPECT_EQ(output_folder_problem((dir / "there").string()), "");
    EXPECT_NE(output_folder_problem("").find("empty"), std::string::npos);
    { std::ofstream(dir / "file") << "x"; }
    EXPECT_NE(output_folder_problem((dir / "file").string()).find("exists and is not a folder"), std::string::npos);
    EXPECT_NE(output_folder_problem((dir / "file" / "below").string()).find("is not a folder"), std::string::npos);
    EXPECT_NE(output_folder_problem("/proc/penumbra-out").find("cannot write into /proc"), std::string::npos);
    EXPECT_TRUE(fs::is_empty(dir / "there")) << "the write check leaves nothing behind";
}

}  // namespace
}  // namespace penumbra
