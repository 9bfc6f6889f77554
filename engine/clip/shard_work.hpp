#pragma once
// A clip's filter work cut into shards the task graph runs in parallel: joint blocks for the
// per-joint methods, time blocks for nlpm. Shards of one clip write disjoint parts of its output.
#include <vector>

#include "core/clip.hpp"
#include "core/status.hpp"
#include "engine/clip/filter_settings.hpp"

namespace mocap::engine {

struct Shard {
  int joint_begin = 0, joint_end = -1;
  int frame_begin = 0, frame_end = -1;
};

// The output slices of a clip: joint blocks for per-joint methods, time blocks for nlpm.
std::vector<Shard> plan_shards(const FilterSettings& settings, int frames, int joints);

// Writes `shard` of `output` (already sized like input) from `input`.
Status run_shard(const ResolvedSettings& resolved, const Clip& input, Clip& output,
                 const Shard& shard);

}  // namespace mocap::engine
