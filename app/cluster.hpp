#pragma once
// MPI, when the engine is built with it and started by mpirun: each rank runs the shard of the
// library whose index is its rank (the same cost-balanced split as --shard), on its own task
// graph; rank 0 joins the parts and reports totals. Without MPI (or outside mpirun) this is a
// single process of rank 0 and size 1.
#include <string>
#include <vector>

#include "engine/run/run_summary.hpp"

namespace mocap::engine {

struct Cluster {
  int rank = 0;
  int size = 1;
  bool active() const { return size > 1; }
};

// Initialises MPI only when the process was launched by an MPI launcher (OMPI_/PMI_/PMIX_
// environment); returns the world's rank and size.
Cluster cluster_init(int* argc, char*** argv);
void cluster_finalize();
const Cluster& cluster();
bool built_with_mpi();

void cluster_barrier();
// Rank 0 receives the totals of every rank's summary (clips, frames, failures with their rank,
// slowest rank's seconds) and each rank's throughput; other ranks get their own summary back.
RunSummary cluster_gather(const RunSummary& local);

}  // namespace mocap::engine
