#pragma once
// A small SVG line-plot writer for eval's report (no plotting dependency): axes with "nice" ticks
// (linear or log10 x), axis labels, a title, polylines (solid or dashed, optional markers) and a
// legend. Non-finite points break a line rather than drawing to infinity.
#include <string>
#include <vector>

namespace mocap::engine::eval {

struct PlotSeries {
  std::string name;
  std::vector<double> x, y;
  std::string color;  // any SVG colour; empty = the palette's next
  bool dashed = false;
  bool markers = false;
  double width = 1.6;
};

struct LinePlot {
  std::string title, x_label, y_label;
  bool log_x = false;
  int width = 640, height = 380;
  std::vector<PlotSeries> series;
};

// The SVG document of `plot` (standalone, UTF-8).
std::string render_svg(const LinePlot& plot);

// `text` with &, <, > and " escaped: safe in XML and HTML text and attribute values.
std::string escape_xml(const std::string& text);

// Tick values covering [lo, hi] at a 1-2-5 step, about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target);

}  // namespace mocap::engine::eval
