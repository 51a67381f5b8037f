#include "obsgain/numerics/distributed.hpp"

#include <cstdlib>

#ifdef OBSGAIN_WITH_MPI
#include <mpi.h>
#endif

namespace obsgain::distributed {

namespace {

bool started = false;  // MPI initialised by a Session
int world_rank = 0, world_size = 1, node_size = 1;

#ifdef OBSGAIN_WITH_MPI
// Started by an MPI launcher: OpenMPI's mpirun, or a PMI/PMIx launcher such as Slurm's srun.
bool launched_by_mpi() {
  for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (std::getenv(variable) != nullptr) return true;
  return false;
}
#endif

}  // namespace

Session::Session([[maybe_unused]] int& argc, [[maybe_unused]] char**& argv) {
#ifdef OBSGAIN_WITH_MPI
  if (!launched_by_mpi()) return;
  int provided = 0;
  // Funneled: only the thread that coordinates the searches and trials calls MPI; the worker threads compute.
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  started = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &world_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &world_size);
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, world_rank, MPI_INFO_NULL, &node);
  MPI_Comm_size(node, &node_size);
  MPI_Comm_free(&node);
#endif
}

Session::~Session() {
#ifdef OBSGAIN_WITH_MPI
  if (started) MPI_Finalize();
#endif
  started = false;
  world_rank = 0;
  world_size = node_size = 1;
}

int rank() { return world_rank; }
int size() { return world_size; }
int local_size() { return node_size; }

std::pair<int, int> slice(int count, int rank, int size) {
  const auto begin = static_cast<long long>(count) * rank / size, end = static_cast<long long>(count) * (rank + 1) / size;
  return {static_cast<int>(begin), static_cast<int>(end)};
}

void share_slices([[maybe_unused]] std::vector<double>& values, [[maybe_unused]] int count,
                  [[maybe_unused]] int width) {
#ifdef OBSGAIN_WITH_MPI
  if (world_size == 1) return;
  std::vector<int> counts(static_cast<std::size_t>(world_size)), offsets(static_cast<std::size_t>(world_size));
  for (int r = 0; r < world_size; ++r) {
    const auto [begin, end] = slice(count, r, world_size);
    counts[static_cast<std::size_t>(r)] = (end - begin) * width;
    offsets[static_cast<std::size_t>(r)] = begin * width;
  }
  MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, values.data(), counts.data(), offsets.data(), MPI_DOUBLE,
                 MPI_COMM_WORLD);
#endif
}

void abort_job(int code) {
#ifdef OBSGAIN_WITH_MPI
  if (started) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::exit(code);
}

bool any(bool flag) {
#ifdef OBSGAIN_WITH_MPI
  if (world_size == 1) return flag;
  int local = flag ? 1 : 0, global = 0;
  MPI_Allreduce(&local, &global, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return global != 0;
#else
  return flag;
#endif
}

}  // namespace obsgain::distributed
