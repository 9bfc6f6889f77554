#pragma once
// The review page of `--report DIR` (README "Review page"): DIR/index.html lists every clip of a
// run (method and parameters chosen, estimated noise, pops, garbage joints, foot contacts, jitter
// and skating before and after), and plays each clip's skeleton before and after cleaning in
// 3-D (three.js, bundled in the page). Each clip's motion goes in its own file DIR/clips/N.js,
// loaded by a <script> tag when the clip is opened (file:// allows that, not fetch), so the page
// opens fast whatever the number of clips.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "core/status.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/run/run_summary.hpp"

namespace mocap::engine {

// At most this many samples of a clip go in the page (a longer clip is decimated by a whole
// stride), and at most this rate: a 300-clip page of CMU clips stays tens of megabytes.
inline constexpr int kReviewMaxSamples = 1000;
inline constexpr double kReviewMaxRate = 60.0;  // Hz

// One clip's motion for the page, taken in the parallel stages: the clip as read (split, before
// any conditioning) and as written (finish).
struct ReviewCapture {
  std::vector<float> positions_before;  // [F][J][3] full rate, file units; freed by finish
  std::vector<std::int16_t> samples;    // pos before, pos after, angles before, angles after
  std::vector<unsigned char> packed;    // the samples as the page holds them (pack())
  int stride = 1, count = 0;            // every stride-th frame, and the frames with a pop
  std::vector<int> frames;              // the frames sampled (count), increasing
  double cm_per_unit = 1, position_scale = 1, angle_scale = 1;  // cm and degrees per step
  std::string units;                                            // the file unit guessed
  double change_rms = 0, change_max = 0;                        // cm, all frames and joints
  int change_max_frame = 0, change_max_joint = 0;
  std::vector<float> angles_before;  // [F][J][3] degrees (rotation vectors); freed by finish
};

// Split stage: the clip exactly as read.
ReviewCapture begin_review(const Clip& as_read);
// Finish stage: the clip as it will be written (after the filter and the feet); `pops` [N][2]
// (frame, joint) are the frames sampled beside the stride.
void finish_review(ReviewCapture& capture, const Clip& cleaned, std::span<const std::int32_t> pops);

// The file unit of a skeleton, guessed from its rest-pose height (a person 1.0-2.3 m tall): cm
// per unit, and its name ("m", "cm", "inch", ...; "unknown ..." scales the body to 170 cm).
double guess_cm_per_unit(double body_height, std::string* name);

struct ReviewClipInfo {
  std::string name;  // as messages name it (source path)
  const Clip* clip = nullptr;
  const ResolvedSettings* resolved = nullptr;
  const ClipConditioning* conditioning = nullptr;
  const ClipFeet* feet = nullptr;         // contacts found and locked (may be empty)
  const MotionMeasure* before = nullptr;  // may be null (no measure for this run)
  const MotionMeasure* after = nullptr;
};

// What the page keeps of one clip, built in a parallel stage so that the serial write stage only
// numbers it and writes its file.
struct ReviewEntry {
  nlohmann::json row;  // the page's row, but its number "i" and "file"
  std::string script;  // the clip file's text after "mocapReviewClip(N,"; empty: no motion
};
ReviewEntry review_entry(const ReviewClipInfo& info, ReviewCapture&& capture);

class ReviewReport {
 public:
  // `command` names the run in the page ("clean", "filter").
  ReviewReport(std::string folder, std::string command);
  // Whether this build holds three.js (scripts/setup.sh installs it before the build); the
  // page cannot draw without it, so --report is refused up front.
  static Status available();
  // Makes the folder and its clips/ folder; an error names the path.
  Status prepare();
  // Serial (the write stage, in clip order): writes the clip's file, keeps its row. A write
  // error is kept and returned by write().
  void add(ReviewEntry&& entry);
  // review_entry and add in one (serial).
  void add(const ReviewClipInfo& info, ReviewCapture&& capture);
  // A clip that failed (named on the page with its error).
  void add_failure(const std::string& name, const std::string& error);
  // index.html, once the run is over; `summary` gives the run's time and method.
  Status write(const RunSummary& summary) const;
  const std::string& folder() const { return folder_; }
  std::size_t clips() const { return rows_.size(); }

 private:
  std::string folder_, command_;
  nlohmann::json rows_ = nlohmann::json::array();
  nlohmann::json failed_ = nlohmann::json::array();
  Status first_error_;
};

// --report DIR for a command: nullptr without it; else the report, its folder made, or an error
// (three.js missing, folder not writable) to print as a usage error.
std::unique_ptr<ReviewReport> open_review_report(const std::string& folder,
                                                 const std::string& command, Status* error);
// After the run: writes the page and says where it is (stderr); returns `status`, or 1 when the
// page could not be written (the error names the file).
int close_review_report(const ReviewReport* review, const RunSummary& summary, int status);

// The files built into the program (engine/run/review_assets.cpp): the page's template and script,
// and three.js (empty when the build had none).
std::string_view review_page_template();
std::string_view review_page_script();
std::string_view review_three_js();

}  // namespace mocap::engine
