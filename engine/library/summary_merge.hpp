#pragma once
// Sums of the per-run tallies of a --json summary over the ranks of an MPI run: pops, garbage
// joints and automatic parameters are counted by each rank over its own clips.
#include <nlohmann/json.hpp>

namespace mocap::engine {

// Adds `from`'s "pops", "garbage_joints", "automatic" and "stages" fields
// (ConditioningTally::write_to, AutomaticTally::write_to, StageTimes) into `into`'s; every other
// field of `into` is kept as it is (the ranks share the command, parameters and output).
void merge_tallies(nlohmann::json& into, const nlohmann::json& from);

}  // namespace mocap::engine
