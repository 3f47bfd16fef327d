// sweep at its boundaries (issue 40): --shard K/N at K == N, and sweep.csv's timing columns,
// the median and the least of the repeats.
#include <gtest/gtest.h>

#include <sstream>

#include "common/errors.h"
#include "sweep/sweep.h"

namespace penumbra::sweep {
namespace {

TEST(SweepBoundaries, TheLastShardIsNOfN) {
    const Shard last = parse_shard("3/3");
    EXPECT_EQ(last.k, 3);
    EXPECT_EQ(last.n, 3);
    EXPECT_EQ(parse_shard("1/1").k, 1);
    EXPECT_THROW(parse_shard("4/3"), InputError);
    EXPECT_THROW(parse_shard("0/3"), InputError);
}

TEST(SweepBoundaries, TheCsvHoldsTheMedianAndTheLeastOfTheRepeats) {
    Table t;
    t.keys = {"resolution"};
    t.columns = {"mae"};
    t.total = 1;
    Row row;
    row.values = {"1024"};
    row.verdict = {0.5};
    row.production_ms = {3.0, 1.0, 2.0};  // median 2, least 1
    row.diagnostic_ms = {5.0, 4.0};       // median 4.5, least 4
    t.rows.push_back(row);
    std::istringstream csv(sweep_csv(t));
    std::string header, line;
    std::getline(csv, header);
    std::getline(csv, line);
    EXPECT_EQ(header, "resolution,mae,production_ms,diagnostic_ms,production_ms_min,diagnostic_ms_min");
    EXPECT_EQ(line, "1024,0.5,2.0000,4.5000,1.0000,4.0000");
}

}  // namespace
}  // namespace penumbra::sweep
