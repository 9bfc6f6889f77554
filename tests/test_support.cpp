#include "tests/test_support.hpp"

#include <sys/wait.h>
#include <unistd.h>
#include <algorithm>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace mocap::test {

std::filesystem::path shared_bvh_dir() {
  const std::filesystem::path dir = std::filesystem::path(MOCAP_SHARED_DIR) / "data" / "bvh";
  std::error_code ec;
  return std::filesystem::is_directory(dir, ec) ? dir : std::filesystem::path{};
}

std::vector<std::filesystem::path> shared_bvh_files() {
  std::vector<std::filesystem::path> files;
  const auto dir = shared_bvh_dir();
  if (dir.empty()) return files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".bvh") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return normalized({n(rng), n(rng), n(rng), n(rng)});
}

Motion every_nth_frame(RotationView rotations, int first, int stride, int frames) {
  Motion m{frames, rotations.joints, {}};
  m.rotations.resize(std::size_t(m.frames) * std::size_t(m.joints) * 4);
  for (int t = 0; t < m.frames; ++t)
    for (int j = 0; j < m.joints; ++j)
      std::copy_n(rotations.at(first + t * stride, j), 4, m.span().at(t, j));
  return m;
}

std::vector<float> random_motion(std::mt19937_64& rng, int frames, int joints, double amplitude) {
  std::vector<float> out(std::size_t(frames) * joints * 4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int j = 0; j < joints; ++j) {
    const Quat base = random_rotation(rng);
    Vec3 amp[3], freq, phase;
    for (auto& a : amp)
      a = {u(rng) * amplitude / 3, u(rng) * amplitude / 3, u(rng) * amplitude / 3};
    freq = {0.01 + 0.05 * std::abs(u(rng)), 0.01 + 0.05 * std::abs(u(rng)),
            0.01 + 0.05 * std::abs(u(rng))};
    phase = {3 * u(rng), 3 * u(rng), 3 * u(rng)};
    for (int t = 0; t < frames; ++t) {
      const Vec3 v = std::sin(freq.x * t + phase.x) * amp[0] +
                     std::sin(freq.y * t + phase.y) * amp[1] +
                     std::sin(freq.z * t + phase.z) * amp[2];
      store_quat(base * exp(v), out.data() + (std::size_t(t) * joints + j) * 4);
    }
  }
  make_hemisphere_continuous({out.data(), frames, joints});
  return out;
}

double rotation_error(RotationView a, RotationView b, int t, int j) {
  return geodesic(load_quat(a.at(t, j)), load_quat(b.at(t, j)));
}

ErrorStats rotation_errors(RotationView a, RotationView b) {
  ErrorStats s;
  double sum = 0;
  for (int t = 0; t < a.frames; ++t)
    for (int j = 0; j < a.joints; ++j) {
      const double e = rotation_error(a, b, t, j);
      s.max = std::max(s.max, e);
      sum += e * e;
    }
  const double n = double(a.frames) * a.joints;
  s.rms = n > 0 ? std::sqrt(sum / n) : 0.0;
  return s;
}

std::filesystem::path cli_path() {
  return MOCAP_CLI_PATH;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TempDir::TempDir(const std::string& tag) {
  std::string pattern =
      (std::filesystem::temp_directory_path() / ("mocap-" + tag + "-XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

CommandResult run_cli(const std::string& arguments) {
  static int counter = 0;
  std::string err_name = "mocap-cli-stderr-";
  err_name.append(std::to_string(getpid())).append("-").append(std::to_string(counter++));
  const auto err_file = std::filesystem::temp_directory_path() / err_name;
  std::string command;  // appended piecewise: GCC 12 warns falsely (-Wrestrict) on a + chain
  command.append("'").append(cli_path().string()).append("' ").append(arguments);
  command.append(" 2>'").append(err_file.string()).append("'");
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  std::size_t n;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) result.out.append(buffer, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.err = read_text(err_file);
  std::filesystem::remove(err_file);
  return result;
}

}  // namespace mocap::test
