#include "engine/run/review_report.hpp"

#include <fmt/format.h>

#include <zlib.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/quaternion.hpp"

namespace mocap::engine {
namespace fs = std::filesystem;

namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

std::string base64(const void* data, std::size_t size) {
  static constexpr char kTable[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const unsigned v = unsigned(p[i]) << 16 | (i + 1 < size ? unsigned(p[i + 1]) << 8 : 0u) |
                       (i + 2 < size ? unsigned(p[i + 2]) : 0u);
    out += kTable[v >> 18 & 63];
    out += kTable[v >> 12 & 63];
    out += i + 1 < size ? kTable[v >> 6 & 63] : '=';
    out += i + 2 < size ? kTable[v & 63] : '=';
  }
  return out;
}

// Quantizes `values` to int16 steps of max|value| / 32767 (the step is returned), appended.
double quantize(const std::vector<float>& values, std::vector<std::int16_t>& out) {
  double peak = 0;
  for (float v : values) peak = std::max(peak, std::abs(double(v)));
  const double step = peak > 0 ? peak / 32767.0 : 1.0;
  for (float v : values) out.push_back(std::int16_t(std::lround(double(v) / step)));
  return step;
}

// Motion is smooth: each value as its step from the sample before (int16, wrapping, so exact),
// low bytes then high bytes, then deflate (zlib format), which the browser undoes with
// DecompressionStream("deflate"). About a quarter of the raw size on CMU clips.
std::vector<unsigned char> pack(const std::vector<std::int16_t>& values, std::size_t row) {
  const std::size_t n = values.size();
  std::vector<unsigned char> shuffled(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto step =
        std::uint16_t(std::uint16_t(values[k]) - (k >= row ? std::uint16_t(values[k - row]) : 0));
    shuffled[k] = static_cast<unsigned char>(step & 0xff);
    shuffled[n + k] = static_cast<unsigned char>(step >> 8);
  }
  uLongf size = compressBound(uLong(shuffled.size()));
  std::vector<unsigned char> out(size);
  if (compress2(out.data(), &size, shuffled.data(), uLong(shuffled.size()), 6) != Z_OK) return {};
  out.resize(size);
  return out;
}

// The samples [S][J][3] at `frames` of positions (converted to cm).
std::vector<float> sample_positions(const std::vector<float>& positions, int joints,
                                    const std::vector<int>& frames, double scale) {
  const std::size_t row = std::size_t(joints) * 3;
  std::vector<float> out(frames.size() * row);
  for (std::size_t s = 0; s < frames.size(); ++s)
    for (std::size_t k = 0; k < row; ++k)
      out[s * row + k] = float(positions[std::size_t(frames[s]) * row + k] * scale);
  return out;
}

// Every joint's local rotation as a rotation vector in degrees, [F][J][3].
std::vector<float> rotation_vectors(const Clip& clip) {
  const int J = clip.joints();
  std::vector<float> out(std::size_t(clip.frames) * std::size_t(J) * 3);
  for (int t = 0; t < clip.frames; ++t)
    for (int j = 0; j < J; ++j) {
      const Vec3 v = log(load_quat(clip.rotation_view().at(t, j)));
      float* o = &out[(std::size_t(t) * std::size_t(J) + std::size_t(j)) * 3];
      o[0] = float(v.x * kDegrees);
      o[1] = float(v.y * kDegrees);
      o[2] = float(v.z * kDegrees);
    }
  return out;
}

// How the page reads a parameter: angles in degrees, widths in frames, cut-offs in Hz.
std::string readable_parameters(const nlohmann::json& parameters) {
  std::string out;
  for (const auto& [key, value] : parameters.items()) {
    if (key == "method") continue;
    std::string text;
    if (value.is_number() &&
        (key == "sigma_g" || key == "h" || key == "range_sigma" || key == "distance_cap"))
      text = fmt::format("{:.3g}°", value.get<double>() * kDegrees);
    else if (value.is_number() && (key == "sigma_t" || key == "window" || key == "search_radius" ||
                                   key == "patch_radius" || key == "translation_sigma_t"))
      text = fmt::format("{:.3g} frames", value.get<double>());
    else if (value.is_number() && key == "cutoff")
      text = fmt::format("{:.3g} Hz", value.get<double>());
    else if (value.is_array() && !value.empty() && key == "joint_cutoffs") {  // auto's, per joint
      const std::vector<double> cutoffs = value.get<std::vector<double>>();
      const auto [low, high] = std::minmax_element(cutoffs.begin(), cutoffs.end());
      text = fmt::format("{:.3g}-{:.3g} Hz", *low, *high);
    } else if (value.is_string())
      text = value.get<std::string>();
    else
      text = value.dump();
    out += (out.empty() ? "" : ", ") + key + " " + text;
  }
  return out;
}

// Text inside a <script> element must not hold "</" (it would close the element early).
std::string script_safe(std::string text) {
  for (std::size_t at = 0; (at = text.find("</", at)) != std::string::npos; at += 3)
    text.replace(at, 2, "<\\/");
  return text;
}

Status write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    return Status::error(fmt::format("{}: cannot write: {}", path.string(), strerror(errno)));
  out.write(text.data(), std::streamsize(text.size()));
  out.close();
  if (!out)
    return Status::error(fmt::format("{}: write failed: {}", path.string(), strerror(errno)));
  return {};
}

