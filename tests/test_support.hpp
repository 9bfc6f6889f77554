#pragma once
// Shared helpers of the test suite: where the real clips are, random motions, comparisons.
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "core/tensor.hpp"

namespace mocap::test {

// ../shared/data/bvh beside the project, or an empty path when it is absent.
std::filesystem::path shared_bvh_dir();
// The .bvh files of ../shared/data/bvh, sorted; empty when absent.
std::vector<std::filesystem::path> shared_bvh_files();

// Skip the current test with a clear message when ../shared/data/bvh is absent.
#define MOCAP_REQUIRE_SHARED_CLIPS()                                                             \
  do {                                                                                           \
    if (::mocap::test::shared_bvh_files().empty())                                               \
      GTEST_SKIP() << "../shared/data/bvh not found beside the project: real-clip test skipped"; \
  } while (0)

// A random unit quaternion, uniform on SO(3).
Quat random_rotation(std::mt19937_64& rng);
// A rotation tensor [F][J][4] that owns its samples, with views of it.
struct Motion {
  int frames = 0, joints = 0;
  std::vector<float> rotations;
  RotationView view() const { return {rotations.data(), frames, joints}; }
  RotationSpan span() { return {rotations.data(), frames, joints}; }
  Quat at(int t, int j) const { return load_quat(view().at(t, j)); }
};

// Frames first, first + stride, ... of `rotations`, `frames` of them, as a motion of their own
// (a lower frame rate of a clip, in the pop tests).
Motion every_nth_frame(RotationView rotations, int first, int stride, int frames);

// A smooth random motion [F][J][4]: each joint a sum of a few random sinusoids in the tangent
// space around a random base rotation, amplitude up to `amplitude` rad; hemisphere-continuous.
std::vector<float> random_motion(std::mt19937_64& rng, int frames, int joints,
                                 double amplitude = 1.0);

// Geodesic distance between sample (t, j) of two rotation tensors.
double rotation_error(RotationView a, RotationView b, int t, int j);
// Largest and RMS geodesic distance between two rotation tensors of equal shape.
struct ErrorStats {
  double max = 0, rms = 0;
};
ErrorStats rotation_errors(RotationView a, RotationView b);

// Path of the mocap-clean executable built with the tests.
std::filesystem::path cli_path();

// Runs `arguments` (shell syntax) with the mocap-clean executable, capturing both streams.
struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};
CommandResult run_cli(const std::string& arguments);

// A fresh empty folder below the system's temporary folder, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& tag);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// Reads a whole file as text ("" when missing).
std::string read_text(const std::filesystem::path& path);

}  // namespace mocap::test
