#include "kernels/foot_contacts.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include "core/format.hpp"
#include "kernels/median.hpp"
#include "kernels/point_smoothing.hpp"

namespace mocap {
namespace {

bool positive_finite(double v) {
  return std::isfinite(v) && v > 0;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

char side_of(const std::string& name) {
  if (name.find("left") != std::string::npos) return 'L';
  if (name.find("right") != std::string::npos) return 'R';
  if (!name.empty() && (name[0] == 'l' || name[0] == 'r')) return name[0] == 'l' ? 'L' : 'R';
  return '?';
}

// The Gaussian-smoothed track (mirror at the ends), so per-frame noise does not read as speed.
std::vector<Vec3> smooth(const std::vector<Vec3>& track, double sigma) {
  if (sigma < 0.5 || track.size() < 3) return track;
  return smooth_mirrored(track, sigma);
}

// The per-frame noise of a track's horizontal axes (white noise of std n has second differences
// of std sqrt(6) n): 1.4826 MAD / sqrt(6) of the second differences, the larger of x and z
// (kernels/median.hpp's median: one selection pass on long clips). The median looks at the
// frames where the foot moves smoothly (most of a clip), not at its swings.
double horizontal_noise(const std::vector<Vec3>& track) {
  const std::size_t n = track.size();
  if (n < 3) return 0;
  double largest = 0;
  std::vector<double> d(n - 2);
  for (int axis : {0, 2}) {
    for (std::size_t t = 1; t + 1 < n; ++t) {
      const auto at = [&](std::size_t u) { return axis == 0 ? track[u].x : track[u].z; };
      d[t - 1] = std::abs(at(t + 1) - 2 * at(t) + at(t - 1));
    }
    largest = std::max(largest, 1.4826 * median(d) / std::sqrt(6.0));
  }
  return largest;
}

std::vector<ContactInterval> detect(const std::vector<Vec3>& track, const FootContactParams& p,
                                    double frame_time, double height) {
  const int n = int(track.size());
  std::vector<ContactInterval> out;
  if (n < 3) return out;
  // Smoothing width (header): at least smoothing_seconds, and wide enough that the track's
  // noise reads as a speed of at most noise_speed_fraction of enter_speed (mean of the
  // horizontal speed of smoothed white noise of std `noise` per axis, sigma frames:
  // 1.25 noise / (2 pi^(1/4) sigma^1.5 frame_time)), at most max_smoothing_seconds.
  double sigma = p.smoothing_seconds / frame_time;
  const double allowed = p.noise_speed_fraction * p.enter_speed * height;
  // The track's noise, per frame (file units), when either rule reads it.
  const double noise = allowed > 0 || p.noise_allowance > 0 ? horizontal_noise(track) : 0;
  if (noise > 0 && allowed > 0) {
    const double needed =
        std::pow(1.25 * noise / (2 * std::pow(kPi, 0.25) * frame_time * allowed), 2.0 / 3.0);
    sigma = std::max(sigma, std::min(needed, p.max_smoothing_seconds / frame_time));
  }
  const std::vector<Vec3> s = smooth(track, sigma);
  // The speed thresholds allow for the noise's own speed: white noise of std n per axis adds
  // E|e|^2 = n^2 smoothed_speed_gain(sigma) / frame_time^2 to the squared speed of the smoothed
  // track, so a planted foot reads as moving. Entering takes sqrt(enter_speed^2 + a^2 E|e|^2)
  // (a: noise_allowance); leaving keeps exit_speed unless that is lower (docs/feet.md,
  // "Contacts": raising both held lift-offs planted and cost rotations at low noise).
  double enter_speed = p.enter_speed, exit_speed = p.exit_speed;
  if (p.noise_allowance > 0) {
    const double relative = noise / height;
    const double e2 = relative * relative * smoothed_speed_gain(sigma) / (frame_time * frame_time);
    const double allowance = p.noise_allowance * p.noise_allowance * e2;
    enter_speed = std::sqrt(enter_speed * enter_speed + allowance);
    exit_speed = std::max(exit_speed, enter_speed);
  }
  // The floor from the smoothed heights: the raw heights' low percentile sits about 1.6 noise
  // deviations below the floor, which on noisy input is the whole enter_height band.
  std::vector<double> ys(s.size());
  for (std::size_t t = 0; t < s.size(); ++t) ys[t] = s[t].y;
  std::nth_element(ys.begin(), ys.begin() + std::ptrdiff_t(ys.size() / 20), ys.end());
  const double floor = ys[ys.size() / 20];
  auto speed = [&](int t) {
    const int a = std::max(t - 1, 0), b = std::min(t + 1, n - 1);
    const double dx = s[std::size_t(b)].x - s[std::size_t(a)].x,
                 dz = s[std::size_t(b)].z - s[std::size_t(a)].z;
    return std::sqrt(dx * dx + dz * dz) / ((b - a) * frame_time) / height;
  };
  const int min_frames = std::max(2, int(std::lround(p.min_seconds / frame_time)));
  bool planted = false;
  int begin = 0;
  for (int t = 0; t <= n; ++t) {
    bool now = planted;
    if (t < n) {
      const double h = (s[std::size_t(t)].y - floor) / height, v = speed(t);
      now = planted ? !(h > p.exit_height || v > exit_speed)
                    : (h < p.enter_height && v < enter_speed);
    } else {
      now = false;
    }
    if (now && !planted) begin = t;
    if (!now && planted) {
      // A short break where the foot stays put (noise crossing an exit threshold) joins the
      // previous contact.
      const bool joins = [&] {
        if (out.empty()) return false;
        const Vec3 moved = s[std::size_t(begin)] - s[std::size_t(out.back().end - 1)];
        return begin - out.back().end <= std::lround(p.merge_seconds / frame_time) &&
               std::hypot(moved.x, moved.z) < p.merge_distance * height;
      }();
      if (joins)
        out.back().end = t;
      else if (t - begin >= min_frames)
        out.push_back({begin, t});
    }
    planted = now;
  }
  return out;
}

}  // namespace

double smoothed_speed_gain(double sigma) {
  if (sigma < 0.5) return 2 * 0.5;  // ((e[t+1] - e[t-1]) / 2)^2 has variance 1/2 per axis
  const std::vector<double> taps = smoothing_taps(sigma);
  const int reach = int(taps.size() / 2);
  double sum = 0;
  for (double w : taps) sum += w;
  // g(u) = taps[u + reach] / sum inside the taps, 0 outside; d(r) = (g(r-1) - g(r+1)) / 2 is
  // nonzero for |r| <= reach + 1.
  const auto g = [&](int u) {
    return u < -reach || u > reach ? 0.0 : taps[std::size_t(u + reach)] / sum;
  };
  double gain = 0;
  for (int r = -reach - 1; r <= reach + 1; ++r) {
    const double d = (g(r - 1) - g(r + 1)) / 2;
    gain += d * d;
  }
  return 2 * gain;
}

Status FootContactParams::validate() const {
  const double values[] = {enter_height, exit_height, enter_speed, exit_speed, min_seconds};
  for (double v : values)
    if (!positive_finite(v)) return Status::error("foot contacts: thresholds must be > 0");
  if (!(smoothing_seconds >= 0) || !std::isfinite(smoothing_seconds))
    return Status::error("foot contacts: smoothing_seconds must be >= 0");
  for (double v : {max_smoothing_seconds, noise_speed_fraction, noise_allowance, merge_seconds,
                   merge_distance})
    if (!(v >= 0) || !std::isfinite(v))
      return Status::error(
          "foot contacts: max_smoothing_seconds, noise_speed_fraction, noise_allowance, "
          "merge_seconds and merge_distance must be finite and >= 0");
  if (exit_height < enter_height || exit_speed < enter_speed)
    return Status::error("foot contacts: an exit threshold must be at least its enter threshold");
  return {};
}

Status FootContactJob::validate() const {
  if (Status s = params.validate(); !s) return s;
  if (!positive_finite(frame_time))
    return Status::error(format("foot contacts: frame_time must be > 0, got %g", frame_time));
  if (!positive_finite(body_height))
    return Status::error(format("foot contacts: body_height must be > 0, got %g", body_height));
  if (contacts == nullptr) return Status::error("foot contacts: no output");
  if (feet.data == nullptr && feet.frames > 0 && feet.joints > 0)
    return Status::error("foot contacts: no input");
  return {};
}

Status FootContactJob::run() const {
  if (Status s = validate(); !s) return s;
  contacts->assign(std::size_t(std::max(feet.joints, 0)), {});
  for (int f = 0; f < feet.joints; ++f) {
    std::vector<Vec3> track(std::size_t(feet.frames));
    for (int t = 0; t < feet.frames; ++t) track[std::size_t(t)] = load_vec3(feet.at(t, f));
    (*contacts)[std::size_t(f)] = detect(track, params, frame_time, body_height);
  }
  return {};
}

namespace {

// The per-axis median (x, z) of the track over an interval.
Vec3 horizontal_median(std::span<const Vec3> track, ContactInterval c) {
  std::vector<double> x, z;
  for (int t = c.begin; t < c.end; ++t) {
    x.push_back(track[std::size_t(t)].x);
    z.push_back(track[std::size_t(t)].z);
  }
  const auto mid = std::ptrdiff_t(x.size() / 2);
  std::nth_element(x.begin(), x.begin() + mid, x.end());
  std::nth_element(z.begin(), z.begin() + mid, z.end());
  return {x[std::size_t(mid)], 0.0, z[std::size_t(mid)]};
}

double horizontal_distance(const Vec3& a, const Vec3& b) {
  return std::hypot(a.x - b.x, a.z - b.z);
}

}  // namespace

std::vector<ContactInterval> widen_contacts(const std::vector<ContactInterval>& input,
                                            const std::vector<ContactInterval>& filtered,
                                            std::span<const Vec3> track, double reach) {
  const int n = int(track.size());
  const std::vector<std::uint8_t> planted = contact_mask(filtered, n);
  std::vector<ContactInterval> out;
  std::vector<Vec3> pins;
  for (std::size_t k = 0; k < input.size(); ++k) {
    ContactInterval c{std::clamp(input[k].begin, 0, n), std::clamp(input[k].end, 0, n)};
    if (c.frames() <= 0) continue;
    const Vec3 pin = horizontal_median(track, c);
    auto holds = [&](int t) {
      return planted[std::size_t(t)] && horizontal_distance(track[std::size_t(t)], pin) < reach;
    };
    const int floor = out.empty() ? 0 : out.back().end;
    while (c.begin > floor && holds(c.begin - 1)) --c.begin;
    if (!out.empty() && c.begin == out.back().end &&
        horizontal_distance(pins.back(), pin) < reach) {
      out.back().end = c.end;  // joined backward: the earlier contact's pin stands
    } else {
      out.push_back(c);
      pins.push_back(pin);
    }
    const int ceiling = k + 1 < input.size() ? std::clamp(input[k + 1].begin, 0, n) : n;
    ContactInterval& last = out.back();
    const Vec3 last_pin = pins.back();
    while (last.end < ceiling && planted[std::size_t(last.end)] &&
           horizontal_distance(track[std::size_t(last.end)], last_pin) < reach)
      ++last.end;
  }
  return out;
}

std::vector<FootChain> find_feet(std::span<const std::string> names, std::span<const int> parents,
                                 std::span<const Vec3> offsets) {
  const int joints = int(parents.size());
  std::vector<int> depth(std::size_t(joints), 0);
  for (int j = 0; j < joints; ++j) {
    const int p = parents[std::size_t(j)];
    depth[std::size_t(j)] = p < 0 ? 0 : depth[std::size_t(p)] + 1;
  }
  auto chain_from = [&](int ankle, char side) {
    FootChain c;
    c.ankle = ankle;
    c.side = side;
    c.knee = parents[std::size_t(ankle)];
    if (c.knee >= 0) c.hip = parents[std::size_t(c.knee)];
    for (int j = ankle + 1; j < joints; ++j)
      if (parents[std::size_t(j)] == ankle) {
        c.toe = j;
        break;
      }
    return c;
  };

  // A leg is kept only if its hip, knee and ankle belong to no leg kept before: two legs that
  // share a joint cannot both be pinned (FootLockJob refuses them), and on a skeleton whose
  // lowest leaves are siblings (a binary tree) they would be one leg counted twice.
  std::vector<std::uint8_t> used(std::size_t(joints), 0);
  std::vector<FootChain> out;
  auto keep_if_disjoint = [&](const FootChain& c) {
    for (int j : {c.hip, c.knee, c.ankle})
      if (j >= 0 && used[std::size_t(j)]) return;
    for (int j : {c.hip, c.knee, c.ankle})
      if (j >= 0) used[std::size_t(j)] = 1;
    out.push_back(c);
  };

  // (side, rank) -> joint; rank 0 = foot/ankle, 1 = toe. Shallowest per key.
  std::map<std::pair<char, int>, int> best;
  for (int j = 0; j < joints && std::size_t(j) < names.size(); ++j) {
    const std::string name = lower(names[std::size_t(j)]);
    const bool foot =
        name.find("foot") != std::string::npos || name.find("ankle") != std::string::npos;
    const bool toe = name.find("toe") != std::string::npos;
    if (!foot && !toe) continue;
    const auto key = std::pair{side_of(name), foot ? 0 : 1};
    const auto it = best.find(key);
    if (it == best.end() || depth[std::size_t(j)] < depth[std::size_t(it->second)]) best[key] = j;
  }
  for (char side : {'L', 'R', '?'}) {
    auto it = best.find({side, 0});
    if (it == best.end()) it = best.find({side, 1});
    if (it != best.end()) keep_if_disjoint(chain_from(it->second, side));
  }
  if (!out.empty()) return out;

  // No names: the two lowest leaves of the rest pose whose legs share no joint.
  std::vector<Vec3> rest(static_cast<std::size_t>(joints));
  std::vector<bool> has_child(std::size_t(joints), false);
  for (int j = 0; j < joints; ++j) {
    const int p = parents[std::size_t(j)];
    const Vec3 o = std::size_t(j) < offsets.size() ? offsets[std::size_t(j)] : Vec3{};
    rest[std::size_t(j)] = p < 0 ? o : rest[std::size_t(p)] + o;
    if (p >= 0) has_child[std::size_t(p)] = true;
  }
  std::vector<int> leaves;
  for (int j = 0; j < joints; ++j)
    if (!has_child[std::size_t(j)] && parents[std::size_t(j)] >= 0) leaves.push_back(j);
  std::stable_sort(leaves.begin(), leaves.end(),
                   [&](int a, int b) { return rest[std::size_t(a)].y < rest[std::size_t(b)].y; });
  for (std::size_t i = 0; i < leaves.size() && out.size() < 2; ++i)
    keep_if_disjoint(chain_from(leaves[i], '?'));
  return out;
}

double rest_height(std::span<const int> parents, std::span<const Vec3> offsets,
                   std::span<const std::pair<int, Vec3>> end_sites) {
  const std::size_t joints = parents.size();
  std::vector<Vec3> rest(joints);
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t j = 0; j < joints; ++j) {
    const int p = parents[j];
    const Vec3 o = j < offsets.size() ? offsets[j] : Vec3{};
    // The root's offset places the whole body; its height is measured from the joints.
    rest[j] = p < 0 ? Vec3{} : rest[std::size_t(p)] + o;
    lo = std::min(lo, rest[j].y);
    hi = std::max(hi, rest[j].y);
  }
  for (const auto& [joint, offset] : end_sites) {
    if (joint < 0 || std::size_t(joint) >= joints) continue;
    const double y = (rest[std::size_t(joint)] + offset).y;
    lo = std::min(lo, y);
    hi = std::max(hi, y);
  }
  return joints == 0 ? 0.0 : hi - lo;
}

std::vector<std::uint8_t> contact_mask(const std::vector<ContactInterval>& intervals, int frames) {
  std::vector<std::uint8_t> mask(std::size_t(std::max(frames, 0)), 0);
  for (const ContactInterval& c : intervals)
    for (int t = std::max(c.begin, 0); t < std::min(c.end, frames); ++t) mask[std::size_t(t)] = 1;
  return mask;
}

}  // namespace mocap
