#include "kernels/flip_chart.hpp"

#include <vector>

#include "kernels/joint_quality.hpp"

namespace mocap {

Quat FlipChart::step(Quat from, Quat to) const {
  return left ? to * inverse(from) : inverse(from) * to;
}

bool FlipChart::takes_out(Quat from, Quat to, bool flipped) const {
  return found && geodesic(from, to) >= kFlipStep &&
         geodesic(step(from, to), flipped ? inverse(flip) : flip) <= kFlipChartTolerance;
}

Quat FlipChart::unflip(Quat q) const {
  return left ? inverse(flip) * q : q * inverse(flip);
}

Quat FlipChart::reflip(Quat q) const {
  return left ? flip * q : q * flip;
}

FlipChart find_flip_chart(std::span<const Quat> curve) {
  FlipChart best;
  double best_spread = 0;
  std::vector<Quat> flips;
  for (const bool left : {true, false}) {
    FlipChart c;
    c.left = left;
    flips.clear();
    for (std::size_t t = 0; t + 1 < curve.size(); ++t) {
      if (geodesic(curve[t], curve[t + 1]) < kFlipStep) continue;
      // The flip's step holds one step of motion too; the step before it, where that is no
      // flip, stands in for it (constant velocity), so that D is not biased by the motion.
      Quat flip = c.step(curve[t], curve[t + 1]);
      if (t > 0 && geodesic(curve[t - 1], curve[t]) < kFlipStep) {
        const Quat motion = c.step(curve[t - 1], curve[t]);
        flip = left ? flip * inverse(motion) : inverse(motion) * flip;
      }
      // Every other flip turns back: D^-1.
      flips.push_back(flips.size() % 2 ? inverse(flip) : flip);
    }
    if (flips.empty()) return best;  // no flips: no chart
    // The mean of the flips near a reference, on its hemisphere (a quaternion's sign is
    // arbitrary); a few flips of another kind do not sway it.
    auto mean_near = [&](Quat reference, double reach) {
      Quat sum{0, 0, 0, 0};
      for (const Quat& f : flips) {
        if (geodesic(f, reference) > reach) continue;
        const double sign = dot(f, reference) < 0 ? -1.0 : 1.0;
        sum = {sum.w + sign * f.w, sum.x + sign * f.x, sum.y + sign * f.y, sum.z + sign * f.z};
      }
      return dot(sum, sum) > 0 ? normalized(sum) : reference;
    };
    // The reference: of up to 16 flips spread over the clip, the one most others lie near.
    const std::size_t stride = (flips.size() + 15) / 16;
    Quat reference = flips.front();
    std::size_t most = 0;
    for (std::size_t i = 0; i < flips.size(); i += stride) {
      std::size_t near = 0;
      for (const Quat& f : flips) near += geodesic(f, flips[i]) <= kFlipChartTolerance;
      if (near > most) {
        most = near;
        reference = flips[i];
      }
    }
    c.flip = mean_near(mean_near(reference, kFlipChartTolerance), kFlipChartTolerance);
    // The form whose flips lie nearer D: the flips of the other form are a turn about an axis
    // that turns with the joint, and may lie within the tolerance too where it turns little.
    std::size_t within = 0;
    double spread = 0;
    for (const Quat& f : flips) {
      const double d = geodesic(f, c.flip);
      within += d <= kFlipChartTolerance;
      spread += d;
    }
    c.found = 2 * within >= flips.size();
    if (c.found && (!best.found || spread < best_spread)) {
      best = c;
      best_spread = spread;
    }
  }
  return best;
}

void take_out_flips(const FlipChart& chart, std::span<Quat> curve,
                    std::span<std::uint8_t> flipped) {
  bool odd = false;
  Quat previous{};  // the sample before, as it came
  for (std::size_t t = 0; t < curve.size(); ++t) {
    const Quat q = curve[t];
    if (t > 0 && chart.takes_out(previous, q, odd)) odd = !odd;
    previous = q;
    flipped[t] = odd;
    Quat u = odd ? chart.unflip(q) : q;
    if (t > 0 && dot(u, curve[t - 1]) < 0) u = negate(u);
    curve[t] = u;
  }
}

}  // namespace mocap
