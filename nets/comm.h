// The processes of a data-parallel training run: one process by default, or the ranks of an MPI job when sdfkit
// was built with MPI (Open MPI from Debian: libopenmpi-dev) and started by a launcher (`mpirun -np N`, `srun`).
//
// Training needs only a few collective operations, and every one of them is exact, so that a run gives the same
// bytes on 1 or N ranks:
//  - ordered_sum: the sum of per-item float buffers in global item order, 0 + g_0 + g_1 + ... + g_{B-1}, where each
//    rank owns a contiguous range of items. Rank r receives the running sum of ranks 0..r-1, adds its own items in
//    order and passes the result on (in segments, so that the ranks work as a pipeline); the last rank broadcasts
//    the total. Floating-point addition is not associative, and a tree or ring all-reduce would change the order
//    of the additions with the rank count; the chain keeps it.
//  - gather of per-item doubles (losses), broadcast of a flag (stop decisions) and of a float buffer.
// Without MPI (or outside a launcher) world() is a single rank and every operation is local.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace sdfkit {

class Comm {
 public:
  /// The job's communicator. The first call initialises MPI when sdfkit has MPI and a launcher's environment is
  /// present (OMPI_COMM_WORLD_SIZE, PMI_SIZE, PMIX_RANK or SLURM_STEP_NUM_TASKS > 1); MPI is finalised at exit.
  static Comm& world();

  [[nodiscard]] int rank() const { return rank_; }
  [[nodiscard]] int size() const { return size_; }
  [[nodiscard]] bool is_root() const { return rank_ == 0; }
  /// True when this build can run over MPI (independent of how it was started).
  static bool mpi_available();
  /// "MPI (Open MPI v4.1.4), 2 ranks" or "single process (built without MPI)" for logs and --help.
  [[nodiscard]] std::string describe() const;

  /// Items [begin, end) of a batch of `items` that this rank owns: contiguous, sizes differing by at most one.
  [[nodiscard]] std::pair<int, int> item_range(int items) const { return item_range(items, rank_, size_); }
  /// The same for any rank of `size` ranks.
  static std::pair<int, int> item_range(int items, int rank, int size);

  /// out[i] = 0 + g_0[i] + g_1[i] + ... over all ranks' items in global item order; `local` holds this rank's
  /// item buffers in order (n floats each). Every rank receives the same `out`. Thread-parallel over fixed
  /// segments of the buffer (the order of the additions for one element never changes). With clear_local, each
  /// local buffer is zeroed as it is read (the next step's gradients accumulate into zeros without a second pass).
  void ordered_sum(const std::vector<float*>& local, float* out, size_t n, bool clear_local = false) const;
  /// Every rank's per-item values concatenated in rank order (= global item order).
  [[nodiscard]] std::vector<double> gather(const std::vector<double>& local) const;
  /// Rank 0's value on every rank.
  [[nodiscard]] bool broadcast(bool value) const;
  /// Rank 0's buffer on every rank (n floats).
  void broadcast(float* data, size_t n) const;
  /// Wait for every rank.
  void barrier() const;
  /// After an error on one rank: end the whole MPI job (MPI_Abort) so that the other ranks do not wait forever
  /// in a collective. No-op in a single process.
  static void abort_if_distributed(int code);

 private:
  Comm() = default;
  int rank_ = 0;
  int size_ = 1;
  bool mpi_ = false;
};

}  // namespace sdfkit
