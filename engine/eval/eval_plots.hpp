#pragma once
// eval's figures, as SVG files in the report folder:
//   fig_curve.svg, fig_speed.svg  one joint's curve and angular speed profile, noisy vs filtered
//                                 vs clean (after Courty 2008, Fig. 2): the joint that moves most
//                                 (largest RMS angle about its mid-clip pose; roots excluded), 1 s
//                                 around its fastest moment, the gaussian condition nearest 0.03
//   fig_iterations.svg            bof's MSE against iterations 1..10 for several sigma_g (after
//                                 Courty 2008, Fig. 3), same condition, all clips pooled
//   fig_psnr.svg                  PSNR gain over the noisy input against the gaussian noise
//                                 level per method, best grid point (solid) and automatic
//                                 parameters (dashed)
#include <filesystem>
#include <string>
#include <vector>

#include "engine/eval/eval_report.hpp"
#include "engine/eval/eval_run.hpp"

namespace mocap::engine::eval {

// Runs the extra filters the figures need (in parallel) and writes the SVG files into `dir`.
// Figures that the configuration cannot support (no gaussian condition, bof not evaluated) are
// left out. False, with *error, when a file cannot be written.
bool write_figures(const EvalResults& results, const EvalConfig& config,
                   const std::filesystem::path& dir, std::vector<Figure>* figures,
                   std::string* error);

}  // namespace mocap::engine::eval
