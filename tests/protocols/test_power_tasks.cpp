// Which replicates `palplab power` runs (protocols/power.hpp ReplicateTasks): the same
// replicates, in the same order, as the explicit list it replaced — per shard, per MPI rank,
// with replicates already done — and enumerated without a list, so that a run of 10^7
// replicates x 10 sizes does not take 1.1 GB before its first replicate (review 2026-12-07).
#include <gtest/gtest.h>

#include <set>
#include <utility>
#include <vector>

#include "protocols/power.hpp"

using namespace palplab::protocols;

namespace {

// The list run_power built before (every rank's share of the shard's missing replicates).
std::vector<std::pair<int, int>> listed(const std::vector<int>& ns, int replicates, int shard,
                                        int shards, const std::set<std::pair<int, int>>& done,
                                        int rank, int ranks, long* total) {
  std::vector<std::pair<int, int>> mine;
  *total = 0;
  for (std::size_t i = 0; i < ns.size(); ++i)
    for (int r = 0; r < replicates; ++r) {
      const long index = static_cast<long>(i) * replicates + r;
      if (index % shards != shard) continue;
      if (done.count({ns[i], r})) continue;
      if ((*total)++ % ranks == rank) mine.push_back({ns[i], r});
    }
  return mine;
}

std::vector<std::pair<int, int>> enumerated(ReplicateTasks& tasks) {
  std::vector<std::pair<int, int>> out;
  for (ReplicateTask t; tasks.next(t);) out.push_back({t.n, t.replicate});
  return out;
}

}  // namespace

TEST(PowerTasks, TheSameReplicatesInTheSameOrderAsTheListTheyReplace) {
  const std::vector<std::vector<int>> sizes = {{3}, {2, 3}, {6, 8, 10, 12}, {5, 2, 9}};
  // Done: some in range, one beyond --replicates, one of a size not asked for.
  const std::set<std::pair<int, int>> done_some = {{2, 0},  {3, 4}, {8, 1}, {9, 2},
                                                   {2, 40}, {7, 0}, {6, 5}};
  for (const auto& ns : sizes)
    for (const int replicates : {1, 2, 5, 7})
      for (const int shards : {1, 2, 3, 5, 40})
        for (int shard = 0; shard < shards; ++shard)
          for (const auto& done : {std::set<std::pair<int, int>>{}, done_some})
            for (const int ranks : {1, 2, 3})
              for (int rank = 0; rank < ranks; ++rank) {
                long total = 0;
                const auto expected =
                    listed(ns, replicates, shard, shards, done, rank, ranks, &total);
                ReplicateTasks tasks(ns, replicates, shard, shards, done, rank, ranks);
                SCOPED_TRACE(::testing::Message()
                             << "sizes " << ns.size() << ", R " << replicates << ", shard " << shard
                             << "/" << shards << ", done " << done.size() << ", rank " << rank
                             << "/" << ranks);
                EXPECT_EQ(tasks.total(), total);
                EXPECT_EQ(tasks.mine(), static_cast<long>(expected.size()));
                EXPECT_EQ(enumerated(tasks), expected);
                ReplicateTask t;
                EXPECT_FALSE(tasks.next(t));  // and stays at the end
              }
}

// The largest count --replicates takes, with ten sizes: counted at once (the old list was 10^8
// entries), the first replicates and the last of each shard where the list had them.
TEST(PowerTasks, AHugeCountIsCountedNotListed) {
  const std::vector<int> ns = {2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  const std::set<std::pair<int, int>> done = {{2, 0}, {2, 2}};
  ReplicateTasks all(ns, 10000000, 0, 1, done);
  EXPECT_EQ(all.total(), 100000000L - 2);
  EXPECT_EQ(all.mine(), 100000000L - 2);
  ReplicateTask t;
  ASSERT_TRUE(all.next(t));
  EXPECT_EQ(t.n, 2);
  EXPECT_EQ(t.replicate, 1);
  ASSERT_TRUE(all.next(t));
  EXPECT_EQ(t.replicate, 3);
  // Shard 3 of 7 on rank 1 of 2: index 10^7 * i + r with index % 7 == 2, every other one.
  ReplicateTasks shard(ns, 10000000, 2, 7, done, 1, 2);
  const long in_shard = 100000000L / 7 + (2 < 100000000L % 7 ? 1 : 0);
  EXPECT_EQ(shard.total(), in_shard - 1);  // (2, 2) is index 2: done
  EXPECT_EQ(shard.mine(), (in_shard - 1) / 2);
  ASSERT_TRUE(shard.next(t));  // index 9 is the first missing (2 done), taken by rank 0; then 16
  EXPECT_EQ(t.n, 2);
  EXPECT_EQ(t.replicate, 16);
}