// The template with each @NAME@ marker replaced, in one pass: what goes in is not searched again.
std::string fill(std::string_view page,
                 const std::vector<std::pair<std::string_view, std::string>>& values) {
  std::string out;
  std::size_t at = 0;
  while (at < page.size()) {
    std::size_t best = std::string_view::npos, which = 0;
    for (std::size_t k = 0; k < values.size(); ++k) {
      const std::size_t found = page.find(values[k].first, at);
      if (found < best) best = found, which = k;
    }
    if (best == std::string_view::npos) break;
    out.append(page.substr(at, best - at));
    out += values[which].second;
    at = best + values[which].first.size();
  }
  if (at < page.size()) out.append(page.substr(at));
  return out;
}

}  // namespace

double guess_cm_per_unit(double body_height, std::string* name) {
  struct Unit {
    const char* name;
    double cm;
  };
  // In order of how often motion files use them; the first that makes a person of 1.0-2.3 m.
  // CMU's conversions keep the ASF length unit, 1/0.45 inch.
  static constexpr Unit kUnits[] = {{"cm", 1},
                                    {"m", 100},
                                    {"inch", 2.54},
                                    {"mm", 0.1},
                                    {"CMU ASF unit (1/0.45 inch)", 2.54 / 0.45}};
  for (const Unit& u : kUnits)
    if (body_height * u.cm >= 100 && body_height * u.cm <= 230) {
      if (name) *name = u.name;
      return u.cm;
    }
  if (name) *name = "unknown (body scaled to 170 cm)";
  return body_height > 0 ? 170.0 / body_height : 1.0;
}

ReviewCapture begin_review(const Clip& as_read) {
  ReviewCapture c;
  if (!as_read.skeleton || as_read.frames <= 0) return c;
  c.positions_before = joint_positions(as_read);
  const double fps = as_read.frame_time > 0 ? 1.0 / as_read.frame_time : 30.0;
  // 1 / 0.0083333 s is 120.0005 Hz: a stride of 2, not 3.
  c.stride = std::max(1, int(std::ceil(fps / kReviewMaxRate - 0.01)));
  while ((as_read.frames + c.stride - 1) / c.stride > kReviewMaxSamples) ++c.stride;
  c.cm_per_unit = guess_cm_per_unit(body_height(*as_read.skeleton), &c.units);
  c.angles_before = rotation_vectors(as_read);
  return c;
}

