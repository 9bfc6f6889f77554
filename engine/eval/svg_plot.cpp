#include "engine/eval/svg_plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace mocap::engine::eval {
std::string escape_xml(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

namespace {

constexpr const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string tick_label(double v) {
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.0e}", v);
  return fmt::format("{:.6g}", v);
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool valid() const { return lo <= hi; }
};

// Ticks of a log10 axis given in log units: decades, with 2 and 5 when there are few decades.
std::vector<double> log_ticks(double lo, double hi) {
  std::vector<double> ticks;
  const bool fine = hi - lo < 2.5;
  for (int e = int(std::floor(lo)); e <= int(std::ceil(hi)); ++e)
    for (double m : {1.0, 2.0, 5.0}) {
      if (!fine && m != 1.0) continue;
      const double v = std::log10(m) + e;
      if (v >= lo - 1e-9 && v <= hi + 1e-9) ticks.push_back(v);
    }
  return ticks;
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo) || target < 1) return {lo};
  const double raw = (hi - lo) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * magnitude >= raw) {
      step = m * magnitude;
      break;
    }
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step)
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return ticks;
}

std::string render_svg(const LinePlot& plot) {
  const double left = 72, right = 190, top = 36, bottom = 52;
  const double w = plot.width, h = plot.height;
  const double x0 = left, x1 = w - right, y0 = h - bottom, y1 = top;
  auto tx = [&](double x) { return plot.log_x ? (x > 0 ? std::log10(x) : NAN) : x; };

  Range xr, yr;
  for (const PlotSeries& s : plot.series)
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
      if (std::isfinite(tx(s.x[i])) && std::isfinite(s.y[i])) {
        xr.add(tx(s.x[i]));
        yr.add(s.y[i]);
      }
  if (!xr.valid()) xr = {0, 1};
  if (!yr.valid()) yr = {0, 1};
  if (xr.hi == xr.lo) xr = {xr.lo - 1, xr.hi + 1};
  if (yr.hi == yr.lo) yr = {yr.lo - 1, yr.hi + 1};
  const double pad = 0.05 * (yr.hi - yr.lo);
  yr = {yr.lo - pad, yr.hi + pad};
  if (plot.log_x) {
    const double xpad = 0.04 * (xr.hi - xr.lo);
    xr = {xr.lo - xpad, xr.hi + xpad};
  }
  auto px = [&](double x) { return x0 + (tx(x) - xr.lo) / (xr.hi - xr.lo) * (x1 - x0); };
  auto py = [&](double y) { return y0 - (y - yr.lo) / (yr.hi - yr.lo) * (y0 - y1); };

  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" "
      "font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      plot.width, plot.height, plot.width, plot.height);
  svg += fmt::format(
      "<text x=\"{:.1f}\" y=\"22\" text-anchor=\"middle\" font-size=\"14\" "
      "font-weight=\"bold\">{}</text>\n",
      (x0 + x1) / 2, escape_xml(plot.title));

  // Grid and ticks.
  const std::vector<double> xticks =
      plot.log_x ? log_ticks(xr.lo, xr.hi) : nice_ticks(xr.lo, xr.hi, 7);
  for (double t : xticks) {
    const double x = x0 + (t - xr.lo) / (xr.hi - xr.lo) * (x1 - x0);
    if (x < x0 - 0.5 || x > x1 + 0.5) continue;
    svg += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" stroke=\"#e3e3e3\"/>\n"
        "<text x=\"{0:.1f}\" y=\"{3:.1f}\" text-anchor=\"middle\">{4}</text>\n",
        x, y0, y1, y0 + 16, tick_label(plot.log_x ? std::pow(10.0, t) : t));
  }
  for (double t : nice_ticks(yr.lo, yr.hi, 6)) {
    const double y = py(t);
    if (y > y0 + 0.5 || y < y1 - 0.5) continue;
    svg += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#e3e3e3\"/>\n"
        "<text x=\"{3:.1f}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>\n",
        x0, y, x1, x0 - 6, y + 4, tick_label(t));
  }
  svg += fmt::format(
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" "
      "stroke=\"#333\"/>\n",
      x0, y1, x1 - x0, y0 - y1);
  svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n",
                     (x0 + x1) / 2, h - 12, escape_xml(plot.x_label));
  svg += fmt::format(
      "<text x=\"16\" y=\"{0:.1f}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {0:.1f})\">"
      "{1}</text>\n",
      (y0 + y1) / 2, escape_xml(plot.y_label));

  // Series, clipped to the plot area.
  svg += fmt::format(
      "<clipPath id=\"area\"><rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" "
      "height=\"{:.1f}\"/></clipPath>\n",
      x0, y1, x1 - x0, y0 - y1);
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& s = plot.series[k];
    const std::string color = s.color.empty() ? kPalette[k % std::size(kPalette)] : s.color;
    const std::string style =
        fmt::format("fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"{}", color, s.width,
                    s.dashed ? " stroke-dasharray=\"6 4\"" : "");
    std::string points;
    auto flush = [&] {
      if (!points.empty())
        svg +=
            fmt::format("<polyline clip-path=\"url(#area)\" {} points=\"{}\"/>\n", style, points);
      points.clear();
    };
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      const double x = px(s.x[i]), y = py(s.y[i]);
      if (!std::isfinite(x) || !std::isfinite(y)) {
        flush();
        continue;
      }
      points += fmt::format("{:.1f},{:.1f} ", x, y);
      if (s.markers)
        svg +=
            fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\"/>\n", x, y, color);
    }
    flush();
    // Legend entry in the right margin.
    const double ly = y1 + 10 + 18 * double(k);
    svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" {}/>\n"
        "<text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n",
        x1 + 12, ly, x1 + 40, ly, style, x1 + 46, ly + 4, escape_xml(s.name));
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace mocap::engine::eval
