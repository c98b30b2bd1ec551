// Subnormal floats (below 1.2e-38) make x86 arithmetic up to ~100x slower, and trained networks produce them
// (weights under weight decay, Adam's second moments, tiny activations): a model trained for 4k steps evaluated 4.7x
// slower than an untrained one until this was set. The networks therefore compute with flush-to-zero and
// denormals-are-zero on every thread that runs them; a value below 1.2e-38 then reads as 0, which no result of
// ours can distinguish.
#pragma once

#if defined(__x86_64__) || defined(__SSE2__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

namespace sdfkit {

/// Sets FTZ and DAZ in this thread's MXCSR (no-op on other architectures). Cheap: call it at the start of every
/// parallel task that does network arithmetic.
inline void flush_denormals_on_this_thread() {
#if defined(__x86_64__) || defined(__SSE2__)
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
}

}  // namespace sdfkit
