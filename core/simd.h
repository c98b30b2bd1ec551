// Run-time choice of the hand-vectorised kernels (dense EMD certificate, nearest-neighbour scans, auction bids):
// AVX2 when the CPU has it, else the portable SSE2/scalar versions. Both compute the same IEEE
// operations in the same order (no fused multiply-add), so results are the same bits either way; tests switch
// AVX2 off to check exactly that.
#pragma once

namespace sdfkit {

/// True when the AVX2 kernels are in use (default: the CPU supports AVX2).
bool avx2_enabled();
/// Turn the AVX2 kernels off (false) or back on (true; stays off on a CPU without AVX2). Process-wide.
void set_avx2_enabled(bool on);

}  // namespace sdfkit
