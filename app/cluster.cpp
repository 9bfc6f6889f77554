#include "app/cluster.hpp"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include "engine/library/summary_merge.hpp"

#ifdef MOCAP_WITH_MPI
#define OMPI_SKIP_MPICXX 1  // the C API only: the deprecated C++ bindings need another library
#include <mpi.h>
#endif

namespace mocap::engine {
namespace {

Cluster g_cluster;  // set once at start-up by cluster_init, like MPI's own world
bool g_mpi_initialised = false;

bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(name)) return true;
  return false;
}

}  // namespace

bool built_with_mpi() {
#ifdef MOCAP_WITH_MPI
  return true;
#else
  return false;
#endif
}

const Cluster& cluster() {
  return g_cluster;
}

Cluster cluster_init([[maybe_unused]] int* argc, [[maybe_unused]] char*** argv) {
#ifdef MOCAP_WITH_MPI
  if (launched_by_mpi()) {
    MPI_Init(argc, argv);
    g_mpi_initialised = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_cluster.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_cluster.size);
  }
#endif
  return g_cluster;
}

void cluster_finalize() {
#ifdef MOCAP_WITH_MPI
  if (g_mpi_initialised) MPI_Finalize();
  g_mpi_initialised = false;
#endif
}

void cluster_barrier() {
#ifdef MOCAP_WITH_MPI
  if (g_mpi_initialised) MPI_Barrier(MPI_COMM_WORLD);
#endif
}

#ifdef MOCAP_WITH_MPI
namespace {

// Each rank's `mine`, gathered on rank 0 in rank order (empty elsewhere).
std::vector<std::string> gather_text(const std::string& mine) {
  const int size = g_cluster.size;
  int length = int(mine.size());
  std::vector<int> lengths(g_cluster.rank == 0 ? size : 0), offsets(size, 0);
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::string text;
  if (g_cluster.rank == 0) {
    int total = 0;
    for (int r = 0; r < size; ++r) offsets[r] = total, total += lengths[r];
    text.resize(std::size_t(total));
  }
  MPI_Gatherv(mine.data(), length, MPI_CHAR, text.data(), lengths.data(), offsets.data(), MPI_CHAR,
              0, MPI_COMM_WORLD);
  std::vector<std::string> all;
  if (g_cluster.rank == 0)
    for (int r = 0; r < size; ++r) all.push_back(text.substr(std::size_t(offsets[r]), lengths[r]));
  return all;
}

}  // namespace
#endif

RunSummary cluster_gather(const RunSummary& local) {
#ifdef MOCAP_WITH_MPI
  if (!g_mpi_initialised || g_cluster.size == 1) return local;
  const int size = g_cluster.size;
  // Fixed-size numbers first, then the failures as "clip\terror\n" text and the tallies of the
  // --json summary (pops, garbage joints, automatic parameters) as JSON.
  double numbers[6] = {double(local.clips),  double(local.frames),
                       double(local.joints), double(local.joint_frames),
                       local.seconds,        local.interrupted ? 1.0 : 0.0};
  std::vector<double> all(g_cluster.rank == 0 ? 6 * size : 0);
  MPI_Gather(numbers, 6, MPI_DOUBLE, all.data(), 6, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  std::string failures;
  for (const auto& f : local.failed) failures += f.clip + '\t' + f.error + '\n';
  const std::vector<std::string> failures_of = gather_text(failures);
  const std::vector<std::string> extras_of = gather_text(local.extra.dump());
  if (g_cluster.rank != 0) return local;
  RunSummary total = local;
  total.clips = total.frames = total.joints = total.joint_frames = 0;
  total.seconds = 0;
  total.failed.clear();
  nlohmann::json ranks = nlohmann::json::array();
  for (int r = 0; r < size; ++r) {
    const double* n = &all[std::size_t(6 * r)];
    total.clips += std::size_t(n[0]);
    total.frames += std::size_t(n[1]);
    total.joints += std::size_t(n[2]);
    total.joint_frames += std::size_t(n[3]);
    total.seconds = std::max(total.seconds, n[4]);
    total.interrupted = total.interrupted || n[5] != 0;
    ranks.push_back({{"rank", r},
                     {"clips", std::size_t(n[0])},
                     {"joint_frames", n[3]},
                     {"seconds", n[4]},
                     {"joint_frames_per_second", n[4] > 0 ? n[3] / n[4] : 0.0}});
    const std::string& text = failures_of[std::size_t(r)];
    for (std::size_t pos = 0; pos < text.size();) {
      const std::size_t tab = text.find('\t', pos), newline = text.find('\n', tab);
      total.failed.push_back(
          {text.substr(pos, tab - pos),
           "rank " + std::to_string(r) + ": " + text.substr(tab + 1, newline - tab - 1)});
      pos = newline + 1;
    }
    if (r > 0) merge_tallies(total.extra, nlohmann::json::parse(extras_of[std::size_t(r)]));
  }
  total.extra["ranks"] = ranks;
  return total;
#else
  return local;
#endif
}

}  // namespace mocap::engine
