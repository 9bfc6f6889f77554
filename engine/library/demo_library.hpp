#pragma once
// The built-in default library: clips of a procedural walking skeleton (walk, run, wave, turn),
// clean by construction, so the demo can add known noise and measure what cleaning recovers.
#include <string>
#include <vector>

#include "core/clip.hpp"

namespace mocap::engine {

struct DemoClip {
  std::string relative_path;  // e.g. "walk/walk_120fps.bvh"
  Clip clip;                  // the ground truth
};

// Four clips on two skeletons (one with ZXY channels like Daz exports, one with ZYX like the
// CMU Motionbuilder conversion) at 120 and 30 fps, with root translation.
std::vector<DemoClip> make_demo_library();

}  // namespace mocap::engine