void finish_review(ReviewCapture& c, const Clip& cleaned, std::span<const std::int32_t> pops) {
  const std::vector<float> after = joint_positions(cleaned);
  const int J = cleaned.joints();
  if (c.positions_before.empty() || after.size() != c.positions_before.size()) {
    c = {};  // shapes disagree (never for checked clips): the page shows no player
    return;
  }
  double sum = 0;
  for (std::size_t k = 0; k < after.size(); k += 3) {
    const double dx = after[k] - c.positions_before[k],
                 dy = after[k + 1] - c.positions_before[k + 1],
                 dz = after[k + 2] - c.positions_before[k + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    sum += d2;
    if (std::sqrt(d2) * c.cm_per_unit > c.change_max) {
      c.change_max = std::sqrt(d2) * c.cm_per_unit;
      c.change_max_frame = int(k / 3 / std::size_t(J));
      c.change_max_joint = int(k / 3 % std::size_t(J));
    }
  }
  c.change_rms = std::sqrt(sum / double(after.size() / 3)) * c.cm_per_unit;
  // Every stride-th frame, and every frame with a pop and the one cleaning moved most, which a
  // stride would skip: the page shows what was repaired.
  for (int t = 0; t < cleaned.frames; t += c.stride) c.frames.push_back(t);
  for (std::size_t k = 0; k + 1 < pops.size(); k += 2)
    if (pops[k] >= 0 && pops[k] < cleaned.frames) c.frames.push_back(pops[k]);
  c.frames.push_back(c.change_max_frame);
  std::sort(c.frames.begin(), c.frames.end());
  c.frames.erase(std::unique(c.frames.begin(), c.frames.end()), c.frames.end());
  c.count = int(c.frames.size());
  std::vector<float> pos_before = sample_positions(c.positions_before, J, c.frames, c.cm_per_unit);
  std::vector<float> pos_after = sample_positions(after, J, c.frames, c.cm_per_unit);
  c.positions_before = {};
  // One scale for both versions of a quantity, so the same value reads back the same.
  std::vector<float> positions = std::move(pos_before);
  positions.insert(positions.end(), pos_after.begin(), pos_after.end());
  std::vector<float> angles = sample_positions(c.angles_before, J, c.frames, 1.0);
  const std::vector<float> angles_after =
      sample_positions(rotation_vectors(cleaned), J, c.frames, 1.0);
  angles.insert(angles.end(), angles_after.begin(), angles_after.end());
  c.angles_before = {};
  c.samples.reserve(positions.size() + angles.size());
  c.position_scale = quantize(positions, c.samples);
  c.angle_scale = quantize(angles, c.samples);
  // The four blocks [S][J][3] follow each other, so a block's first sample steps from the last
  // of the block before: exact all the same.
  c.packed = pack(c.samples, std::size_t(J) * 3);
  c.samples = {};
  if (c.packed.empty()) c = {};  // zlib out of memory: no player for this clip
}

ReviewReport::ReviewReport(std::string folder, std::string command)
    : folder_(std::move(folder)), command_(std::move(command)) {}

Status ReviewReport::available() {
  if (review_three_js().empty())
    return Status::error(
        "--report needs three.js, and this mocap-clean was built without it: run "
        "scripts/setup.sh (it installs three.js with npm into web/review/node_modules) on a "
        "machine that reaches the npm registry, then build again");
  return {};
}

Status ReviewReport::prepare() {
  std::error_code ec;
  fs::create_directories(fs::path(folder_) / "clips", ec);
  if (ec)
    return Status::error(
        fmt::format("{}: cannot make the report folder: {}", folder_, ec.message()));
  return {};
}

ReviewEntry review_entry(const ReviewClipInfo& info, ReviewCapture&& capture) {
  const Clip& clip = *info.clip;
  const Skeleton& sk = *clip.skeleton;
  const double fps = clip.frame_time > 0 ? 1.0 / clip.frame_time : 0;
  const double cm = capture.cm_per_unit;

  ReviewEntry entry;
  nlohmann::json& row = entry.row;
  row["name"] = info.name;
  row["frames"] = clip.frames;
  row["fps"] = fps;
  row["joints"] = sk.joint_count();
  const ResolvedSettings& r = *info.resolved;
  row["method"] =
      r.unchanged ? std::string("unchanged") : std::string(to_string(r.settings.method));
  row["parameters"] = readable_parameters(r.settings.to_json());
  row["noise_deg"] = r.noise_sigma >= 0 ? nlohmann::json(r.noise_sigma * kDegrees) : nullptr;

  const ClipConditioning& cond = *info.conditioning;
  nlohmann::json pops = nlohmann::json::array();
  for (std::size_t k = 0; k + 1 < cond.pop_samples.size(); k += 2)
    pops.push_back({cond.pop_samples[k], cond.pop_samples[k + 1]});
  row["pops"] = pops.size();
  row["pops_repaired"] = cond.repaired;
  std::string pop_joints;
  for (std::size_t j = 0; j < cond.pops.size(); ++j)
    if (cond.pops[j] > 0)
      pop_joints +=
          fmt::format("{}{} {}", pop_joints.empty() ? "" : ", ", sk.joint_names[j], cond.pops[j]);
  row["pop_joints"] = pop_joints;
  nlohmann::json garbage = nlohmann::json::array();
  std::string garbage_names;
  for (std::size_t j = 0; j < cond.garbage.size(); ++j)
    if (cond.garbage[j]) {
      garbage.push_back(j);
      garbage_names += fmt::format("{}{} ({})", garbage_names.empty() ? "" : ", ",
                                   sk.joint_names[j], to_string(cond.joints[j].joint_class));
    }
  row["garbage"] = garbage_names;
  row["garbage_count"] = garbage.size();

  // The contacts found on the clip as it came: the feet stage's, else the motion check's.
  nlohmann::json contacts = nlohmann::json::array();
  int contact_count = 0;
  const auto add_contacts = [&](const std::vector<FootChain>& legs,
                                const std::vector<std::vector<ContactInterval>>& intervals) {
    for (std::size_t leg = 0; leg < legs.size() && leg < intervals.size(); ++leg) {
      nlohmann::json list = nlohmann::json::array();
      for (const ContactInterval& c : intervals[leg]) list.push_back({c.begin, c.end});
      contact_count += int(intervals[leg].size());
      contacts.push_back({{"joint", legs[leg].ankle}, {"intervals", std::move(list)}});
    }
  };
  if (info.feet && !info.feet->legs.empty())
    add_contacts(info.feet->legs, info.feet->contacts);
  else if (info.before)
    add_contacts(info.before->feet, info.before->contacts);
  row["contacts"] = contact_count;
  row["feet_locked"] = info.feet && info.feet->locked;

  // Jitter is a second difference per frame^2 and skating a step per frame: per second, in cm.
  if (info.before && info.after) {
    row["jitter_before"] = info.before->jitter * cm * fps * fps;
    row["jitter_after"] = info.after->jitter * cm * fps * fps;
    row["skating_before"] = info.before->skating * cm * fps;
    row["skating_after"] = info.after->skating * cm * fps;
    row["contact_steps"] = info.before->contact_steps;
  }
  row["change_rms"] = capture.change_rms;
  row["change_max"] = capture.change_max;
  row["change_max_frame"] = capture.change_max_frame;
  row["change_max_joint"] =
      capture.count > 0 ? nlohmann::json(sk.joint_names[std::size_t(capture.change_max_joint)])
                        : nlohmann::json(nullptr);
  row["units"] = capture.units;
  row["has_motion"] = capture.count > 0;

  if (capture.count > 0) {
    nlohmann::json meta;
    meta["joints"] = sk.joint_names;
    meta["parents"] = sk.parents;
    meta["fps"] = fps;
    meta["frames"] = clip.frames;
    meta["stride"] = capture.stride;
    meta["count"] = capture.count;
    meta["sample_frames"] = capture.frames;
    meta["position_scale"] = capture.position_scale;
    meta["angle_scale"] = capture.angle_scale;
    meta["encoding"] = "int16 steps, byte planes, deflate";
    meta["pops"] = std::move(pops);
    meta["contacts"] = std::move(contacts);
    meta["garbage"] = std::move(garbage);
    entry.script = fmt::format("{},\"{}\");\n", script_safe(meta.dump()),
                               base64(capture.packed.data(), capture.packed.size()));
  }
  return entry;
}

void ReviewReport::add(ReviewEntry&& entry) {
  const std::size_t index = rows_.size();
  const std::string file = fmt::format("clips/{:05}.js", index);
  entry.row["i"] = index;
  entry.row["file"] = file;
  if (!entry.script.empty()) {
    const std::string text = fmt::format("mocapReviewClip({},", index) + entry.script;
    if (Status s = write_text(fs::path(folder_) / file, text); !s.ok() && first_error_.ok())
      first_error_ = s;
  }
  rows_.push_back(std::move(entry.row));
}

void ReviewReport::add(const ReviewClipInfo& info, ReviewCapture&& capture) {
  add(review_entry(info, std::move(capture)));
}

void ReviewReport::add_failure(const std::string& name, const std::string& error) {
  failed_.push_back({{"clip", name}, {"error", error}});
}

Status ReviewReport::write(const RunSummary& summary) const {
  if (!first_error_.ok()) return first_error_;
  nlohmann::json run;
  run["command"] = command_;
  run["clips"] = rows_.size();
  run["seconds"] = summary.seconds;
  run["interrupted"] = summary.interrupted;
  run["failed"] = failed_;
  if (summary.extra.contains("method")) run["method"] = summary.extra["method"];
  if (summary.extra.contains("kept")) run["kept"] = summary.extra["kept"];

  const std::string page = fill(review_page_template(),
                                {{"@RUN_JSON@", script_safe(run.dump())},
                                 {"@CLIPS_JSON@", script_safe(rows_.dump())},
                                 {"@THREE_JS@", script_safe(std::string(review_three_js()))},
                                 {"@REVIEW_JS@", script_safe(std::string(review_page_script()))}});
  return write_text(fs::path(folder_) / "index.html", page);
}

std::unique_ptr<ReviewReport> open_review_report(const std::string& folder,
                                                 const std::string& command, Status* error) {
  if (folder.empty()) return nullptr;
  if (Status s = ReviewReport::available(); !s.ok()) {
    *error = s;
    return nullptr;
  }
  auto review = std::make_unique<ReviewReport>(folder, command);
  if (Status s = review->prepare(); !s.ok()) {
    *error = s;
    return nullptr;
  }
  return review;
}

int close_review_report(const ReviewReport* review, const RunSummary& summary, int status) {
  if (!review) return status;
  if (Status s = review->write(summary); !s.ok()) {
    fmt::print(stderr, "mocap-clean: {}: review page: {}\n", summary.command, s.message());
    return 1;
  }
  fmt::print(stderr, "{}: review page: {} ({} clips)\n", summary.command,
             (fs::path(review->folder()) / "index.html").string(), review->clips());
  return status;
}

}  // namespace mocap::engine
