#include "engine/eval/eval_plots.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include "core/quaternion.hpp"
#include "engine/eval/eval_methods.hpp"
#include "engine/eval/svg_plot.hpp"
#include "engine/run/atomic_file.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/metrics.hpp"

namespace mocap::engine::eval {
namespace {

constexpr double kPlotDegrees = 180.0 / 3.14159265358979323846;  // axes a person reads

// Twelve: room for methods added to the table after the eight eval has today.
constexpr const char* kMethodColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                         "#9467bd", "#8c564b", "#e377c2", "#17becf",
                                         "#bcbd22", "#7f7f7f", "#393b79", "#637939"};

std::string method_color(EvalMethod m) {
  return kMethodColors[m.index % std::size(kMethodColors)];
}

// The gaussian condition nearest 0.03 rad (log distance), else -1.
int figure_condition(const EvalConfig& config) {
  int best = -1;
  double best_distance = 0;
  for (std::size_t c = 0; c < config.conditions.size(); ++c) {
    const NoiseCondition& nc = config.conditions[c];
    if (!nc.is_gaussian() || !(nc.sigma > 0)) continue;
    const double d = std::abs(std::log(nc.sigma / 0.03));
    if (best < 0 || d < best_distance) {
      best = int(c);
      best_distance = d;
    }
  }
  return best;
}

int method_index(const EvalConfig& config, EvalMethod method) {
  for (std::size_t m = 0; m < config.grids.size(); ++m)
    if (config.grids[m].method == method && !config.grids[m].repaired) return int(m);
  return -1;
}

// The clip and joint that moves most: the largest RMS angle from the joint's pose in the middle
// of the clip's longest segment (roots excluded: their rotation is the subject's heading). The
// amplitude rather than the speed, which would pick a joint of small jittery motion (a toe).
struct JointChoice {
  int clip = -1, joint = -1;
};
const Segment& longest_segment(const EvalClip& c) {
  return *std::max_element(
      c.segments.begin(), c.segments.end(),
      [](const Segment& a, const Segment& b) { return a.frames() < b.frames(); });
}
JointChoice largest_motion(const EvalResults& r) {
  JointChoice choice;
  double best = -1;
  for (std::size_t k = 0; k < r.clips.size(); ++k) {
    const EvalClip& c = r.clips[k];
    if (c.segments.empty()) continue;
    const Segment& seg = longest_segment(c);
    if (seg.frames() < 2) continue;
    const RotationView v = c.clean.rotation_view();
    for (int j = 0; j < c.clean.joints(); ++j) {
      if (c.geometry.parents[std::size_t(j)] < 0) continue;
      const Quat middle = load_quat(v.at((seg.begin + seg.end) / 2, j));
      double sum = 0;
      for (int t = seg.begin; t < seg.end; ++t) {
        const double d = geodesic(middle, load_quat(v.at(t, j)));
        sum += d * d;
      }
      if (sum / seg.frames() > best) {
        best = sum / seg.frames();
        choice = {int(k), j};
      }
    }
  }
  return choice;
}

bool write(const std::filesystem::path& dir, const std::string& file, const LinePlot& plot,
           std::vector<Figure>* figures, const std::string& caption, std::string* error) {
  if (!write_file_atomically(dir / file, render_svg(plot), error)) return false;
  figures->push_back({file, caption});
  return true;
}

bool curve_figures(const EvalResults& r, const EvalConfig& config, int c,
                   const std::filesystem::path& dir, std::vector<Figure>* figures,
                   std::string* error) {
  const JointChoice choice = largest_motion(r);
  if (choice.clip < 0) return true;
  const EvalClip& clip = r.clips[std::size_t(choice.clip)];
  const NoisyClip& noisy = r.noisy[std::size_t(c)][std::size_t(choice.clip)];
  const int j = choice.joint, frames = clip.clean.frames, joints = clip.clean.joints();
  const std::string joint_name = clip.clean.skeleton->joint_names[std::size_t(j)];

  // 1 s of the longest segment around the joint's fastest moment.
  const Segment seg =
      *std::max_element(clip.segments.begin(), clip.segments.end(),
                        [](const Segment& a, const Segment& b) { return a.frames() < b.frames(); });
  const double* speed = &clip.reference.speeds[std::size_t(j) * std::size_t(frames - 1)];
  int fastest = seg.begin;
  for (int t = seg.begin; t + 1 < seg.end; ++t)
    if (speed[t] > speed[fastest]) fastest = t;
  const int length =
      std::min(seg.frames(), std::max(8, int(std::lround(1.0 / clip.clean.frame_time))));
  const int begin = std::clamp(fastest - length / 2, seg.begin, seg.end - length);
  const int end = begin + length;

  struct Curve {
    std::string name, color;
    std::vector<float> rotations;
    double width;
  };
  std::vector<Curve> curves{{"noisy", "#aaaaaa", noisy.rotations, 1.0}};
  for (EvalMethod m : {*parse_eval_method("bof"), *parse_eval_method("nlpm")}) {
    if (method_index(config, m) < 0) continue;
    Curve curve{std::string(to_string(m)) + " (automatic)", method_color(m), {}, 1.6};
    std::vector<float> translations;
    if (Status s =
            filter_clip(clip, noisy, m, false, nullptr, curve.rotations, translations, nullptr);
        !s)
      continue;
    curves.push_back(std::move(curve));
  }
  curves.push_back({"clean", "#000000", clip.clean.rotations, 1.4});

  // The tangent component (about the window's first clean pose) that varies most in the clean.
  const Quat ref = load_quat(clip.clean.rotation_view().at(begin, j));
  auto component = [&](const std::vector<float>& rot, int t, int axis) {
    const Vec3 v = log(inverse(ref) * load_quat(&rot[(std::size_t(t) * joints + j) * 4]));
    return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
  };
  int axis = 0;
  double widest = -1;
  for (int a = 0; a < 3; ++a) {
    double lo = 1e9, hi = -1e9;
    for (int t = begin; t < end; ++t) {
      lo = std::min(lo, component(clip.clean.rotations, t, a));
      hi = std::max(hi, component(clip.clean.rotations, t, a));
    }
    if (hi - lo > widest) {
      widest = hi - lo;
      axis = a;
    }
  }
  const std::string condition = config.conditions[std::size_t(c)].label();
  LinePlot curve_plot{fmt::format("{}, {} ({})", clip.name, joint_name, condition),
                      "time (s)",
                      // Degrees: what a person reads (issue 17); the data stay in radians.
                      fmt::format("rotation from the first clean pose shown, {} of the "
                                  "rotation vector (degrees)",
                                  "xyz"[axis]),
                      false,
                      760,
                      380,
                      {}};
  LinePlot speed_plot{fmt::format("Angular speed, {} {} ({})", clip.name, joint_name, condition),
                      "time (s)",
                      "angular speed (degrees/s)",
                      false,
                      760,
                      380,
                      {}};
  for (const Curve& cv : curves) {
    PlotSeries a{cv.name, {}, {}, cv.color, false, false, cv.width};
    PlotSeries b = a;
    std::vector<double> sp(std::size_t(frames - 1));
    angular_speed({cv.rotations.data(), frames, joints}, clip.clean.frame_time, j, sp);
    for (int t = begin; t < end; ++t) {
      a.x.push_back(t * clip.clean.frame_time);
      a.y.push_back(component(cv.rotations, t, axis) * kPlotDegrees);
      if (t + 1 < end) {
        b.x.push_back(t * clip.clean.frame_time);
        b.y.push_back(sp[std::size_t(t)] * kPlotDegrees);
      }
    }
    curve_plot.series.push_back(std::move(a));
    speed_plot.series.push_back(std::move(b));
  }
  return write(dir, "fig_curve.svg", curve_plot, figures,
               fmt::format("{} of {} over 1 s around its fastest moment: noisy ({}), filtered "
                           "with automatic parameters, clean (after Courty 2008, Fig. 2).",
                           joint_name, clip.name, condition),
               error) &&
         write(dir, "fig_speed.svg", speed_plot, figures,
               fmt::format("Angular speed profile of the same joint: filtering must bring the "
                           "noisy profile back to the clean one without flattening its peaks."),
               error);
}

bool iteration_figure(const EvalResults& r, const EvalConfig& config, int c,
                      const std::filesystem::path& dir, std::vector<Figure>* figures,
                      std::string* error) {
  const int m = method_index(config, *parse_eval_method("bof"));
  if (m < 0) return true;
  std::set<double> sigma_set;
  for (const ParamPoint& p : config.grids[std::size_t(m)].points)
    for (const auto& [name, v] : p)
      if (name == "sigma_g") sigma_set.insert(v);
  if (sigma_set.empty()) sigma_set = {0.05, 0.1, 0.2, 0.4};
  const std::vector<double> sigmas(sigma_set.begin(), sigma_set.end());
  constexpr int kIterations = 10;
  const std::size_t N = r.clips.size();
  // [sigma][clip][iteration] squared error sums and counts.
  std::vector<std::vector<std::array<double, kIterations>>> sq(
      sigmas.size(), std::vector<std::array<double, kIterations>>(N));
  std::vector<double> counts(N, 0);
  for (std::size_t k = 0; k < N; ++k)
    for (const Segment& s : r.clips[k].segments)
      if (s.frames() >= 2) counts[k] += double(s.frames()) * r.clips[k].clean.joints();
  tbb::parallel_for(std::size_t(0), sigmas.size() * N, [&](std::size_t i) {
    const std::size_t g = i / N, k = i % N;
    const EvalClip& clip = r.clips[k];
    const int joints = clip.clean.joints();
    std::vector<float> current = r.noisy[std::size_t(c)][k].rotations, next(current.size());
    BilateralParams params;
    params.sigma_g = sigmas[g];
    params.iterations = 1;
    for (int it = 0; it < kIterations; ++it) {
      double sum = 0;
      for (const Segment& s : clip.segments) {
        const std::size_t offset = std::size_t(s.begin) * std::size_t(joints) * 4;
        MotionIO io;
        io.frame_time = clip.clean.frame_time;
        io.rotations = {current.data() + offset, s.frames(), joints};
        io.filtered_rotations = {next.data() + offset, s.frames(), joints};
        if (s.frames() < 2 || !BilateralJob{params, io}.run()) {
          std::copy_n(current.begin() + std::ptrdiff_t(offset),
                      std::size_t(s.frames()) * joints * 4, next.begin() + std::ptrdiff_t(offset));
          continue;
        }
        for (int t = s.begin; t < s.end; ++t)
          for (int j = 0; j < joints; ++j) {
            const double d = geodesic(load_quat(&next[(std::size_t(t) * joints + j) * 4]),
                                      load_quat(clip.clean.rotation_view().at(t, j)));
            sum += d * d;
          }
      }
      sq[g][k][std::size_t(it)] = sum;
      std::swap(current, next);
    }
  });
  double total = 0;
  for (double n : counts) total += n;
  const std::string condition = config.conditions[std::size_t(c)].label();
  LinePlot plot{fmt::format("bof: MSE against iterations ({})", condition),
                "iterations",
                "MSE (mrad^2)",
                false,
                640,
                380,
                {}};
  for (std::size_t g = 0; g < sigmas.size(); ++g) {
    PlotSeries s{fmt::format("sigma_g = {:g}", sigmas[g]), {}, {}, "", false, true, 1.6};
    for (int it = 0; it < kIterations; ++it) {
      double sum = 0;
      for (std::size_t k = 0; k < N; ++k) sum += sq[g][k][std::size_t(it)];
      s.x.push_back(it + 1);
      s.y.push_back(total > 0 ? 1e6 * sum / total : NAN);
    }
    plot.series.push_back(std::move(s));
  }
  return write(dir, "fig_iterations.svg", plot, figures,
               fmt::format("bof (sigma_t = 1) repeated on its own output: MSE against the clean "
                           "clips after 1..10 iterations, {}, all clips (after Courty 2008, "
                           "Fig. 3).",
                           condition),
               error);
}

bool psnr_figure(const EvalResults& r, const EvalConfig& config, const std::filesystem::path& dir,
                 std::vector<Figure>* figures, std::string* error) {
  std::vector<std::size_t> gaussian;
  for (std::size_t c = 0; c < config.conditions.size(); ++c)
    if (config.conditions[c].is_gaussian() && config.conditions[c].sigma > 0) gaussian.push_back(c);
  std::sort(gaussian.begin(), gaussian.end(), [&](std::size_t a, std::size_t b) {
    return config.conditions[a].sigma < config.conditions[b].sigma;
  });
  if (gaussian.size() < 2) return true;
  LinePlot plot{"PSNR gain over the noisy input",
                "gaussian noise sigma (degrees)",
                "PSNR gain (dB)",
                true,
                760,
                420,
                {}};
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    const EvalMethod method = config.grids[m].method;
    if (config.grids[m].repaired) continue;      // gaussian noise: repair changes next to nothing
    if (locked_twin(config.grids, m)) continue;  // --feet both: scored in the feet tables
    PlotSeries best{
        label(config.grids[m]) + " best", {}, {}, method_color(method), false, true, 1.6};
    PlotSeries automatic{
        label(config.grids[m]) + " auto", {}, {}, method_color(method), true, false, 1.4};
    for (std::size_t c : gaussian) {
      const int b = best_point(r, config, m, c);
      best.x.push_back(config.conditions[c].sigma * kPlotDegrees);
      const double noisy = pooled_noisy(r, c).psnr();
      best.y.push_back(b < 0 ? NAN : pooled(r, m, std::size_t(b), c).psnr() - noisy);
      automatic.x.push_back(config.conditions[c].sigma * kPlotDegrees);
      automatic.y.push_back(pooled(r, m, config.grids[m].points.size(), c).psnr() - noisy);
    }
    plot.series.push_back(std::move(best));
    plot.series.push_back(std::move(automatic));
  }
  return write(dir, "fig_psnr.svg", plot, figures,
               "PSNR of the rotations minus the noisy input's, against the gaussian noise level, "
               "per method: best grid point (solid, dots) and automatic parameters (dashed); all "
               "clips pooled.",
               error);
}

}  // namespace

bool write_figures(const EvalResults& results, const EvalConfig& config,
                   const std::filesystem::path& dir, std::vector<Figure>* figures,
                   std::string* error) {
  const int c = figure_condition(config);
  if (c >= 0) {
    if (!curve_figures(results, config, c, dir, figures, error)) return false;
    if (!iteration_figure(results, config, c, dir, figures, error)) return false;
  }
  return psnr_figure(results, config, dir, figures, error);
}

}  // namespace mocap::engine::eval
