#pragma once
// What a command tells its user when a run ends: the failures, then the closing line or --json.
#include "engine/run/run_summary.hpp"

namespace mocap::engine {

// Prints the summary as JSON (stdout) or as a human line (stderr), and the failures (stderr).
void report(const RunSummary& summary, bool json);

}  // namespace mocap::engine
