#include "nets/comm.h"

#include "core/error.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdlib>
#include <limits>

#ifdef SDFKIT_HAVE_MPI
#include <mpi.h>
#endif

namespace sdfkit {
namespace {

// Elements per thread task of the additions, and per message of the rank chain (4 MB: large enough to stream,
// small enough that the next rank starts early).
constexpr size_t kAddBlock = size_t(1) << 14;
constexpr size_t kSegment = size_t(1) << 20;

bool launched_by_mpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (const char* v = std::getenv(var); v != nullptr && *v != '\0') return true;
  return false;
}

// out[i] = (start[i], or 0 without start) + g_0[i] + g_1[i] + ... for i in [0, n), in parallel over fixed blocks;
// each g_k[i] is zeroed after it is read when clear is set.
void add_in_order(const std::vector<float*>& items, size_t offset, const float* start, float* out, size_t n,
                  bool clear) {
  const size_t blocks = (n + kAddBlock - 1) / kAddBlock;
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    const size_t i0 = b * kAddBlock, i1 = std::min(n, i0 + kAddBlock);
    float* o = out + i0;
    const size_t len = i1 - i0;
    if (start)
      std::copy(start + i0, start + i1, o);
    else
      std::fill(o, o + len, 0.0f);
    for (float* item : items) {
      float* g = item + offset + i0;
      for (size_t i = 0; i < len; ++i) o[i] += g[i];
      if (clear) std::fill(g, g + len, 0.0f);
    }
  });
}

#ifdef SDFKIT_HAVE_MPI
void check_mpi(int code, const char* what) {
  if (code != MPI_SUCCESS) throw Error(std::string("MPI: ") + what + " failed (error " + std::to_string(code) + ")");
}
int as_count(size_t n) {
  require(n <= static_cast<size_t>(std::numeric_limits<int>::max()), "MPI: message too large");
  return static_cast<int>(n);
}
#endif

}  // namespace

bool Comm::mpi_available() {
#ifdef SDFKIT_HAVE_MPI
  return true;
#else
  return false;
#endif
}

Comm& Comm::world() {
  static Comm* comm = [] {
    auto* c = new Comm();
#ifdef SDFKIT_HAVE_MPI
    if (launched_by_mpi()) {
      int provided = 0;
      check_mpi(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
      MPI_Comm_rank(MPI_COMM_WORLD, &c->rank_);
      MPI_Comm_size(MPI_COMM_WORLD, &c->size_);
      c->mpi_ = true;
      std::atexit([] {
        int finalized = 0;
        MPI_Finalized(&finalized);
        if (!finalized) MPI_Finalize();
      });
    }
#else
    if (launched_by_mpi())
      throw InvalidInput("this sdfkit was built without MPI, but it was started by an MPI launcher: install "
                         "libopenmpi-dev and rebuild (scripts/build), or run it without mpirun");
#endif
    return c;
  }();
  return *comm;
}

void Comm::abort_if_distributed(int code) {
#ifdef SDFKIT_HAVE_MPI
  int initialized = 0, finalized = 0, size = 1;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) return;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1) MPI_Abort(MPI_COMM_WORLD, code);
#else
  (void)code;
#endif
}

std::string Comm::describe() const {
  if (!mpi_) return mpi_available() ? "single process" : "single process (built without MPI)";
  return "MPI, " + std::to_string(size_) + (size_ == 1 ? " rank" : " ranks");
}

std::pair<int, int> Comm::item_range(int items, int rank, int size) {
  require(size > 0 && rank >= 0 && rank < size && items >= 0, "Comm::item_range: bad rank or size");
  const auto at = [&](int r) { return static_cast<int>(static_cast<int64_t>(items) * r / size); };
  return {at(rank), at(rank + 1)};
}

void Comm::ordered_sum(const std::vector<float*>& local, float* out, size_t n, bool clear_local) const {
  if (!mpi_ || size_ == 1) {
    add_in_order(local, 0, nullptr, out, n, clear_local);
    return;
  }
#ifdef SDFKIT_HAVE_MPI
  // The rank chain, one segment at a time: receive the running sum of the ranks before, add this rank's items,
  // pass it on. The last rank then holds the total and broadcasts it.
  for (size_t s0 = 0; s0 < n; s0 += kSegment) {
    const size_t len = std::min(kSegment, n - s0);
    if (rank_ > 0)
      check_mpi(MPI_Recv(out + s0, as_count(len), MPI_FLOAT, rank_ - 1, 17, MPI_COMM_WORLD, MPI_STATUS_IGNORE),
                "MPI_Recv");
    add_in_order(local, s0, rank_ > 0 ? out + s0 : nullptr, out + s0, len, clear_local);
    if (rank_ + 1 < size_)
      check_mpi(MPI_Send(out + s0, as_count(len), MPI_FLOAT, rank_ + 1, 17, MPI_COMM_WORLD), "MPI_Send");
  }
  for (size_t s0 = 0; s0 < n; s0 += kSegment)
    check_mpi(MPI_Bcast(out + s0, as_count(std::min(kSegment, n - s0)), MPI_FLOAT, size_ - 1, MPI_COMM_WORLD),
              "MPI_Bcast");
#endif
}

std::vector<double> Comm::gather(const std::vector<double>& local) const {
  if (!mpi_ || size_ == 1) return local;
  std::vector<double> all;
#ifdef SDFKIT_HAVE_MPI
  const int mine = as_count(local.size());
  std::vector<int> counts(static_cast<size_t>(size_)), offsets(static_cast<size_t>(size_));
  check_mpi(MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Allgather");
  int total = 0;
  for (int r = 0; r < size_; ++r) {
    offsets[static_cast<size_t>(r)] = total;
    total += counts[static_cast<size_t>(r)];
  }
  all.resize(static_cast<size_t>(total));
  check_mpi(MPI_Allgatherv(local.data(), mine, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE,
                           MPI_COMM_WORLD),
            "MPI_Allgatherv");
#endif
  return all;
}

bool Comm::broadcast(bool value) const {
  if (!mpi_ || size_ == 1) return value;
#ifdef SDFKIT_HAVE_MPI
  int v = value ? 1 : 0;
  check_mpi(MPI_Bcast(&v, 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Bcast");
  return v != 0;
#else
  return value;
#endif
}

void Comm::broadcast(float* data, size_t n) const {
  if (!mpi_ || size_ == 1) return;
#ifdef SDFKIT_HAVE_MPI
  for (size_t s0 = 0; s0 < n; s0 += kSegment)
    check_mpi(MPI_Bcast(data + s0, as_count(std::min(kSegment, n - s0)), MPI_FLOAT, 0, MPI_COMM_WORLD), "MPI_Bcast");
#else
  (void)data;
#endif
}

void Comm::barrier() const {
#ifdef SDFKIT_HAVE_MPI
  if (mpi_ && size_ > 1) check_mpi(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");
#endif
}

}  // namespace sdfkit
