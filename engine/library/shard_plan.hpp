#pragma once
// Splitting a library's clips across processes (scheduler array tasks or MPI ranks) by cost.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "engine/run/clip_source.hpp"

namespace mocap::engine {

struct ShardSpec {
  int index = 0;  // I in [0, N)
  int count = 1;  // N
  bool active() const { return count > 1; }
  std::string tag() const;  // "s<I>of<N>", names this shard's part files
};

// "I/N" with 0 <= I < N; nullopt (and a reason) otherwise.
std::optional<ShardSpec> parse_shard(const std::string& text, std::string* error);

// The source indices of shard `spec` among `candidates`: longest-processing-time-first over the
// clips' costs (frames x joints; ties broken by index), so shards finish close together. The
// same candidates give the same split in every process; sorted by index.
std::vector<std::size_t> shard_selection(const ClipSource& source,
                                         const std::vector<std::size_t>& candidates,
                                         ShardSpec spec);

}  // namespace mocap::engine
