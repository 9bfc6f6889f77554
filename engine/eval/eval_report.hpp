#pragma once
// eval's outputs from its results: report.json (everything), the markdown tables (the headline
// one in the style of Dean & Lewis 2017, Table I: rows methods, columns noise conditions, each
// cell "PSNR of the best grid point / PSNR of the automatic parameters"), and index.html.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/eval/eval_run.hpp"

namespace mocap::engine::eval {

struct Figure {
  std::string file;  // relative to the report folder ("fig_curve.svg")
  std::string caption;
};

// The headline table (PSNR best / auto) only: what eval prints on stdout.
std::string psnr_table(const EvalResults& results, const EvalConfig& config);
// All tables: PSNR, RMSE, end effectors, foot skating, angular speed, the best parameters.
std::string markdown_report(const EvalResults& results, const EvalConfig& config);

nlohmann::json report_json(const EvalResults& results, const EvalConfig& config);

// A self-contained page: the tables as HTML and the figures as <img src="...svg">.
std::string html_report(const EvalResults& results, const EvalConfig& config,
                        const std::vector<Figure>& figures, const std::string& command_line);

}  // namespace mocap::engine::eval
